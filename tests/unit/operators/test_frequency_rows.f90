!> Tests src/operators/frequency_rows.f90 and frequency_rows.c.
!> CTest: test_frequency_rows_np1 and test_frequency_rows_np2.
!> The chunk product, both as the processor runs it (its clone: AVX2/FMA where the processor has
!> them) and compiled for the default target, against the plain matrix product w = K z with the
!> symmetric K written out in full from the packed triangle, entry by entry (the definition, no
!> packing or vector order shared with the code under test): random kernels and columns, signed
!> entries (the mirror classes' factors), a companion's subset of the entries (kernel_map), 16 and
!> 6 unknowns per bead, to 1e-13 of the largest |w|. The kernel's re-layout by rows
!> (rows_frequencies_innermost) against the (entry, frequency) layout it comes from, exactly,
!> with row lengths that are and are not multiples of the chunk.
program test_frequency_rows
  use, intrinsic :: iso_c_binding, only: C_INT
  use beadmob_kinds, only: dp, i8
  use beadmob_testing
  use beadmob_frequency_rows, only: row_chunk, row_stride_of, rows_frequencies_innermost, chunk_product, &
                                    chunk_product_default
  implicit none
  type(test_suite_t) :: suite

  suite = start_tests('test_frequency_rows')
  call check_equal(suite, row_stride_of(8), 8, 'row_stride_of(8)')
  call check_equal(suite, row_stride_of(13), 16, 'row_stride_of(13)')
  call check_equal(suite, row_stride_of(126), 128, 'row_stride_of(126)')
  call check_layout(5, 3)
  call check_layout(8, 2)
  call check_layout(13, 4)
  call check_products(16, 16, 13)
  call check_products(16, 16, 8)
  call check_products(6, 16, 22)   ! a companion of 6 unknowns reading its parent's entries
  call check_products(6, 6, 5)
  call finish_tests(suite)

contains

  !> rows_frequencies_innermost on `rows` rows of `row_length` frequencies of 10 entries.
  subroutine check_layout(row_length, rows)
    integer, intent(in) :: row_length, rows
    integer, parameter :: entries = 10
    real(dp), allocatable :: kernel(:, :), original(:, :), flat(:)
    integer :: stride, r, k, e
    integer(i8) :: at
    logical :: same
    stride = row_stride_of(row_length)
    allocate (kernel(entries, rows * stride))
    kernel = -1
    call random_number(kernel(:, 1:rows * row_length))
    original = kernel(:, 1:rows * row_length)
    call rows_frequencies_innermost(size(kernel, kind=i8), kernel, entries, int(rows, i8), row_length, stride)
    flat = reshape(kernel, [size(kernel)])   ! row r's (frequency k, entry e) expected at number at + 1
    same = .true.
    do r = 1, rows
      do e = 1, entries
        do k = 1, stride
          at = int(r - 1, i8) * entries * stride + int(e - 1, i8) * stride + k - 1
          if (k <= row_length) then
            same = same .and. flat(at + 1) == original(e, (r - 1) * row_length + k)
          else
            same = same .and. flat(at + 1) == 0
          end if
        end do
      end do
    end do
    call check(suite, same, 'rows_frequencies_innermost: ' // trim(str_pair(row_length, rows)) // &
               ' every number in its place, the padding zero')
  end subroutine check_layout

  !> The chunk product of nb unknowns reading a kernel of parent_nb unknowns' packed entries
  !> (through a map that embeds the nb slots among the parent's), the row of `row_length`
  !> frequencies, at every chunk of the row.
  subroutine check_products(nb, parent_nb, row_length)
    integer, intent(in) :: nb, parent_nb, row_length
    integer :: stride, n_parent, n_packed, s, t, e, k, c, offset, slot(nb)
    integer(C_INT), allocatable :: entry(:)
    real(dp), allocatable :: kernel(:, :), factor(:), full(:, :), z(:, :, :), w(:, :, :), w_default(:, :, :)
    real(dp) :: reference(nb), worst, worst_default, largest, draw
    stride = row_stride_of(row_length)
    n_parent = parent_nb * (parent_nb + 1) / 2
    n_packed = nb * (nb + 1) / 2
    ! The kernel row as stored: (frequency padded to stride, parent entry).
    allocate (kernel(stride, n_parent))
    kernel = 0
    call random_number(kernel(1:row_length, :))
    kernel(1:row_length, :) = kernel(1:row_length, :) - 0.5_dp
    ! nb slots among the parent's, every other from the last (a companion's subset)
    do s = 1, nb
      slot(s) = parent_nb - 2 * (nb - s) * merge(1, 0, 2 * nb <= parent_nb)
    end do
    allocate (entry(n_packed), factor(n_packed))
    do t = 1, nb
      do s = 1, t
        e = s + t * (t - 1) / 2
        entry(e) = slot(s) + slot(t) * (slot(t) - 1) / 2 - 1
        call random_number(draw)
        factor(e) = merge(1.0_dp, -1.0_dp, draw < 0.5_dp)
      end do
    end do
    allocate (z(row_chunk, 2, nb), w(row_chunk, 2, nb), w_default(row_chunk, 2, nb), full(nb, nb))
    worst = 0
    worst_default = 0
    largest = 0
    do offset = 0, row_length - 1, row_chunk
      call random_number(z)
      z = z - 0.5_dp
      call chunk_product(nb, stride, kernel(offset + 1:, 1), entry, factor, z, w)
      call chunk_product_default(nb, stride, kernel(offset + 1:, 1), entry, factor, z, w_default)
      do k = 1, min(row_chunk, row_length - offset)
        ! K at this frequency, both triangles from the packed upper one
        do t = 1, nb
          do s = 1, t
            e = s + t * (t - 1) / 2
            full(s, t) = factor(e) * kernel(offset + k, entry(e) + 1)
            full(t, s) = full(s, t)
          end do
        end do
        do c = 1, 2
          reference = matmul(full, z(k, c, :))
          largest = max(largest, maxval(abs(reference)))
          worst = max(worst, maxval(abs(w(k, c, :) - reference)))
          worst_default = max(worst_default, maxval(abs(w_default(k, c, :) - reference)))
        end do
      end do
    end do
    call check(suite, worst <= 1e-13_dp * largest, 'chunk_product ' // trim(str_pair(nb, row_length)) // &
               ': largest difference from K z over max |K z| ' // trim(ratio(worst, largest)))
    call check(suite, worst_default <= 1e-13_dp * largest, 'chunk_product_default ' // trim(str_pair(nb, row_length)) &
               // ': largest difference from K z over max |K z| ' // trim(ratio(worst_default, largest)))
  end subroutine check_products

  function str_pair(a, b) result(text)
    integer, intent(in) :: a, b
    character(len=40) :: text
    write (text, '(i0, " x ", i0)') a, b
  end function str_pair

  function ratio(a, b) result(text)
    real(dp), intent(in) :: a, b
    character(len=20) :: text
    write (text, '(es10.2)') a / max(b, tiny(1.0_dp))
  end function ratio
end program test_frequency_rows
