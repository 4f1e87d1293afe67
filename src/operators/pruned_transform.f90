!> The 3-D FFT of the FFT operator's bead fields, pruned to where beads can be (theory.md T4,
!> "Pruned transforms"). The beads lie in the data box [0, s_a) of the padded box [0, n_a)
!> (n_a >= 2 s_a - 1 per axis), about an eighth of it, and a product needs its result on the data
!> box only. A 3-D transform is three passes of 1-D transforms. Forward, only the fast-axis lines
!> through the data box carry anything (about a quarter of them), only the middle-axis lines of
!> the data planes (a half), and the global transpose before the slow axis moves the data planes
!> only (half the volume); the slow-axis pass is whole. The inverse mirrors it: the slow axis in
!> full, the data planes transposed back, the middle axis on them and the fast axis on the data
!> rows. About 0.58 of the flops and half the transpose traffic of the whole transform, and the
!> same spectrum, given one middle line at a time: FFTW's r2c layout with FFTW_MPI_TRANSPOSED_OUT,
!> [lines][n_slow][n_fast/2 + 1][fields] in C order with the middle-axis lines split over the ranks
!> (FFTW-MPI's transposed layout), where the kernel (kernel_spectrum.f90) multiplies it frequency
!> by frequency.
!>
!> The slow axis runs one middle line at a time (forward_line, backward_line): the line's data
!> planes are transposed into a scratch where each slow-axis line is contiguous (FFTW's estimated
!> plans for lines strided across the row cost up to 3.5 times its measured ones, those for
!> contiguous lines no more: bench/fft_layout), transformed, and the line's spectrum written
!> beside it, where the caller multiplies it by the kernel while it is in cache, before the way
!> back. So the whole spectrum is never stored.
!>
!> Memory: one aligned buffer, and a scratch and a spectrum of one middle line. The transposed
!> data planes ([lines][data planes][n_fast/2 + 1][fields]) start at the buffer's beginning; the
!> real data planes ([planes][n_middle][2 (n_fast/2 + 1)][fields], FFTW's in-place r2c padding, the
!> planes split over the ranks in FFTW's default blocks) sit behind the region the transposes
!> write, so no transpose reads and writes the same memory.
module beadmob_pruned_transform
  use, intrinsic :: iso_c_binding
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_fftw
  use mpi, only: MPI_Allreduce, MPI_IN_PLACE, MPI_INTEGER, MPI_SUM
  implicit none
  private
  public :: pruned_transform_t, size_pruned_transform, make_pruned_plans, free_pruned_plans, forward_planes, &
            forward_line, backward_line, backward_planes, destroy_pruned_transform

  type :: pruned_transform_t
    integer :: fields = 0
    integer :: box(3) = 1                  ! padded sizes of the fast, middle and slow axis
    integer :: data(3) = 1                 ! sites 0 .. data - 1 of each axis can hold a bead
    integer :: half = 1                    ! complex numbers of a fast-axis line: box(1) / 2 + 1
    !> This rank's data planes (slow axis) and spectrum lines (middle axis)
    integer(C_INTPTR_T) :: planes = 0, first_plane = 0, lines = 0, first_line = 0
    integer(i8) :: n_frequencies = 0       ! this rank's: lines * n_slow * half
    type(C_PTR) :: buffer = C_NULL_PTR, line_buffer = C_NULL_PTR
    !> The data planes (real) and the transposed data planes ([lines][data planes][row])
    real(C_DOUBLE), pointer, contiguous :: slab(:) => null()
    real(C_DOUBLE), pointer, contiguous :: all(:) => null()   ! the whole buffer
    complex(C_DOUBLE_COMPLEX), pointer, contiguous :: transposed(:, :, :) => null()
    !> One middle line: its slow-axis lines, each contiguous (k_slow, row number), and its
    !> spectrum (field, 1 + k_fast + half k_slow)
    complex(C_DOUBLE_COMPLEX), pointer, contiguous :: scratch(:, :) => null()
    complex(C_DOUBLE_COMPLEX), pointer, contiguous :: spectrum(:, :) => null()
    complex(C_DOUBLE_COMPLEX), pointer, contiguous :: flat_spectrum(:) => null()   ! the same, 0-based
    !> fast r2c, middle forward, transpose, slow forward, slow backward (on the scratch),
    !> transpose back, middle backward, fast c2r
    type(C_PTR) :: plans(8) = C_NULL_PTR
    integer(i8) :: slab_offset = 0         ! doubles before the data planes in the buffer
  end type pruned_transform_t

  integer, parameter :: fast_forward = 1, middle_forward = 2, transpose_forward = 3, slow_forward = 4, &
                        slow_backward = 5, transpose_backward = 6, middle_backward = 7, fast_backward = 8

contains

  !> Collective. Sizes, slabs and the buffer of `fields` fields on the padded box `box` (fast,
  !> middle, slow) with beads on the data box `data`; no plans yet (make_pruned_plans).
  subroutine size_pruned_transform(comm, fields, box, data, t, err)
    integer, intent(in) :: comm, fields, box(3), data(3)
    type(pruned_transform_t), intent(inout) :: t
    type(error_t), intent(inout) :: err
    integer(C_INTPTR_T) :: row, forward_alloc, backward_alloc, back_lines(2), back_planes(2)
    integer(i8) :: compact, doubles, scratch_size, line_size
    real(C_DOUBLE), pointer, contiguous :: line_doubles(:)

    t%fields = fields
    t%box = box
    t%data = min(data, box)
    t%half = box(1) / 2 + 1
    row = int(t%half, C_INTPTR_T) * fields   ! complex numbers of one (plane, middle index)
    ! The transposes of the data planes: (data planes x middle) <-> (middle x data planes).
    forward_alloc = fftw_mpi_local_size_many_transposed(2, [int(t%data(3), C_INTPTR_T), int(box(2), C_INTPTR_T)], &
                                                        2 * row, FFTW_MPI_DEFAULT_BLOCK, FFTW_MPI_DEFAULT_BLOCK, &
                                                        int(comm, C_INT32_T), t%planes, t%first_plane, t%lines, t%first_line)
    backward_alloc = fftw_mpi_local_size_many_transposed(2, [int(box(2), C_INTPTR_T), int(t%data(3), C_INTPTR_T)], &
                                                         2 * row, FFTW_MPI_DEFAULT_BLOCK, FFTW_MPI_DEFAULT_BLOCK, &
                                                         int(comm, C_INT32_T), back_lines(1), back_lines(2), &
                                                         back_planes(1), back_planes(2))
    if (any(back_lines /= [t%lines, t%first_line]) .or. any(back_planes /= [t%planes, t%first_plane])) then
      call raise(err, 'internal error: the backward transpose of the pruned FFT splits the data otherwise')
      return
    end if
    t%n_frequencies = int(t%lines, i8) * box(3) * t%half
    ! Doubles: the transposed data planes (and the scratch FFTW's transposes may use) first, the
    ! data planes behind them (32-byte aligned).
    compact = max(int(forward_alloc, i8), int(backward_alloc, i8), 2 * int(t%lines, i8) * t%data(3) * row)
    t%slab_offset = 4 * ((compact + 3) / 4)
    doubles = t%slab_offset + max(int(forward_alloc, i8), int(backward_alloc, i8), 2 * int(t%planes, i8) * box(2) * row, &
                                  1_i8)
    t%buffer = fftw_alloc_real(int(doubles, C_SIZE_T))
    scratch_size = 2 * int(line_stride(box(3)), i8) * row   ! doubles of the scratch
    line_size = 2 * int(box(3), i8) * row                  ! and of the spectrum
    t%line_buffer = fftw_alloc_real(int(scratch_size + line_size, C_SIZE_T))
    if (.not. c_associated(t%buffer) .or. .not. c_associated(t%line_buffer)) then
      call raise(err, 'could not allocate the FFT buffer (' // str(8.0_dp * (doubles + scratch_size + line_size) / &
                                                                   1.0e9_dp) // ' GB)')
      return
    end if
    call c_f_pointer(t%buffer, t%all, [doubles])
    t%slab => t%all(t%slab_offset + 1:t%slab_offset + 2 * int(t%planes, i8) * box(2) * row)
    call c_f_pointer(t%buffer, t%transposed, [row, int(t%data(3), i8), int(t%lines, i8)])
    call c_f_pointer(t%line_buffer, t%scratch, [int(line_stride(box(3)), i8), row])
    call c_f_pointer(t%line_buffer, line_doubles, [scratch_size + line_size])
    call c_f_pointer(c_loc(line_doubles(scratch_size + 1)), t%spectrum, [int(fields, i8), int(box(3), i8) * t%half])
    call c_f_pointer(c_loc(line_doubles(scratch_size + 1)), t%flat_spectrum, [line_size / 2])
    t%flat_spectrum(0:) => t%flat_spectrum
  end subroutine size_pruned_transform

  !> Collective. The eight plans of the pruned transform with `flags`; made = every plan on every
  !> rank (otherwise none is kept: with FFTW_WISDOM_ONLY the caller plans again without it).
  !> Planning may overwrite the buffer.
  subroutine make_pruned_plans(comm, t, flags, made)
    integer, intent(in) :: comm
    type(pruned_transform_t), intent(inout) :: t
    integer(C_INT), intent(in) :: flags
    logical, intent(out) :: made
    type(fftw_iodim) :: line(1), rows(3), planes(2)
    type(C_PTR) :: slab, start
    integer :: f, row, missing, ierr

    f = t%fields
    row = t%half * f
    slab = c_loc(t%all(t%slab_offset + 1))
    start = t%buffer
    missing = 0
    if (t%planes > 0) then
      ! Fast axis, the data rows of each data plane: real stride f, complex stride f.
      line(1) = fftw_iodim(t%box(1), f, f)
      rows(1) = fftw_iodim(f, 1, 1)
      rows(2) = fftw_iodim(t%data(2), 2 * row, row)
      rows(3) = fftw_iodim(int(t%planes), 2 * row * t%box(2), row * t%box(2))
      t%plans(fast_forward) = fftw_plan_guru_dft_r2c(1, line, 3, rows, slab, slab, flags)
      rows(2) = fftw_iodim(t%data(2), row, 2 * row)
      rows(3) = fftw_iodim(int(t%planes), row * t%box(2), 2 * row * t%box(2))
      line(1) = fftw_iodim(t%box(1), f, f)
      t%plans(fast_backward) = fftw_plan_guru_dft_c2r(1, line, 3, rows, slab, slab, flags)
      ! Middle axis, every column of each data plane (complex).
      line(1) = fftw_iodim(t%box(2), row, row)
      planes(1) = fftw_iodim(row, 1, 1)
      planes(2) = fftw_iodim(int(t%planes), row * t%box(2), row * t%box(2))
      t%plans(middle_forward) = fftw_plan_guru_dft(1, line, 2, planes, slab, slab, FFTW_FORWARD, flags)
      t%plans(middle_backward) = fftw_plan_guru_dft(1, line, 2, planes, slab, slab, FFTW_BACKWARD, flags)
      missing = missing + count(.not. c_associated_all([t%plans(fast_forward), t%plans(fast_backward), &
                                                         t%plans(middle_forward), t%plans(middle_backward)]))
    end if
    if (t%lines > 0) then
      ! Slow axis, whole, on the scratch's contiguous lines of one middle line (complex).
      line(1) = fftw_iodim(t%box(3), 1, 1)
      planes(1) = fftw_iodim(row, line_stride(t%box(3)), line_stride(t%box(3)))
      t%plans(slow_forward) = fftw_plan_guru_dft(1, line, 1, planes(1:1), t%line_buffer, t%line_buffer, FFTW_FORWARD, &
                                                 flags)
      t%plans(slow_backward) = fftw_plan_guru_dft(1, line, 1, planes(1:1), t%line_buffer, t%line_buffer, &
                                                  FFTW_BACKWARD, flags)
      missing = missing + count(.not. c_associated_all([t%plans(slow_forward), t%plans(slow_backward)]))
    end if
    ! Collective: the transposes of the data planes (row = 2 row doubles per element).
    t%plans(transpose_forward) = fftw_mpi_plan_many_transpose(int(t%data(3), C_INTPTR_T), int(t%box(2), C_INTPTR_T), &
                                                              int(2 * row, C_INTPTR_T), FFTW_MPI_DEFAULT_BLOCK, &
                                                              FFTW_MPI_DEFAULT_BLOCK, slab, start, &
                                                              int(comm, C_INT32_T), flags)
    t%plans(transpose_backward) = fftw_mpi_plan_many_transpose(int(t%box(2), C_INTPTR_T), int(t%data(3), C_INTPTR_T), &
                                                               int(2 * row, C_INTPTR_T), FFTW_MPI_DEFAULT_BLOCK, &
                                                               FFTW_MPI_DEFAULT_BLOCK, start, slab, &
                                                               int(comm, C_INT32_T), flags)
    missing = missing + count(.not. c_associated_all([t%plans(transpose_forward), t%plans(transpose_backward)]))
    call MPI_Allreduce(MPI_IN_PLACE, missing, 1, MPI_INTEGER, MPI_SUM, comm, ierr)
    made = missing == 0
    if (.not. made) call free_pruned_plans(t)
  end subroutine make_pruned_plans

  pure function c_associated_all(pointers) result(associated_each)
    type(C_PTR), intent(in) :: pointers(:)
    logical :: associated_each(size(pointers))
    integer :: k
    do k = 1, size(pointers)
      associated_each(k) = c_associated(pointers(k))
    end do
  end function c_associated_all

  !> The data planes (t%slab, zero off the beads) -> the transposed data planes, transformed
  !> along the fast and the middle axis; the data planes are overwritten. The slow axis follows
  !> line by line (forward_line).
  subroutine forward_planes(t)
    type(pruned_transform_t), intent(inout) :: t
    if (t%planes > 0) then
      call fftw_execute(t%plans(fast_forward))
      call fftw_execute(t%plans(middle_forward))
    end if
    call fftw_execute(t%plans(transpose_forward))
  end subroutine forward_planes

  !> Middle line `line` (1 .. t%lines) of the transposed data planes -> its spectrum (t%spectrum),
  !> through the scratch: each row number's slow-axis line contiguous, zero beyond the data planes.
  subroutine forward_line(t, line)
    type(pruned_transform_t), intent(inout) :: t
    integer, intent(in) :: line
    integer :: plane, slow, row
    row = t%half * t%fields
    do plane = 1, t%data(3)
      t%scratch(plane, :) = t%transposed(:, plane, line)
    end do
    t%scratch(t%data(3) + 1:t%box(3), :) = (0.0_C_DOUBLE, 0.0_C_DOUBLE)
    call fftw_execute(t%plans(slow_forward))
    do slow = 0, t%box(3) - 1
      t%flat_spectrum(slow * row:(slow + 1) * row - 1) = t%scratch(slow + 1, :)
    end do
  end subroutine forward_line

  !> The spectrum of middle line `line` (t%spectrum, overwritten) -> the line's transposed data
  !> planes.
  subroutine backward_line(t, line)
    type(pruned_transform_t), intent(inout) :: t
    integer, intent(in) :: line
    integer :: plane, slow, row
    row = t%half * t%fields
    do slow = 0, t%box(3) - 1
      t%scratch(slow + 1, :) = t%flat_spectrum(slow * row:(slow + 1) * row - 1)
    end do
    call fftw_execute(t%plans(slow_backward))
    do plane = 1, t%data(3)
      t%transposed(:, plane, line) = t%scratch(plane, :)
    end do
  end subroutine backward_line

  !> The transposed data planes of every line (backward_line) -> the data planes (t%slab), on the
  !> data rows of each data plane (the other rows hold whatever the middle-axis pass left).
  subroutine backward_planes(t)
    type(pruned_transform_t), intent(inout) :: t
    call fftw_execute(t%plans(transpose_backward))
    if (t%planes > 0) then
      call fftw_execute(t%plans(middle_backward))
      call fftw_execute(t%plans(fast_backward))
    end if
  end subroutine backward_planes

  subroutine free_pruned_plans(t)
    type(pruned_transform_t), intent(inout) :: t
    integer :: k
    do k = 1, size(t%plans)
      if (c_associated(t%plans(k))) call fftw_destroy_plan(t%plans(k))
      t%plans(k) = C_NULL_PTR
    end do
  end subroutine free_pruned_plans

  subroutine destroy_pruned_transform(t)
    type(pruned_transform_t), intent(inout) :: t
    call free_pruned_plans(t)
    if (c_associated(t%buffer)) call fftw_free(t%buffer)
    if (c_associated(t%line_buffer)) call fftw_free(t%line_buffer)
    t%buffer = C_NULL_PTR
    t%line_buffer = C_NULL_PTR
    t%slab => null()
    t%all => null()
    t%transposed => null()
    t%scratch => null()
    t%spectrum => null()
    t%flat_spectrum => null()
  end subroutine destroy_pruned_transform

end module beadmob_pruned_transform
