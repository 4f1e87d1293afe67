!> The FFT operator's transforms for fields of one mirror-parity class (theory.md T4, "Mirror
!> classes"). When the bead set is symmetric under the mirrors of the fast and the middle FFT
!> axis, a field x of class (s_f, s_m) obeys x_i(M_a r) = s_a D_a(i) x_i(r): each field is even
!> or odd about the bead set's centre along both axes. The DFT of such a line is a cosine
!> transform (even) or -i times a sine transform (odd) of its half, so the 3-D transform of the
!> class is: along the fast and the middle axis FFTW's real-to-real transforms (DCT/DST of type
!> I when the centre is a site, type II/III when it falls between two sites) on the sites and
!> frequencies 0 .. n/2, then the slow axis as a real-to-complex FFT (the data are real). Its
!> spectrum, [lines][k_slow <= n_slow/2][k_fast <= n_fast/2][fields] with the middle-axis
!> frequencies 0 .. n_middle/2 split over the ranks, is the octant of frequencies that
!> kernel_spectrum.f90 gives; the operator multiplies it there (fft_operator.F90). About a
!> quarter of the sites, transposes and frequencies of the pruned transform (pruned_transform.f90),
!> which stays for bodies without the two mirrors.
!>
!> Site and frequency slots 0 .. n/2 per mirrored axis (n even): site j is the bead plane j
!> from the centre (whole sample: planes c, c + 1, ...; between sites: c + 1/2, c + 3/2, ...).
!> Frequency k sits in slot k for every field; a slot its transform does not produce (k = 0 and
!> n/2 of an odd field about a site, k = 0 of an odd field between sites, k = n/2 of an even one
!> between sites) is zero. The plans are made once per class on one buffer and run on any buffer
!> of the same layout (FFTW's new-array execute), so the batch's copies share them.
module beadmob_mirror_transform
  use, intrinsic :: iso_c_binding
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_fftw
  use mpi, only: MPI_Allreduce, MPI_IN_PLACE, MPI_INTEGER, MPI_SUM
  implicit none
  private
  public :: mirror_transform_t, mirror_buffer_t, size_mirror_transform, make_mirror_plans, mirror_forward, &
            mirror_backward, make_mirror_buffer, destroy_mirror_buffer, destroy_mirror_transform, n_classes, class_signs

  !> Classes (s_f, s_m): 1 = (+, +), 2 = (-, +), 3 = (+, -), 4 = (-, -).
  integer, parameter :: n_classes = 4

  !> The layout, the fields' runs and the plans (shared by every buffer).
  type :: mirror_transform_t
    integer :: fields = 0
    integer :: box(3) = 2                  ! padded sizes (fast, middle even)
    integer :: data(3) = 1                 ! bead sites per axis
    integer :: half(2) = 2                 ! slots of the fast and middle axis: box / 2 + 1
    integer :: fundamental(2) = 1          ! slots holding beads: sites 0 .. fundamental - 1
    logical :: whole(2) = .true.           ! the centre is a site (odd data), else between two
    integer :: row = 0                     ! doubles of one (plane, middle slot): half(1) * fields
    integer(C_INTPTR_T) :: planes = 0, first_plane = 0, lines = 0, first_line = 0
    integer(i8) :: n_frequencies = 0       ! this rank's: lines * (box(3)/2 + 1) * half(1)
    integer(i8) :: slab_doubles = 0, spectrum_doubles = 0, transposed_doubles = 0
    !> Runs of consecutive fields with the same mirror signs D_f, D_m (run_sign(:, run))
    integer, allocatable :: run_first(:), run_count(:), run_sign(:, :)
    !> pass(run, axis, direction, class): r2r plans (null: nothing to transform)
    type(C_PTR), allocatable :: pass(:, :, :, :)
    type(C_PTR) :: slow_forward = C_NULL_PTR, slow_backward = C_NULL_PTR
    type(C_PTR) :: transpose_forward = C_NULL_PTR, transpose_backward = C_NULL_PTR
  end type mirror_transform_t

  !> One buffer: region A holds the data planes, then (same memory) the spectrum; region B the
  !> transposed planes extended along the slow axis.
  type :: mirror_buffer_t
    type(C_PTR) :: memory = C_NULL_PTR
    real(C_DOUBLE), pointer, contiguous :: all(:) => null()
    real(C_DOUBLE), pointer, contiguous :: slab(:) => null()        ! [planes][half_m][half_f][fields]
    real(C_DOUBLE), pointer, contiguous :: transposed(:) => null()  ! [lines][n_slow][half_f][fields]
    complex(C_DOUBLE_COMPLEX), pointer, contiguous :: spectrum(:, :) => null()   ! (fields, frequencies)
  end type mirror_buffer_t

  integer, parameter :: forward = 1, backward = 2

  interface
    subroutine fftw_execute_r2r(p, in, out) bind(C, name='fftw_execute_r2r')
      import :: C_PTR
      type(C_PTR), value :: p, in, out
    end subroutine fftw_execute_r2r
    subroutine fftw_execute_dft_r2c(p, in, out) bind(C, name='fftw_execute_dft_r2c')
      import :: C_PTR
      type(C_PTR), value :: p, in, out
    end subroutine fftw_execute_dft_r2c
    subroutine fftw_execute_dft_c2r(p, in, out) bind(C, name='fftw_execute_dft_c2r')
      import :: C_PTR
      type(C_PTR), value :: p, in, out
    end subroutine fftw_execute_dft_c2r
    subroutine fftw_mpi_execute_r2r(p, in, out) bind(C, name='fftw_mpi_execute_r2r')
      import :: C_PTR
      type(C_PTR), value :: p, in, out
    end subroutine fftw_mpi_execute_r2r
    type(C_PTR) function fftw_plan_guru_r2r(rank, dims, howmany_rank, howmany_dims, in, out, kind, flags) &
      bind(C, name='fftw_plan_guru_r2r')
      import :: C_PTR, C_INT, fftw_iodim
      integer(C_INT), value :: rank, howmany_rank, flags
      type(fftw_iodim), dimension(*), intent(in) :: dims, howmany_dims
      type(C_PTR), value :: in, out
      integer(C_INT), dimension(*), intent(in) :: kind
    end function fftw_plan_guru_r2r
  end interface

  integer(C_INT), parameter :: FFTW_REDFT00 = 3, FFTW_REDFT01 = 4, FFTW_REDFT10 = 5, FFTW_RODFT00 = 7, &
                               FFTW_RODFT01 = 8, FFTW_RODFT10 = 9

contains

  !> The class's signs (s_f, s_m).
  pure function class_signs(class) result(s)
    integer, intent(in) :: class
    integer :: s(2)
    s(1) = merge(1, -1, mod(class - 1, 2) == 0)
    s(2) = merge(1, -1, class <= 2)
  end function class_signs

  !> Collective. The layout of `fields` fields (their mirror signs along the fast and the middle
  !> axis: sign(field, 1:2), fields with equal signs best consecutive) on the padded box `box`
  !> (fast and middle even, >= 2 data - 1) with `data` bead sites per axis.
  subroutine size_mirror_transform(comm, sign, box, data, t, err)
    integer, intent(in) :: comm, sign(:, :), box(3), data(3)
    type(mirror_transform_t), intent(inout) :: t
    type(error_t), intent(inout) :: err
    integer(C_INTPTR_T) :: forward_alloc, backward_alloc, back(4)
    integer :: f, runs
    t%fields = size(sign, 1)
    t%box = box
    t%data = data
    if (any(mod(box(1:2), 2) /= 0) .or. any(box < 2 * data - 1)) then
      call raise(err, 'internal error: the mirror transform needs even fast and middle sizes of at least 2 data - 1')
      return
    end if
    t%half = box(1:2) / 2 + 1
    t%whole = mod(data(1:2), 2) == 1
    t%fundamental = merge((data(1:2) + 1) / 2, data(1:2) / 2, t%whole)
    t%row = t%half(1) * t%fields
    forward_alloc = fftw_mpi_local_size_many_transposed(2, [int(data(3), C_INTPTR_T), int(t%half(2), C_INTPTR_T)], &
                                                        int(t%row, C_INTPTR_T), FFTW_MPI_DEFAULT_BLOCK, &
                                                        FFTW_MPI_DEFAULT_BLOCK, int(comm, C_INT32_T), t%planes, &
                                                        t%first_plane, t%lines, t%first_line)
    backward_alloc = fftw_mpi_local_size_many_transposed(2, [int(t%half(2), C_INTPTR_T), int(data(3), C_INTPTR_T)], &
                                                         int(t%row, C_INTPTR_T), FFTW_MPI_DEFAULT_BLOCK, &
                                                         FFTW_MPI_DEFAULT_BLOCK, int(comm, C_INT32_T), back(1), back(2), &
                                                         back(3), back(4))
    if (any(back /= [t%lines, t%first_line, t%planes, t%first_plane])) then
      call raise(err, 'internal error: the backward transpose of the mirror transform splits the data otherwise')
      return
    end if
    t%n_frequencies = int(t%lines, i8) * (box(3) / 2 + 1) * t%half(1)
    t%slab_doubles = max(int(t%planes, i8) * t%half(2) * t%row, int(forward_alloc, i8), int(backward_alloc, i8), 1_i8)
    t%spectrum_doubles = 2 * t%n_frequencies * t%fields
    t%transposed_doubles = max(int(t%lines, i8) * box(3) * t%row, int(forward_alloc, i8), int(backward_alloc, i8), 1_i8)
    ! Runs of fields with equal signs.
    allocate (t%run_first(t%fields), t%run_count(t%fields), t%run_sign(2, t%fields))
    runs = 0
    do f = 1, t%fields
      if (runs > 0) then
        if (all(sign(f, 1:2) == t%run_sign(:, runs))) then
          t%run_count(runs) = t%run_count(runs) + 1
          cycle
        end if
      end if
      runs = runs + 1
      t%run_first(runs) = f
      t%run_count(runs) = 1
      t%run_sign(:, runs) = sign(f, 1:2)
    end do
    t%run_first = t%run_first(1:runs)
    t%run_count = t%run_count(1:runs)
    t%run_sign = t%run_sign(:, 1:runs)
  end subroutine size_mirror_transform

  !> A buffer of the transform's layout (memory: false if it could not be allocated).
  subroutine make_mirror_buffer(t, b, made)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    logical, intent(out) :: made
    integer(i8) :: region_a, doubles
    region_a = 4 * ((max(t%slab_doubles, t%spectrum_doubles) + 3) / 4)   ! 32-byte aligned region B
    doubles = region_a + t%transposed_doubles
    b%memory = fftw_alloc_real(int(doubles, C_SIZE_T))
    made = c_associated(b%memory)
    if (.not. made) return
    call c_f_pointer(b%memory, b%all, [doubles])
    b%slab => b%all(1:max(t%slab_doubles, 1_i8))
    b%transposed => b%all(region_a + 1:region_a + t%transposed_doubles)
    call c_f_pointer(b%memory, b%spectrum, [int(t%fields, i8), max(t%n_frequencies, 1_i8)])
  end subroutine make_mirror_buffer

  subroutine destroy_mirror_buffer(b)
    type(mirror_buffer_t), intent(inout) :: b
    if (c_associated(b%memory)) call fftw_free(b%memory)
    b%memory = C_NULL_PTR
    b%all => null()
    b%slab => null()
    b%transposed => null()
    b%spectrum => null()
  end subroutine destroy_mirror_buffer

  !> Collective. Every plan of every class on buffer b (which planning may overwrite); made =
  !> every plan on every rank.
  subroutine make_mirror_plans(comm, t, b, flags, made)
    integer, intent(in) :: comm
    type(mirror_transform_t), intent(inout) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer(C_INT), intent(in) :: flags
    logical, intent(out) :: made
    type(fftw_iodim) :: line(1), many(3), slow_many(2)
    integer :: run, axis, direction, class, missing, ierr, n, offset, kind(1), slot_stride, s(2), parity
    integer(C_INT) :: kinds(1)
    type(C_PTR) :: at

    allocate (t%pass(size(t%run_first), 2, 2, n_classes))
    t%pass = C_NULL_PTR
    missing = 0
    if (t%planes > 0) then
      do class = 1, n_classes
        s = class_signs(class)
        do axis = 1, 2
          slot_stride = merge(t%fields, t%row, axis == 1)
          do run = 1, size(t%run_first)
            parity = s(axis) * t%run_sign(axis, run)
            do direction = forward, backward
              call pass_kind(t, axis, parity, direction, kind(1), n, offset)
              if (n < 1) cycle
              kinds(1) = int(kind(1), C_INT)
              line(1) = fftw_iodim(n, slot_stride, slot_stride)
              many(1) = fftw_iodim(t%run_count(run), 1, 1)
              if (axis == 1) then   ! fast: the data rows of each plane
                many(2) = fftw_iodim(t%fundamental(2), t%row, t%row)
              else                  ! middle: every fast-axis frequency of each plane
                many(2) = fftw_iodim(t%half(1), t%fields, t%fields)
              end if
              many(3) = fftw_iodim(int(t%planes), t%half(2) * t%row, t%half(2) * t%row)
              at = c_loc(b%slab(1 + offset * slot_stride + t%run_first(run) - 1))
              t%pass(run, axis, direction, class) = fftw_plan_guru_r2r(1, line, 3, many, at, at, kinds, flags)
              if (.not. c_associated(t%pass(run, axis, direction, class))) missing = missing + 1
            end do
          end do
        end do
      end do
    end if
    if (t%lines > 0) then
      line(1) = fftw_iodim(t%box(3), t%row, t%row)
      slow_many(1) = fftw_iodim(t%row, 1, 1)
      slow_many(2) = fftw_iodim(int(t%lines), t%box(3) * t%row, (t%box(3) / 2 + 1) * t%row)
      t%slow_forward = fftw_plan_guru_dft_r2c(1, line, 2, slow_many, c_loc(b%transposed), b%memory, flags)
      slow_many(2) = fftw_iodim(int(t%lines), (t%box(3) / 2 + 1) * t%row, t%box(3) * t%row)
      t%slow_backward = fftw_plan_guru_dft_c2r(1, line, 2, slow_many, b%memory, c_loc(b%transposed), flags)
      if (.not. c_associated(t%slow_forward)) missing = missing + 1
      if (.not. c_associated(t%slow_backward)) missing = missing + 1
    end if
    t%transpose_forward = fftw_mpi_plan_many_transpose(int(t%data(3), C_INTPTR_T), int(t%half(2), C_INTPTR_T), &
                                                       int(t%row, C_INTPTR_T), FFTW_MPI_DEFAULT_BLOCK, &
                                                       FFTW_MPI_DEFAULT_BLOCK, b%memory, c_loc(b%transposed), &
                                                       int(comm, C_INT32_T), flags)
    t%transpose_backward = fftw_mpi_plan_many_transpose(int(t%half(2), C_INTPTR_T), int(t%data(3), C_INTPTR_T), &
                                                        int(t%row, C_INTPTR_T), FFTW_MPI_DEFAULT_BLOCK, &
                                                        FFTW_MPI_DEFAULT_BLOCK, c_loc(b%transposed), b%memory, &
                                                        int(comm, C_INT32_T), flags)
    if (.not. c_associated(t%transpose_forward)) missing = missing + 1
    if (.not. c_associated(t%transpose_backward)) missing = missing + 1
    call MPI_Allreduce(MPI_IN_PLACE, missing, 1, MPI_INTEGER, MPI_SUM, comm, ierr)
    made = missing == 0
  end subroutine make_mirror_plans

  !> The r2r kind, length and first slot of one field's pass along `axis` (1 fast, 2 middle) of
  !> parity +-1; n < 1: nothing to transform (an odd field on a single plane is zero).
  pure subroutine pass_kind(t, axis, parity, direction, kind, n, offset)
    type(mirror_transform_t), intent(in) :: t
    integer, intent(in) :: axis, parity, direction
    integer, intent(out) :: kind, n, offset
    offset = 0
    if (t%whole(axis)) then
      if (parity > 0) then     ! x(-j) = x(j): DCT-I on slots 0 .. n/2 (its own inverse)
        kind = FFTW_REDFT00
        n = t%half(axis)
      else                     ! x(-j) = -x(j): DST-I on slots 1 .. n/2 - 1
        kind = FFTW_RODFT00
        n = t%half(axis) - 2
        offset = 1
      end if
    else
      n = t%box(axis) / 2
      if (parity > 0) then     ! x(-1-j) = x(j): DCT-II, inverse DCT-III
        kind = merge(FFTW_REDFT10, FFTW_REDFT01, direction == forward)
      else                     ! x(-1-j) = -x(j): DST-II, inverse DST-III
        kind = merge(FFTW_RODFT10, FFTW_RODFT01, direction == forward)
      end if
    end if
  end subroutine pass_kind

  !> The data planes of buffer b (zero off the fundamental sites) of class `class` -> its
  !> spectrum (b%spectrum); the planes are overwritten.
  subroutine mirror_forward(t, b, class)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer, intent(in) :: class
    integer :: axis
    integer(i8) :: row, line, plane
    do axis = 1, 2
      call run_passes(t, b, class, axis, forward)
    end do
    call fftw_mpi_execute_r2r(t%transpose_forward, b%memory, c_loc(b%transposed))
    ! [lines][data planes][row] -> [lines][n_slow][row], zero beyond the data planes; backwards,
    ! since each line moves to a later place.
    row = t%row
    do line = t%lines - 1, 0, -1
      do plane = t%data(3) - 1, 0, -1
        call move(b%transposed, (line * t%data(3) + plane) * row, (line * t%box(3) + plane) * row, row)
      end do
      b%transposed((line * t%box(3) + t%data(3)) * row + 1:(line + 1) * t%box(3) * row) = 0.0_dp
    end do
    if (t%lines > 0) call fftw_execute_dft_r2c(t%slow_forward, c_loc(b%transposed), b%memory)
  end subroutine mirror_forward

  !> The spectrum of buffer b (overwritten) -> its data planes (b%slab) of class `class`, right
  !> on the fundamental sites.
  subroutine mirror_backward(t, b, class)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer, intent(in) :: class
    integer :: axis
    integer(i8) :: row, line, plane
    if (t%lines > 0) call fftw_execute_dft_c2r(t%slow_backward, b%memory, c_loc(b%transposed))
    row = t%row
    do line = 0, t%lines - 1
      do plane = 0, t%data(3) - 1
        call move(b%transposed, (line * t%box(3) + plane) * row, (line * t%data(3) + plane) * row, row)
      end do
    end do
    call fftw_mpi_execute_r2r(t%transpose_backward, c_loc(b%transposed), b%memory)
    do axis = 2, 1, -1
      call run_passes(t, b, class, axis, backward)
    end do
  end subroutine mirror_backward

  !> One axis' r2r passes of every run, with the slot moves and zeros around them (module header).
  subroutine run_passes(t, b, class, axis, direction)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer, intent(in) :: class, axis, direction
    integer :: run, s(2), parity, kind, n, offset, slot_stride
    if (t%planes == 0) return
    s = class_signs(class)
    slot_stride = merge(t%fields, t%row, axis == 1)
    do run = 1, size(t%run_first)
      parity = s(axis) * t%run_sign(axis, run)
      call pass_kind(t, axis, parity, direction, kind, n, offset)
      if (.not. t%whole(axis) .and. parity < 0 .and. direction == backward) call shift_slots(t, b, run, axis, -1)
      if (n >= 1) call fftw_execute_r2r(t%pass(run, axis, direction, class), &
                                        c_loc(b%slab(1 + offset * slot_stride + t%run_first(run) - 1)), &
                                        c_loc(b%slab(1 + offset * slot_stride + t%run_first(run) - 1)))
      if (direction == forward) then
        if (t%whole(axis)) then
          if (parity < 0) then
            call zero_slot(t, b, run, axis, 0)
            call zero_slot(t, b, run, axis, t%half(axis) - 1)
          end if
        else if (parity < 0) then
          call shift_slots(t, b, run, axis, 1)
        else
          call zero_slot(t, b, run, axis, t%half(axis) - 1)
        end if
      else if (t%whole(axis) .and. parity < 0) then   ! an odd field is zero on the mirror plane
        call zero_slot(t, b, run, axis, 0)
      end if
    end do
  end subroutine run_passes

  !> Lines of one pass: (plane, other-axis slot) pairs; along the fast axis the data rows only.
  pure subroutine pass_lines(t, axis, other, line_stride)
    type(mirror_transform_t), intent(in) :: t
    integer, intent(in) :: axis
    integer, intent(out) :: other
    integer(i8), intent(out) :: line_stride
    if (axis == 1) then
      other = t%fundamental(2)
      line_stride = t%row
    else
      other = t%half(1)
      line_stride = t%fields
    end if
  end subroutine pass_lines

  !> Slot `slot` of the run's fields along `axis` set to zero on every line of the pass.
  subroutine zero_slot(t, b, run, axis, slot)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer, intent(in) :: run, axis, slot
    integer :: other, o
    integer(i8) :: line_stride, slot_stride, plane, base
    call pass_lines(t, axis, other, line_stride)
    slot_stride = merge(int(t%fields, i8), int(t%row, i8), axis == 1)
    do plane = 0, t%planes - 1
      do o = 0, other - 1
        base = plane * t%half(2) * t%row + o * line_stride + slot * slot_stride + t%run_first(run)
        b%slab(base:base + t%run_count(run) - 1) = 0.0_dp
      end do
    end do
  end subroutine zero_slot

  !> Along `axis`, the run's slots 0 .. n/2 - 1 moved up by one (by = 1; slot 0 then zero) or
  !> slots 1 .. n/2 down by one (by = -1): the sine transform between sites produces and reads
  !> frequencies 1 .. n/2 in its slots 0 .. n/2 - 1.
  subroutine shift_slots(t, b, run, axis, by)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer, intent(in) :: run, axis, by
    integer :: other, o, k, n
    integer(i8) :: line_stride, slot_stride, plane, base, to, from
    call pass_lines(t, axis, other, line_stride)
    slot_stride = merge(int(t%fields, i8), int(t%row, i8), axis == 1)
    n = t%box(axis) / 2
    do plane = 0, t%planes - 1
      do o = 0, other - 1
        base = plane * t%half(2) * t%row + o * line_stride + t%run_first(run)
        if (by > 0) then
          do k = n - 1, 0, -1
            call move(b%slab, base + k * slot_stride - 1, base + (k + 1) * slot_stride - 1, int(t%run_count(run), i8))
          end do
          b%slab(base:base + t%run_count(run) - 1) = 0.0_dp
        else
          do k = 0, n - 1
            call move(b%slab, base + (k + 1) * slot_stride - 1, base + k * slot_stride - 1, int(t%run_count(run), i8))
          end do
        end if
      end do
    end do
  end subroutine shift_slots

  !> flat(to + 1 : to + n) <- flat(from + 1 : from + n); overlapping moves are safe either way
  !> (an array assignment would make a temporary copy for the possible overlap).
  pure subroutine move(flat, from, to, n)
    real(C_DOUBLE), intent(inout) :: flat(:)
    integer(i8), intent(in) :: from, to, n
    integer(i8) :: k
    if (to > from) then
      do k = n, 1, -1
        flat(to + k) = flat(from + k)
      end do
    else if (to < from) then
      do k = 1, n
        flat(to + k) = flat(from + k)
      end do
    end if
  end subroutine move

  subroutine destroy_mirror_transform(t)
    type(mirror_transform_t), intent(inout) :: t
    integer :: k
    type(C_PTR) :: single(4)
    type(C_PTR), allocatable :: passes(:)
    if (allocated(t%pass)) then
      passes = reshape(t%pass, [size(t%pass)])
      do k = 1, size(passes)
        if (c_associated(passes(k))) call fftw_destroy_plan(passes(k))
      end do
    end if
    single = [t%slow_forward, t%slow_backward, t%transpose_forward, t%transpose_backward]
    do k = 1, 4
      if (c_associated(single(k))) call fftw_destroy_plan(single(k))
    end do
    t%slow_forward = C_NULL_PTR
    t%slow_backward = C_NULL_PTR
    t%transpose_forward = C_NULL_PTR
    t%transpose_backward = C_NULL_PTR
    if (allocated(t%pass)) deallocate (t%pass)
  end subroutine destroy_mirror_transform
end module beadmob_mirror_transform
