!> The FFT operator's kernel by rows of frequencies and its product on a chunk of a row
!> (frequency_rows.c; docs/theory.md T4, "The frequency product in real arithmetic"). A row is
!> the n_fast / 2 + 1 frequencies of one (middle line, k_slow), consecutive in the kernel. Each
!> row is kept as (frequency, packed entry), its frequencies padded with zeros to row_stride, a
!> multiple of row_chunk: one packed entry of a chunk of row_chunk frequencies is then a
!> contiguous vector, and the product runs as vector operations over the frequencies.
module beadmob_frequency_rows
  use, intrinsic :: iso_c_binding, only: C_INT, C_DOUBLE
  use beadmob_kinds, only: dp, i8
  implicit none
  private
  public :: row_chunk, row_stride_of, rows_frequencies_innermost, chunk_product, chunk_product_default

  !> Frequencies of one chunk product (ROW_CHUNK of frequency_rows.c)
  integer, parameter :: row_chunk = 8

  interface
    !> w(:, c, s) = sum_t K'(s, t) z(:, c, t) at the row_chunk frequencies of a chunk, c = 1, 2;
    !> K'(s, t) = factor(e) kernel(entry(e) row_stride + 1 :) for packed entry e of (s, t).
    subroutine chunk_product(nb, row_stride, kernel, entry, factor, z, w) bind(C, name='beadmob_chunk_product')
      import :: C_INT, C_DOUBLE
      integer(C_INT), value :: nb, row_stride
      real(C_DOUBLE), intent(in) :: kernel(*)       ! the chunk's first frequency of packed entry 0
      integer(C_INT), intent(in) :: entry(*)        ! 0-based packed entry of the kernel read for e
      real(C_DOUBLE), intent(in) :: factor(*)       ! sign of packed entry e
      real(C_DOUBLE), intent(in) :: z(*)            ! (row_chunk, 2, nb)
      real(C_DOUBLE), intent(out) :: w(*)           ! (row_chunk, 2, nb)
    end subroutine chunk_product
    !> chunk_product compiled for the build's default target only (what a processor without
    !> AVX2 runs; the tests check it on every machine)
    subroutine chunk_product_default(nb, row_stride, kernel, entry, factor, z, w) &
      bind(C, name='beadmob_chunk_product_default')
      import :: C_INT, C_DOUBLE
      integer(C_INT), value :: nb, row_stride
      real(C_DOUBLE), intent(in) :: kernel(*), factor(*), z(*)
      integer(C_INT), intent(in) :: entry(*)
      real(C_DOUBLE), intent(out) :: w(*)
    end subroutine chunk_product_default
  end interface

contains

  !> Frequencies of a stored row: row_length rounded up to a multiple of row_chunk.
  pure integer function row_stride_of(row_length)
    integer, intent(in) :: row_length
    row_stride_of = row_chunk * ((row_length + row_chunk - 1) / row_chunk)
  end function row_stride_of

  !> kernel(:, 1 : rows row_length) as the kernel's transform left it, (packed entry, frequency),
  !> re-laid in place row by row as (frequency padded to row_stride, packed entry): row r then
  !> fills the numbers (r - 1) entries row_stride + 1 ... r entries row_stride of the storage.
  !> The rows are moved from the last, whose new place lies behind every row's old one.
  subroutine rows_frequencies_innermost(total, storage, entries, rows, row_length, row_stride)
    integer(i8), intent(in) :: total, rows   ! total >= rows entries row_stride
    real(dp), intent(inout) :: storage(total)
    integer, intent(in) :: entries, row_length, row_stride
    real(dp), allocatable :: row(:, :)
    integer(i8) :: r, from, to
    allocate (row(row_stride, entries))
    row = 0
    do r = rows, 1, -1
      from = (r - 1) * entries * row_length
      to = (r - 1) * entries * row_stride
      row(1:row_length, :) = transpose(reshape(storage(from + 1:from + entries * row_length), [entries, row_length]))
      storage(to + 1:to + entries * row_stride) = reshape(row, [entries * row_stride])
    end do
  end subroutine rows_frequencies_innermost
end module beadmob_frequency_rows
