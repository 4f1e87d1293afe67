!> The FFT operator's transforms for fields of one mirror-parity class (theory.md T4, "Mirror
!> classes"). When the bead set is symmetric under the mirrors of the fast and the middle FFT
!> axis, a field x of class (s_f, s_m) obeys x_i(M_a r) = s_a D_a(i) x_i(r): each field is even
!> or odd about the bead set's centre along both axes. The DFT of such a line is a cosine
!> transform (even) or -i times a sine transform (odd) of its half, so the 3-D transform of the
!> class is: along the fast and the middle axis cosine and sine transforms (DCT/DST of type I
!> when the centre is a site, type II/III when it falls between two sites; as matrix products on
!> the beads' stretches where dense_axes finds them cheaper, else FFTW's real-to-real transforms)
!> on the sites and frequencies 0 .. n/2, then the slow axis as real FFTs (the data are real; two
!> lines as one complex FFT). Its
!> spectrum, [lines][k_slow <= n_slow/2][k_fast <= n_fast/2][fields] with the middle-axis
!> frequencies 0 .. n_middle/2 split over the ranks, is the octant of frequencies that
!> kernel_spectrum.f90 gives; the operator multiplies it there (fft_operator.F90). About a
!> quarter of the sites, transposes and frequencies of the pruned transform (pruned_transform.f90),
!> which stays for bodies without the two mirrors.
!>
!> Layout of one (slow plane, middle slot) row of half(1) * fields numbers: the fields' runs (equal
!> signs along the fast and the middle axis, consecutive) one after the other, each as [fast slot]
!> [field of the run]: a pass of one run then transforms contiguous vectors of fields (the fast
!> axis) or one contiguous block (the middle axis) with one kind. field_base and field_step place
!> field s at fast slot k at field_base(s) + k field_step(s) of its row, in the data planes and,
!> after the slow axis' transform (which treats each number of a row alike), in the spectrum.
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
  use beadmob_lapack, only: dgemm
  use mpi, only: MPI_Allreduce, MPI_IN_PLACE, MPI_INTEGER, MPI_SUM
  implicit none
  private
  public :: mirror_transform_t, mirror_buffer_t, size_mirror_transform, make_mirror_plans, forward_planes, &
            forward_line, backward_line, backward_planes, make_mirror_buffer, destroy_mirror_buffer, &
            destroy_mirror_transform, n_classes, class_signs, fundamental_site

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
    integer(i8) :: slab_doubles = 0, transposed_doubles = 0
    !> Runs of consecutive fields with the same mirror signs D_f, D_m (run_sign(:, run))
    integer, allocatable :: run_first(:), run_count(:), run_sign(:, :)
    integer, allocatable :: field_base(:), field_step(:)   ! by field (row layout above)
    !> pass(run, axis, direction, class): r2r plans (null: nothing to transform)
    type(C_PTR), allocatable :: pass(:, :, :, :)
    !> The axes that pass by matrix products instead (DGEMM; dense_axes): matrix(:, :, parity,
    !> direction, axis), the same transform as a matrix on the slots, zero where a slot is not
    !> produced or not read.
    logical :: dense(2) = .false.
    real(dp), allocatable :: matrix(:, :, :, :, :)
    !> Where the data planes hold beads (size_mirror_transform's sites; unset: everywhere), for the
    !> dense passes to skip the rest: row_span(:, j_m, plane) the first and last fundamental fast
    !> site with a bead in data row (plane, middle site j_m), plane_span(:, plane) the first and last
    !> middle site with a bead in the plane (last < first: none); every data plane, from 0.
    integer, allocatable :: row_span(:, :, :), plane_span(:, :)
    type(C_PTR) :: slow_forward = C_NULL_PTR, slow_backward = C_NULL_PTR
    type(C_PTR) :: transpose_forward = C_NULL_PTR, transpose_backward = C_NULL_PTR
  end type mirror_transform_t

  !> One buffer: region A holds the data planes, region B the transposed data planes. The slow
  !> axis runs one middle line at a time (forward_line, backward_line): the scratch holds the
  !> line's slow-axis lines, each contiguous, the spectrum the line's frequencies.
  type :: mirror_buffer_t
    type(C_PTR) :: memory = C_NULL_PTR, scratch_memory = C_NULL_PTR, spectrum_memory = C_NULL_PTR
    real(C_DOUBLE), pointer, contiguous :: all(:) => null()
    real(C_DOUBLE), pointer, contiguous :: slab(:) => null()        ! [planes][half_m][half_f][fields]
    real(C_DOUBLE), pointer, contiguous :: transposed(:) => null()  ! [lines][data planes][half_f][fields]
    !> The same as (complex pair of a row, data plane, middle line): what the slow axis reads and writes
    complex(C_DOUBLE_COMPLEX), pointer, contiguous :: line_planes(:, :, :) => null()
    !> scratch(k_slow, p): the slow-axis line of the row's complex pair p (the row's numbers 2p - 1, 2p);
    !> its leading dimension line_stride(n_slow)
    complex(C_DOUBLE_COMPLEX), pointer, contiguous :: scratch(:, :) => null()
    !> (numbers of a row, rows k_slow = 0 .. n_slow/2) of one middle line; field s at fast
    !> frequency k of a row is number 1 + field_base(s) + k field_step(s)
    complex(C_DOUBLE_COMPLEX), pointer, contiguous :: spectrum(:, :) => null()
  end type mirror_buffer_t

  integer, parameter :: forward = 1, backward = 2
  !> Which axes pass by matrix products (dense_axes): an axis of h slots does when its rows'
  !> stretches of bead sites are on average shorter than dense_factor log2 h (the matrix product's
  !> flops follow the stretch, FFTW's r2r transform's h log2 h; FFTW runs the middle axis's long
  !> strides and the fast axis's short ones at several times fewer flops per second than DGEMM).
  !> Middle axis: a 3-bead thick disc of radius 100 beads (211 slots, its rows' mean stretch 82)
  !> is 1.25x faster as matrix products, one of radius 160 (331 slots, 125) as fast either way, so
  !> 15 (= 125 / log2 331). Fast axis: 7.3, the former fixed limit of 96 slots for full rows
  !> (48 / log2 96), which shells' short rows pass far below (the 1e6-bead sphere's 126 slots as
  !> matrix products on both axes: its job 1.23x faster).
  real(dp), parameter :: dense_factor(2) = [7.3_dp, 15.0_dp]

  interface
    subroutine fftw_execute_r2r(p, in, out) bind(C, name='fftw_execute_r2r')
      import :: C_PTR
      type(C_PTR), value :: p, in, out
    end subroutine fftw_execute_r2r
    subroutine fftw_execute_dft(p, in, out) bind(C, name='fftw_execute_dft')
      import :: C_PTR
      type(C_PTR), value :: p, in, out
    end subroutine fftw_execute_dft
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

  !> Site l of an axis of n sites: its fundamental slot j and where it lies, k = -1 on the
  !> mirror plane (its own image), 0 on the fundamental side, 1 beyond.
  pure subroutine fundamental_site(l, n, j, k)
    integer, intent(in) :: l, n
    integer, intent(out) :: j, k
    if (mod(n, 2) == 1) then
      j = abs(l - (n - 1) / 2)
      k = merge(-1, merge(0, 1, l > (n - 1) / 2), l == (n - 1) / 2)
    else
      j = merge(l - n / 2, n / 2 - 1 - l, l >= n / 2)
      k = merge(0, 1, l >= n / 2)
    end if
  end subroutine fundamental_site

  !> row_span and plane_span from sites(:, bead), the lattice site (fast, middle, slow; from 0)
  !> of every bead. A hollow or thin body leaves most of its box empty (ring_1mm's rows hold beads
  !> on a sixth of their fundamental sites, a sphere's shell on its two ends): the dense passes
  !> then transform only the stretch of each row between its first and last bead and skip rows and
  !> planes without any. Only the sites between them are read forward, and only they are written
  !> back, which is all the unfold reads (mirror_classes.F90).
  pure subroutine mark_bead_sites(t, sites)
    type(mirror_transform_t), intent(inout) :: t
    integer, intent(in) :: sites(:, :)
    integer :: bead, j(2), k, plane, axis
    allocate (t%row_span(2, 0:t%fundamental(2) - 1, 0:t%data(3) - 1), t%plane_span(2, 0:t%data(3) - 1))
    t%row_span(1, :, :) = huge(1)
    t%row_span(2, :, :) = -1
    t%plane_span(1, :) = huge(1)
    t%plane_span(2, :) = -1
    do bead = 1, size(sites, 2)
      plane = sites(3, bead)
      do axis = 1, 2
        call fundamental_site(sites(axis, bead), t%data(axis), j(axis), k)
      end do
      t%row_span(1, j(2), plane) = min(t%row_span(1, j(2), plane), j(1))
      t%row_span(2, j(2), plane) = max(t%row_span(2, j(2), plane), j(1))
      t%plane_span(1, plane) = min(t%plane_span(1, plane), j(2))
      t%plane_span(2, plane) = max(t%plane_span(2, plane), j(2))
    end do
  end subroutine mark_bead_sites

  !> The axes that pass by matrix products (dense_factor): the mean stretch of bead sites of the
  !> fast axis's data rows and of the middle axis's planes (rows and planes without beads count
  !> 0), the whole fundamental sites without row_span. The same on every rank (all planes).
  pure function dense_axes(t) result(dense)
    type(mirror_transform_t), intent(in) :: t
    logical :: dense(2)
    real(dp) :: mean(2)
    if (allocated(t%row_span)) then
      mean(1) = real(sum(max(t%row_span(2, :, :) - t%row_span(1, :, :) + 1, 0)), dp) / size(t%row_span(1, :, :))
      mean(2) = real(sum(max(t%plane_span(2, :) - t%plane_span(1, :) + 1, 0)), dp) / size(t%plane_span(1, :))
    else
      mean = real(t%fundamental, dp)
    end if
    dense = mean < dense_factor * log(real(t%half, dp)) / log(2.0_dp)
  end function dense_axes

  !> Collective. The layout of `fields` fields (their mirror signs along the fast and the middle
  !> axis: sign(field, 1:2), fields with equal signs best consecutive) on the padded box `box`
  !> (fast and middle even, >= 2 data - 1) with `data` bead sites per axis. sites(:, bead): the
  !> lattice site (fast, middle, slow; from 0) of every bead, on every rank, when the transform
  !> is only ever applied to fields on them (mark_bead_sites; without it, the whole planes).
  !> Which axes pass by matrix products: dense_axes, or with dense_limit >= 0 those of at most
  !> that many slots (0: FFTW's r2r transforms only; negative: dense_axes too).
  subroutine size_mirror_transform(comm, sign, box, data, t, err, dense_limit, sites)
    integer, intent(in) :: comm, sign(:, :), box(3), data(3)
    type(mirror_transform_t), intent(inout) :: t
    type(error_t), intent(inout) :: err
    integer, intent(in), optional :: dense_limit, sites(:, :)
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
    ! Even: the slow axis transforms the real numbers of a row in pairs (forward_line); an odd
    ! count gets one unused number.
    t%row = 2 * ((t%half(1) * t%fields + 1) / 2)
    if (allocated(t%row_span)) deallocate (t%row_span, t%plane_span)
    if (present(sites)) call mark_bead_sites(t, sites)
    t%dense = dense_axes(t)
    if (present(dense_limit)) then
      if (dense_limit >= 0) t%dense = t%half <= dense_limit
    end if
    if (any(t%dense)) call make_pass_matrices(t)
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
    t%transposed_doubles = max(int(t%lines, i8) * data(3) * t%row, int(forward_alloc, i8), int(backward_alloc, i8), 1_i8)
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
    allocate (t%field_base(t%fields), t%field_step(t%fields))
    do runs = 1, size(t%run_first)
      do f = t%run_first(runs), t%run_first(runs) + t%run_count(runs) - 1
        t%field_base(f) = run_start(t, runs) + f - t%run_first(runs)
        t%field_step(f) = t%run_count(runs)
      end do
    end do
  end subroutine size_mirror_transform

  !> A buffer of the transform's layout (memory: false if it could not be allocated).
  subroutine make_mirror_buffer(t, b, made)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    logical, intent(out) :: made
    integer(i8) :: region_a, doubles
    region_a = 4 * ((t%slab_doubles + 3) / 4)   ! 32-byte aligned region B
    doubles = region_a + t%transposed_doubles
    b%memory = fftw_alloc_real(int(doubles, C_SIZE_T))
    made = c_associated(b%memory)
    if (.not. made) return
    call c_f_pointer(b%memory, b%all, [doubles])
    b%slab => b%all(1:max(t%slab_doubles, 1_i8))
    b%transposed => b%all(region_a + 1:region_a + t%transposed_doubles)
    call c_f_pointer(c_loc(b%transposed), b%line_planes, [t%row / 2, t%data(3), int(t%lines)])
    b%scratch_memory = fftw_alloc_real(int(line_stride(t%box(3)), C_SIZE_T) * t%row)
    made = c_associated(b%scratch_memory)
    if (.not. made) return
    call c_f_pointer(b%scratch_memory, b%scratch, [line_stride(t%box(3)), t%row / 2])
    b%spectrum_memory = fftw_alloc_real(2 * int(t%row, C_SIZE_T) * (t%box(3) / 2 + 1))
    made = c_associated(b%spectrum_memory)
    if (.not. made) return
    call c_f_pointer(b%spectrum_memory, b%spectrum, [t%row, t%box(3) / 2 + 1])
  end subroutine make_mirror_buffer

  subroutine destroy_mirror_buffer(b)
    type(mirror_buffer_t), intent(inout) :: b
    if (c_associated(b%memory)) call fftw_free(b%memory)
    if (c_associated(b%scratch_memory)) call fftw_free(b%scratch_memory)
    if (c_associated(b%spectrum_memory)) call fftw_free(b%spectrum_memory)
    b%memory = C_NULL_PTR
    b%scratch_memory = C_NULL_PTR
    b%spectrum_memory = C_NULL_PTR
    b%scratch => null()
    b%all => null()
    b%slab => null()
    b%transposed => null()
    b%line_planes => null()
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
    integer :: run, axis, direction, class, missing, ierr, n, offset, kind(1), slot_stride, s(2), parity, segments, &
               segment_stride, length
    integer(C_INT) :: kinds(1)
    type(C_PTR) :: at

    allocate (t%pass(size(t%run_first), 2, 2, n_classes))
    t%pass = C_NULL_PTR
    missing = 0
    if (t%planes > 0) then
      do class = 1, n_classes
        s = class_signs(class)
        do axis = 1, 2
          do run = 1, size(t%run_first)
            parity = s(axis) * t%run_sign(axis, run)
            call pass_geometry(t, run, axis, slot_stride, segments, segment_stride, length)
            do direction = forward, backward
              call pass_kind(t, axis, parity, direction, kind(1), n, offset)
              if (n < 1 .or. t%dense(axis)) cycle
              kinds(1) = int(kind(1), C_INT)
              ! Fast: the run's fields on each data row; middle: the run's block of each plane.
              line(1) = fftw_iodim(n, slot_stride, slot_stride)
              many(1) = fftw_iodim(length, 1, 1)
              many(2) = fftw_iodim(segments, segment_stride, segment_stride)
              many(3) = fftw_iodim(int(t%planes), t%half(2) * t%row, t%half(2) * t%row)
              at = c_loc(b%slab(1 + run_start(t, run) + offset * slot_stride))
              t%pass(run, axis, direction, class) = fftw_plan_guru_r2r(1, line, 3, many, at, at, kinds, flags)
              if (.not. c_associated(t%pass(run, axis, direction, class))) missing = missing + 1
            end do
          end do
        end do
      end do
    end if
    if (t%lines > 0) then
      ! In place on the scratch's contiguous lines, one middle line at a time: FFTW's estimated
      ! plans for the same lines strided across the row (the layout of the spectrum) cost 2-3.5
      ! times as much at many sizes (140, 120, 100: bench/fft_layout), contiguous ones never more.
      line(1) = fftw_iodim(t%box(3), 1, 1)
      slow_many(1) = fftw_iodim(t%row / 2, line_stride(t%box(3)), line_stride(t%box(3)))
      t%slow_forward = fftw_plan_guru_dft(1, line, 1, slow_many(1:1), c_loc(b%scratch), c_loc(b%scratch), &
                                          FFTW_FORWARD, flags)
      t%slow_backward = fftw_plan_guru_dft(1, line, 1, slow_many(1:1), c_loc(b%scratch), c_loc(b%scratch), &
                                           FFTW_BACKWARD, flags)
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

  !> The data planes of buffer b (zero off the fundamental sites) of class `class` -> the
  !> transposed data planes, transformed along the fast and the middle axis; the planes are
  !> overwritten. The slow axis follows line by line (forward_line).
  subroutine forward_planes(t, b, class)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer, intent(in) :: class
    integer :: axis
    do axis = 1, 2
      call run_passes(t, b, class, axis, forward)
    end do
    call fftw_mpi_execute_r2r(t%transpose_forward, b%memory, c_loc(b%transposed))
  end subroutine forward_planes

  !> Middle line `line` (1 .. t%lines) of the transposed planes -> its spectrum (b%spectrum). Two
  !> real lines a, b at once as the complex line z = a + i b, transposed into the scratch (zero
  !> beyond the data planes); their spectra follow from Z's, A(k) = (Z(k) + conj Z(n - k)) / 2
  !> and B(k) = (Z(k) - conj Z(n - k)) / 2i, k = 0 .. n/2 (a real FFT of each at half the cost).
  !> One line at a time, so that the spectrum is still in cache for the kernel's product.
  subroutine forward_line(t, b, line)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer, intent(in) :: line
    integer :: plane
    do plane = 1, t%data(3)
      b%scratch(plane, :) = b%line_planes(:, plane, line)
    end do
    b%scratch(t%data(3) + 1:t%box(3), :) = (0.0_dp, 0.0_dp)
    call fftw_execute_dft(t%slow_forward, c_loc(b%scratch), c_loc(b%scratch))
    call split_pairs(t, b)
  end subroutine forward_line

  !> The spectrum of middle line `line` (b%spectrum, overwritten) -> the line's transposed data
  !> planes.
  subroutine backward_line(t, b, line)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer, intent(in) :: line
    integer :: plane
    call join_pairs(t, b)
    call fftw_execute_dft(t%slow_backward, c_loc(b%scratch), c_loc(b%scratch))
    do plane = 1, t%data(3)
      b%line_planes(:, plane, line) = b%scratch(plane, :)
    end do
  end subroutine backward_line

  !> The transposed data planes of every line (backward_line) -> the data planes (b%slab) of
  !> class `class`, right on the fundamental sites.
  subroutine backward_planes(t, b, class)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer, intent(in) :: class
    integer :: axis
    call fftw_mpi_execute_r2r(t%transpose_backward, c_loc(b%transposed), b%memory)
    do axis = 2, 1, -1
      call run_passes(t, b, class, axis, backward)
    end do
  end subroutine backward_planes

  !> The spectra of the pairs' two real lines (Z in the scratch) into the spectrum.
  subroutine split_pairs(t, b)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer :: n, k, p, row
    complex(C_DOUBLE_COMPLEX) :: here, there
    n = t%box(3)
    do k = 0, n / 2
      row = k + 1
      do p = 1, t%row / 2
        here = b%scratch(k + 1, p)
        there = conjg(b%scratch(mod(n - k, n) + 1, p))
        b%spectrum(2 * p - 1, row) = 0.5_dp * (here + there)
        b%spectrum(2 * p, row) = cmplx(0.0_dp, -0.5_dp, C_DOUBLE_COMPLEX) * (here - there)
      end do
    end do
  end subroutine split_pairs

  !> The inverse of split_pairs: Z(k) = A(k) + i B(k) for every k (A(n - k) = conj A(k)) into the
  !> scratch, whose inverse transform is then a + i b.
  subroutine join_pairs(t, b)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer :: n, k, p, row
    complex(C_DOUBLE_COMPLEX), parameter :: i = (0.0_dp, 1.0_dp)
    n = t%box(3)
    do k = 0, n / 2
      row = k + 1
      do p = 1, t%row / 2
        b%scratch(k + 1, p) = b%spectrum(2 * p - 1, row) + i * b%spectrum(2 * p, row)
        if (k > 0 .and. 2 * k /= n) b%scratch(n - k + 1, p) = conjg(b%spectrum(2 * p - 1, row)) + &
                                                               i * conjg(b%spectrum(2 * p, row))
      end do
    end do
  end subroutine join_pairs

  !> One axis' r2r passes of every run, with the slot moves and zeros around them (module header).
  subroutine run_passes(t, b, class, axis, direction)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer, intent(in) :: class, axis, direction
    integer :: run, s(2), parity, kind, n, offset, slot_stride, segments, segment_stride, length
    if (t%planes == 0) return
    s = class_signs(class)
    do run = 1, size(t%run_first)
      parity = s(axis) * t%run_sign(axis, run)
      call pass_geometry(t, run, axis, slot_stride, segments, segment_stride, length)
      if (t%dense(axis)) then
        call dense_pass(t, b, run, axis, t%matrix(:, :, merge(1, 2, parity > 0), direction, axis), direction)
        cycle
      end if
      call pass_kind(t, axis, parity, direction, kind, n, offset)
      if (.not. t%whole(axis) .and. parity < 0 .and. direction == backward) call shift_slots(t, b, run, axis, -1)
      if (n >= 1) call fftw_execute_r2r(t%pass(run, axis, direction, class), &
                                        c_loc(b%slab(1 + run_start(t, run) + offset * slot_stride)), &
                                        c_loc(b%slab(1 + run_start(t, run) + offset * slot_stride)))
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

  !> The slot matrices of the dense axes (FFTW's definitions of its r2r kinds, written on the
  !> slots 0 .. n/2 of module header): DCT-I and DST-I (their own inverses) about a site; between
  !> sites DCT-II / DST-II forward (the sine's frequency k + 1 in slot k + 1) and DCT-III / DST-III
  !> back.
  subroutine make_pass_matrices(t)
    type(mirror_transform_t), intent(inout) :: t
    integer :: axis, h, n, j, k
    real(dp), parameter :: pi = acos(-1.0_dp)
    allocate (t%matrix(maxval(t%half), maxval(t%half), 2, 2, 2))
    t%matrix = 0.0_dp
    do axis = 1, 2
      if (.not. t%dense(axis)) cycle
      h = t%half(axis)
      n = t%box(axis) / 2
      associate (m => t%matrix(:, :, :, :, axis))
        do k = 0, h - 1
          do j = 0, h - 1
            if (t%whole(axis)) then
              ! Even: Y_k = X_0 + (-1)^k X_n + 2 sum_{0<j<n} X_j cos(pi j k / n); odd: slots 1 .. n - 1.
              m(k + 1, j + 1, 1, :) = merge(1.0_dp, 2.0_dp, j == 0 .or. j == n) * cos(pi * j * k / n)
              if (j > 0 .and. j < n .and. k > 0 .and. k < n) m(k + 1, j + 1, 2, :) = 2 * sin(pi * j * k / n)
            else if (j < n) then
              ! Forward: sites j < n to frequencies (even: slots k < n; odd: slots 1 .. n).
              if (k < n) m(k + 1, j + 1, 1, forward) = 2 * cos(pi * (j + 0.5_dp) * k / n)
              if (k > 0) m(k + 1, j + 1, 2, forward) = 2 * sin(pi * (j + 0.5_dp) * k / n)
            end if
            if (.not. t%whole(axis) .and. k < n) then
              ! Back: frequency slot j to site k < n (even: slots < n, odd: slots 1 .. n).
              if (j < n) m(k + 1, j + 1, 1, backward) = merge(1.0_dp, 2.0_dp, j == 0) * cos(pi * (k + 0.5_dp) * j / n)
              if (j > 0) m(k + 1, j + 1, 2, backward) = merge(1.0_dp, 2.0_dp, j == n) * sin(pi * (k + 0.5_dp) * j / n)
            end if
          end do
        end do
      end associate
    end do
  end subroutine make_pass_matrices

  !> One run's pass along a dense axis: each vector of slots times the matrix (one DGEMM per
  !> plane for the middle axis, per data row for the fast axis). Only the fundamental sites hold
  !> anything forward (the fold zeroes the rest) and only they are read back (the fast pass runs on
  !> their rows, the unfold reads them), so the sites' side of the matrix is cut to them: half the
  !> flops of the whole matrix; with the beads' sites marked (mark_bead_sites), to the stretch
  !> between the first and the last bead of the row or plane, and a row or plane without any is
  !> skipped (forward its slots stay the fold's zeros; back nothing reads them).
  subroutine dense_pass(t, b, run, axis, matrix, direction)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer, intent(in) :: run, axis, direction
    !> The pass's matrix in the first half(axis) rows and columns; explicit shape, so that a stretch
    !> of its columns or rows is passed from its first element
    real(dp), intent(in) :: matrix(size(t%matrix, 1), size(t%matrix, 2))
    integer :: slot_stride, segments, segment_stride, length, o, h, span(2), sites, ld
    integer(i8) :: plane, base
    real(dp), allocatable :: product(:)   ! on the heap: a large box's would not fit on the stack
    call pass_geometry(t, run, axis, slot_stride, segments, segment_stride, length)
    h = t%half(axis)
    ld = size(matrix, 1)
    allocate (product(length * h))
    do plane = 0, t%planes - 1
      do o = 0, segments - 1
        span = [0, t%fundamental(axis) - 1]
        if (allocated(t%row_span)) span = merge(t%row_span(:, o, plane + t%first_plane), &
                                                t%plane_span(:, plane + t%first_plane), axis == 1)
        if (span(2) < span(1)) cycle
        sites = span(2) - span(1) + 1
        base = plane * t%half(2) * t%row + int(o, i8) * segment_stride + run_start(t, run)
        ! The slots of the vectors are columns slot_stride apart: product = X M^T, with M's
        ! columns (forward) or rows (back) cut to the sites span(1) .. span(2).
        if (direction == forward) then
          call dgemm('N', 'T', length, h, sites, 1.0_dp, b%slab(base + int(span(1), i8) * slot_stride + 1:), slot_stride, &
                     matrix(1, span(1) + 1), ld, 0.0_dp, product, length)
          call place(product, b%slab(base + 1:), length, h, slot_stride)
        else
          call dgemm('N', 'T', length, sites, h, 1.0_dp, b%slab(base + 1:), slot_stride, matrix(span(1) + 1, 1), ld, &
                     0.0_dp, product, length)
          call place(product, b%slab(base + int(span(1), i8) * slot_stride + 1:), length, sites, slot_stride)
        end if
      end do
    end do
  end subroutine dense_pass

  !> columns(:, k) of a (length x h) matrix into the slots slot_stride apart.
  pure subroutine place(columns, slots, length, h, slot_stride)
    integer, intent(in) :: length, h, slot_stride
    real(dp), intent(in) :: columns(length, h)
    real(dp), intent(inout) :: slots(*)
    integer :: k
    do k = 1, h
      slots((k - 1) * slot_stride + 1:(k - 1) * slot_stride + length) = columns(:, k)
    end do
  end subroutine place

  !> Doubles of a row before run `run`'s block.
  pure integer function run_start(t, run)
    type(mirror_transform_t), intent(in) :: t
    integer, intent(in) :: run
    run_start = t%half(1) * (t%run_first(run) - 1)
  end function run_start

  !> Where a pass of one run reads along `axis` in each plane: slots slot_stride apart, on
  !> `segments` contiguous vectors of `length` doubles segment_stride apart (fast: the run's fields
  !> on each data row; middle: the run's whole block).
  pure subroutine pass_geometry(t, run, axis, slot_stride, segments, segment_stride, length)
    type(mirror_transform_t), intent(in) :: t
    integer, intent(in) :: run, axis
    integer, intent(out) :: slot_stride, segments, segment_stride, length
    if (axis == 1) then
      slot_stride = t%run_count(run)
      segments = t%fundamental(2)
      segment_stride = t%row
      length = t%run_count(run)
    else
      slot_stride = t%row
      segments = 1
      segment_stride = 0
      length = t%half(1) * t%run_count(run)
    end if
  end subroutine pass_geometry

  !> Slot `slot` of the run along `axis` set to zero on every vector of the pass.
  subroutine zero_slot(t, b, run, axis, slot)
    type(mirror_transform_t), intent(in) :: t
    type(mirror_buffer_t), intent(inout) :: b
    integer, intent(in) :: run, axis, slot
    integer :: slot_stride, segments, segment_stride, length, o
    integer(i8) :: plane, base
    call pass_geometry(t, run, axis, slot_stride, segments, segment_stride, length)
    do plane = 0, t%planes - 1
      do o = 0, segments - 1
        base = plane * t%half(2) * t%row + int(o, i8) * segment_stride + run_start(t, run) + int(slot, i8) * slot_stride
        b%slab(base + 1:base + length) = 0.0_dp
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
    integer :: slot_stride, segments, segment_stride, length, o, k, n
    integer(i8) :: plane, base
    call pass_geometry(t, run, axis, slot_stride, segments, segment_stride, length)
    n = t%box(axis) / 2
    do plane = 0, t%planes - 1
      do o = 0, segments - 1
        base = plane * t%half(2) * t%row + int(o, i8) * segment_stride + run_start(t, run)
        if (by > 0) then
          do k = n - 1, 0, -1
            call move(b%slab, base + int(k, i8) * slot_stride, base + int(k + 1, i8) * slot_stride, int(length, i8))
          end do
          b%slab(base + 1:base + length) = 0.0_dp
        else
          do k = 0, n - 1
            call move(b%slab, base + int(k + 1, i8) * slot_stride, base + int(k, i8) * slot_stride, int(length, i8))
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

  !> Frees the plans (the layout stays: make_mirror_plans may plan again).
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
