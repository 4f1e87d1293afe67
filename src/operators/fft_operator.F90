!> The multipole operator of a lattice bead model as a PETSc MATSHELL whose far field is an FFT
!> convolution (design/method.md, "Why a lattice makes it fast"; theory.md T4). Same product as
!> the direct operator (bead_operator.F90):
!>   y_i = S x_i + sum_{j /= i} A(l_i - l_j) x_j,
!> l the integer lattice coordinates. Because A depends on l_i - l_j only, the sum is the linear
!> convolution of the multipole field x (zero off the beads) with the kernel K(d) = A(d)
!> (K(0) = 0, K = 0 outside the displacement box [-span, span]^3). On a periodic box of
!> n_a >= 2 span_a + 1 sites per axis the circular convolution equals it at every bead site
!> (no wrapped image reaches back into [-span, span]), so it is exact up to rounding:
!>   y = IFFT( K^(k) FFT(x)(k) ),  K^(k) an nb x nb complex block per frequency.
!>
!> Layout (FFTW's MPI interface, slab decomposition): the padded box is stored in C order
!> [n0][n1][n2][nb] (Fortran (nb, n2, n1, n0)), the nb multipole fields interleaved so that one
!> "many" plan transforms all of them with one global transpose; real space is split over ranks
!> along n0, Fourier space (FFTW_MPI_TRANSPOSED_OUT) along n1, which saves the transpose back
!> in both the forward and the inverse transform: the product is pointwise, so the order of the
!> frequencies never matters as long as the kernel is transformed by the same plan.
!>
!> Kernel symmetries, which make the stored kernel one real number per (a <= b) pair and
!> frequency instead of nb^2 complex ones:
!>  - A(-d) = A(d)^T (theory.md T4) makes K^(k) Hermitian:
!>      K^(k)^H = sum_d A(d)^T e^{+ik.d} = sum_d A(-d) e^{+ik.d} = K^(k);
!>    only the upper triangle is transformed and stored.
!>  - Inversion: every basis density has a parity, phi_a(-y) = p_a phi_a(y) with p = (-1)^(n-1)
!>    for sigma = 0, 2 and (-1)^n for sigma = 1 (theory.md T2: grad R_n, y x grad R_n,
!>    grad I_n); its single-layer field has the same parity, so A(-d)_ab = p_a p_b A(d)_ab. An
!>    entry with p_a p_b = 1 is even in d, its transform real; one with p_a p_b = -1 is odd, its
!>    transform imaginary. The fields are stored even unknowns first ("slots"), so K^ is
!>      [ R_ee     i J_eo ]      R_ee, R_oo real symmetric, J_eo real,
!>      [ -i J_eo^T  R_oo ]
!>    and the per-frequency product is real matrices times complex vectors.
!> create_fft_operator checks both relations on the block table before relying on them. The
!> real-to-complex transforms store half of the frequencies (real fields, K^(-k) = conj K^(k)).
module beadmob_fft_operator
#include "petsc/finclude/petscmat.h"
  use petscmat
  use, intrinsic :: iso_c_binding
  use beadmob_kinds, only: dp, i8
  use, intrinsic :: iso_fortran_env, only: error_unit
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_progress, only: progress_line, progress_seconds
  use beadmob_multipole_basis, only: multipole_basis_t
  use beadmob_pair_blocks, only: self_block
  use beadmob_block_table, only: block_table_t, make_block_table, lattice_block, lattice_block_entries
  use beadmob_unit_lattice, only: lattice_tolerance
  use beadmob_file_system, only: rename_file, remove_file
  use beadmob_multipole_operator, only: multipole_operator_t, operator_options_t
  use beadmob_operator_cost, only: job_size_t, operator_cost_t, canonical_blocks_of, lattice_blocks_seconds, &
                                   fill_seconds, &
                                   fft_seconds, multiply_seconds, transpose_fraction, transform_bytes
  implicit none
  private
  public :: fft_operator_t, create_fft_operator, destroy_fft_operator, fft_size, create_fft_companion, fft_cost, &
            fft_box_of_spans

  ! The part of FFTW's Fortran 2003 MPI interface used here, with the names, C symbols and
  ! argument types of /usr/include/fftw3-mpi.f03 and fftw3.f03 (FFTW 3 ABI). That header is not
  ! included because gfortran's INCLUDE (and cpp) does not find its nested include 'fftw3.f03'
  ! without an -I for the FFTW include directory, which the build does not pass.
  integer(C_INT), parameter :: FFTW_MEASURE = 0, FFTW_ESTIMATE = 64, FFTW_WISDOM_ONLY = 2097152
  integer(C_INT), parameter :: FFTW_MPI_TRANSPOSED_IN = 536870912
  integer(C_INT), parameter :: FFTW_MPI_TRANSPOSED_OUT = 1073741824
  integer(C_INTPTR_T), parameter :: FFTW_MPI_DEFAULT_BLOCK = 0

  interface
    subroutine fftw_mpi_init() bind(C, name='fftw_mpi_init')
    end subroutine fftw_mpi_init
    integer(C_INTPTR_T) function fftw_mpi_local_size_many_transposed(rnk, n, howmany, block0, block1, comm, &
                                                                     local_n0, local_0_start, local_n1, local_1_start) &
      bind(C, name='fftw_mpi_local_size_many_transposed_f03')
      import :: C_INT, C_INTPTR_T, C_INT32_T
      integer(C_INT), value :: rnk
      integer(C_INTPTR_T), dimension(*), intent(in) :: n
      integer(C_INTPTR_T), value :: howmany, block0, block1
      integer(C_INT32_T), value :: comm
      integer(C_INTPTR_T), intent(out) :: local_n0, local_0_start, local_n1, local_1_start
    end function fftw_mpi_local_size_many_transposed
    type(C_PTR) function fftw_mpi_plan_many_dft_r2c(rnk, n, howmany, iblock, oblock, in, out, comm, flags) &
      bind(C, name='fftw_mpi_plan_many_dft_r2c_f03')
      import :: C_PTR, C_INT, C_INTPTR_T, C_INT32_T, C_DOUBLE, C_DOUBLE_COMPLEX
      integer(C_INT), value :: rnk
      integer(C_INTPTR_T), dimension(*), intent(in) :: n
      integer(C_INTPTR_T), value :: howmany, iblock, oblock
      real(C_DOUBLE), dimension(*), intent(out) :: in
      complex(C_DOUBLE_COMPLEX), dimension(*), intent(out) :: out
      integer(C_INT32_T), value :: comm
      integer(C_INT), value :: flags
    end function fftw_mpi_plan_many_dft_r2c
    type(C_PTR) function fftw_mpi_plan_many_dft_c2r(rnk, n, howmany, iblock, oblock, in, out, comm, flags) &
      bind(C, name='fftw_mpi_plan_many_dft_c2r_f03')
      import :: C_PTR, C_INT, C_INTPTR_T, C_INT32_T, C_DOUBLE, C_DOUBLE_COMPLEX
      integer(C_INT), value :: rnk
      integer(C_INTPTR_T), dimension(*), intent(in) :: n
      integer(C_INTPTR_T), value :: howmany, iblock, oblock
      complex(C_DOUBLE_COMPLEX), dimension(*), intent(out) :: in
      real(C_DOUBLE), dimension(*), intent(out) :: out
      integer(C_INT32_T), value :: comm
      integer(C_INT), value :: flags
    end function fftw_mpi_plan_many_dft_c2r
    subroutine fftw_mpi_execute_dft_r2c(p, in, out) bind(C, name='fftw_mpi_execute_dft_r2c')
      import :: C_PTR, C_DOUBLE, C_DOUBLE_COMPLEX
      type(C_PTR), value :: p
      real(C_DOUBLE), dimension(*), intent(inout) :: in
      complex(C_DOUBLE_COMPLEX), dimension(*), intent(out) :: out
    end subroutine fftw_mpi_execute_dft_r2c
    subroutine fftw_mpi_execute_dft_c2r(p, in, out) bind(C, name='fftw_mpi_execute_dft_c2r')
      import :: C_PTR, C_DOUBLE, C_DOUBLE_COMPLEX
      type(C_PTR), value :: p
      complex(C_DOUBLE_COMPLEX), dimension(*), intent(inout) :: in
      real(C_DOUBLE), dimension(*), intent(out) :: out
    end subroutine fftw_mpi_execute_dft_c2r
    integer(C_INT) function fftw_import_wisdom_from_filename(path) bind(C, name='fftw_import_wisdom_from_filename')
      import :: C_INT, C_CHAR
      character(kind=C_CHAR), dimension(*), intent(in) :: path
    end function fftw_import_wisdom_from_filename
    integer(C_INT) function fftw_export_wisdom_to_filename(path) bind(C, name='fftw_export_wisdom_to_filename')
      import :: C_INT, C_CHAR
      character(kind=C_CHAR), dimension(*), intent(in) :: path
    end function fftw_export_wisdom_to_filename
    subroutine fftw_mpi_broadcast_wisdom(comm) bind(C, name='fftw_mpi_broadcast_wisdom_f03')
      import :: C_INT32_T
      integer(C_INT32_T), value :: comm
    end subroutine fftw_mpi_broadcast_wisdom
    subroutine fftw_mpi_gather_wisdom(comm) bind(C, name='fftw_mpi_gather_wisdom_f03')
      import :: C_INT32_T
      integer(C_INT32_T), value :: comm
    end subroutine fftw_mpi_gather_wisdom
    subroutine fftw_destroy_plan(p) bind(C, name='fftw_destroy_plan')
      import :: C_PTR
      type(C_PTR), value :: p
    end subroutine fftw_destroy_plan
    type(C_PTR) function fftw_alloc_real(n) bind(C, name='fftw_alloc_real')
      import :: C_PTR, C_SIZE_T
      integer(C_SIZE_T), value :: n
    end function fftw_alloc_real
    subroutine fftw_free(p) bind(C, name='fftw_free')
      import :: C_PTR
      type(C_PTR), value :: p
    end subroutine fftw_free
  end interface

  !> The MATSHELL context: kernel, plans, buffer and scatter, set once.
  type, extends(multipole_operator_t) :: fft_operator_t
    !> The lattice (on_lattice, span, lattice, computed_blocks) and its compact block table (the
    !> canonical blocks), freed once the kernel is transformed.
    type(block_table_t) :: table
    integer :: axes(3) = [1, 2, 3]          ! lattice axis of the fast, middle and slow FFT dimension
    integer :: box(3) = 1                   ! padded size of the fast, middle and slow FFT dimension
    !> FFTW_MEASURE plans (timed trial transforms while planning, ~20 % faster products at a
    !> set-up cost of about ten products, but the chosen algorithm, hence the rounding, may vary
    !> from run to run) or FFTW_ESTIMATE plans (reproducible to the last bit). Measured plans are
    !> remembered between runs in FFTW wisdom next to the table cache (<cache file>.fftw_wisdom;
    !> none without a cache): a later run on the same box plans at once (plans_from_wisdom).
    logical :: measure_plans = .true.
    integer(C_INTPTR_T) :: slab_planes = 0  ! real space: this rank's planes of the slow dimension
    integer(C_INTPTR_T) :: slab_start = 0
    integer(i8) :: n_frequencies = 0        ! frequencies (of all fields' one) on this rank
    integer :: n_even = 0                   ! unknowns of even parity (slots 1..n_even)
    integer, allocatable :: slot(:)         ! field slot of each unknown
    !> Upper triangle of K^(k) / M over slots, packed by columns (entry s + t(t-1)/2 for s <= t),
    !> for this rank's frequencies: the real part, or for an even-odd entry the imaginary part.
    real(dp), allocatable :: kernel(:, :)
    !> A companion (create_fft_companion) holds no kernel of its own: it reads its entries from
    !> its parent's, entry e of its packed triangle being kernel_map(e) of the parent's.
    real(dp), pointer, contiguous :: shared_kernel(:, :) => null()
    integer, allocatable :: kernel_map(:)
    type(C_PTR) :: buffer = C_NULL_PTR, forward = C_NULL_PTR, backward = C_NULL_PTR
    real(C_DOUBLE), pointer, contiguous :: real_data(:) => null()
    complex(C_DOUBLE_COMPLEX), pointer, contiguous :: spectrum(:, :) => null()
    Vec :: slab          ! PETSc view of real_data (this rank's real-space slab)
    VecScatter :: to_slab
    logical :: created = .false.
  contains
    procedure :: create => create_fft
    procedure :: create_companion => fft_companion
    procedure :: destroy => destroy_fft
    procedure, nopass :: cost => fft_cost
  end type fft_operator_t

  !> fftw_mpi_init once per process (a second call would be harmless but is not promised).
  logical, save :: fftw_mpi_started = .false.

  interface
    subroutine MatCreateShell(comm, m_local, n_local, m, n, context, matrix, ierr)
      use petscmat
      import :: fft_operator_t
      MPI_Comm :: comm
      PetscInt :: m_local, n_local, m, n
      type(fft_operator_t) :: context
      Mat :: matrix
      PetscErrorCode :: ierr
    end subroutine MatCreateShell
    subroutine MatShellGetContext(matrix, context, ierr)
      use petscmat
      import :: fft_operator_t
      Mat :: matrix
      type(fft_operator_t), pointer :: context
      PetscErrorCode :: ierr
    end subroutine MatShellGetContext
  end interface

contains

  !> multipole_operator_t%create: cache file, FFTW planner, progress lines and the companion's
  !> needs (the lattice) from the options.
  subroutine create_fft(this, comm, basis, centres, first_bead, n_local, options, err)
    class(fft_operator_t), target, intent(inout) :: this
    MPI_Comm, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :)
    integer(i8), intent(in) :: first_bead, n_local
    type(operator_options_t), intent(in) :: options
    type(error_t), intent(inout) :: err
    Mat :: matrix
    if (allocated(options%cache_file)) this%table%cache_file = options%cache_file
    this%measure_plans = options%measure_plans
    call create_fft_operator(comm, basis, centres, first_bead, n_local, this, matrix, err, options%report, &
                             keep_lattice=allocated(options%companion_unknowns))
    if (err%failed) return
    this%matrix = matrix
    this%on_lattice = .true.
    this%computed_blocks = this%table%computed_blocks
    this%cached_blocks = this%table%cached_blocks
  end subroutine create_fft

  subroutine fft_companion(this, comm, unknowns, companion, err)
    class(fft_operator_t), target, intent(inout) :: this
    MPI_Comm, intent(in) :: comm
    integer, intent(in) :: unknowns(:)
    class(multipole_operator_t), allocatable, target, intent(inout) :: companion
    type(error_t), intent(inout) :: err
    Mat :: matrix
    allocate (fft_operator_t :: companion)
    select type (companion)
    type is (fft_operator_t)
      call create_fft_companion(comm, this, unknowns, companion, matrix, err)
      if (companion%created) companion%matrix = matrix
    end select
  end subroutine fft_companion

  !> multipole_operator_t%cost (docs/scaling.md lists the terms): the canonical blocks (freed
  !> once the kernel is transformed), the packed kernel of this rank's frequencies, the FFT buffer
  !> of its slab and FFTW-MPI's transposes; the companion's buffer. Time: quadrature per canonical
  !> block, kernel fill per site and entry, the kernel's transforms; per product two transforms
  !> of nb fields and the kernel product.
  pure subroutine fft_cost(size, cost)
    type(job_size_t), intent(in) :: size
    type(operator_cost_t), intent(out) :: cost
    real(dp) :: nb, packed, sites, real_planes, freq_planes, frequencies, log_sites
    nb = size%nb
    packed = nb * (nb + 1) / 2
    cost%canonical_blocks = canonical_blocks_of(size%spans)
    cost%transient = 8 * nb**2 * cost%canonical_blocks + transform_bytes(size)
    cost%fft_box = fft_box_of_spans(size%spans)
    sites = product(real(cost%fft_box, dp))
    log_sites = log(sites) / log(2.0_dp)
    ! FFTW slabs: real space split along the slow axis, the transposed spectrum along the middle one.
    real_planes = real(ceiling(real(cost%fft_box(3), dp) / size%n_ranks), dp)
    freq_planes = real(ceiling(real(cost%fft_box(2), dp) / size%n_ranks), dp)
    frequencies = freq_planes * cost%fft_box(3) * (cost%fft_box(1) / 2 + 1)
    cost%kernel = 8 * packed * frequencies
    cost%fft_buffer = 16 * nb * max(frequencies, real_planes * cost%fft_box(2) * (cost%fft_box(1) / 2 + 1))
    if (size%n_ranks > 1) cost%transposes = transpose_fraction * cost%fft_buffer
    cost%companion = cost%fft_buffer * size%nb_low / nb * merge(1 + transpose_fraction, 1.0_dp, size%n_ranks > 1)
    cost%seconds_setup = lattice_blocks_seconds(size, cost%canonical_blocks) &
                         + (fill_seconds * packed * product(real(2 * size%spans + 1, dp)) &
                          + ceiling(packed / nb) * fft_seconds * nb * sites * log_sites) / size%n_ranks
    cost%seconds_product = (2 * fft_seconds * nb * sites * log_sites + multiply_seconds * packed * sites / 2) / size%n_ranks
    cost%seconds_low_product = (2 * fft_seconds * size%nb_low * sites * log_sites &
                                + multiply_seconds * size%nb_low * (size%nb_low + 1) / 2 * sites / 2) / size%n_ranks
  end subroutine fft_cost

  !> The padded FFT box (fast, middle, slow axis: increasing sizes) of a bead set whose lattice
  !> spans are `spans` (as plan_transforms chooses it).
  pure function fft_box_of_spans(spans) result(box)
    integer, intent(in) :: spans(3)
    integer :: box(3), padded(3), a
    do a = 1, 3
      padded(a) = fft_size(max(2 * spans(a) + 1, 2))
    end do
    box = [minval(padded), sum(padded) - minval(padded) - maxval(padded), maxval(padded)]
  end function fft_box_of_spans

  subroutine destroy_fft(this)
    class(fft_operator_t), intent(inout) :: this
    Mat :: matrix
    matrix = this%matrix
    call destroy_fft_operator(this, matrix)
  end subroutine destroy_fft

  !> Smallest n >= minimum whose prime factors are 2, 3, 5, 7 (FFTW's fastest sizes).
  pure integer function fft_size(minimum)
    integer, intent(in) :: minimum
    integer :: rest, p
    integer, parameter :: primes(4) = [2, 3, 5, 7]
    fft_size = max(minimum, 1)
    do
      rest = fft_size
      do p = 1, size(primes)
        do while (mod(rest, primes(p)) == 0)
          rest = rest / primes(p)
        end do
      end do
      if (rest == 1) return
      fft_size = fft_size + 1
    end do
  end function fft_size

  !> Collective. `op` must stay in place (not be moved or copied) while `matrix` lives: PETSc
  !> keeps its address. Set op%measure_plans before the call to choose the FFTW planner. On error
  !> (err set on some rank) no matrix is created; calling destroy_fft_operator then is harmless.
  !> report (default false; true on rank 0 only): progress lines of the set-up, which takes
  !> minutes for a million beads (the blocks, then each batch of kernel entries).
  !> keep_lattice (default false): keep op%table%lattice for a companion (create_fft_companion).
  subroutine create_fft_operator(comm, basis, centres, first_bead, n_local, op, matrix, err, report, keep_lattice)
    MPI_Comm, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :)
    integer(i8), intent(in) :: first_bead, n_local
    type(fft_operator_t), target, intent(inout) :: op
    Mat, intent(out) :: matrix
    type(error_t), intent(inout) :: err
    logical, intent(in), optional :: report, keep_lattice
    PetscErrorCode :: ierr
    integer :: failed_here, failed_anywhere
    logical :: reporting, keeping
    real(dp) :: start

    reporting = .false.
    if (present(report)) reporting = report
    start = MPI_Wtime()
    op%block_size = basis%size
    op%n_beads = size(centres, 2, kind=i8)
    op%first_bead = first_bead
    op%n_local = n_local
    allocate (op%self_block(basis%size, basis%size))
    call self_block(basis, op%self_block)

    ! Checked before the block table, which would otherwise store every pair of an off-lattice set.
    call check_on_lattice(centres, err)
    ! Compact table: each rank forms the blocks of its own FFT slab from the canonical ones
    ! (transform_kernel), so nothing of the size of the displacement box is held on any rank.
    if (.not. err%failed) call make_block_table(comm, basis, centres, first_bead, n_local, op%table, err, expand=.false.)
    if (.not. err%failed) call progress_line(reporting, 'blocks: ' // str(op%table%computed_blocks) // &
                                             ' canonical blocks computed, ' // str(op%table%cached_blocks) // &
                                             ' read from the cache (' // progress_seconds(MPI_Wtime() - start) // ' s)')
    if (.not. err%failed) call order_by_parity(basis, op)
    if (.not. err%failed) call check_symmetries(op, err)
    if (.not. err%failed) call plan_transforms(comm, op, err)
    if (.not. err%failed) call transform_kernel(op, err, reporting, start)
    call free_canonical_blocks(op%table)   ! the kernel holds them now
    failed_here = merge(1, 0, err%failed)
    call MPI_Allreduce(failed_here, failed_anywhere, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
    if (failed_anywhere /= 0) then
      if (.not. err%failed) call raise(err, 'the FFT operator could not be set up on another rank')
      call free_fftw(op)
      return
    end if

    keeping = .false.
    if (present(keep_lattice)) keeping = keep_lattice
    call finish_shell(comm, op, matrix, err, keeping)
  end subroutine create_fft_operator

  !> Collective. The operator of the sub-basis `unknowns` (indices into the parent's unknowns per
  !> bead; e.g. the order L - 1 functions of an order-L basis) on the same beads: the principal
  !> sub-blocks of the parent's, since a Galerkin block entry depends on its two functions only
  !> (theory.md T14). Its kernel entries are the parent's (a transform of a sub-block is the
  !> sub-block of the transform), read in place: only the plans, the buffer and the scatter of
  !> size(unknowns) fields are new. The parent must have been created with keep_lattice
  !> (its lattice moves to the companion and is freed) and must outlive the companion; `companion`
  !> must stay in place while `matrix` lives.
  subroutine create_fft_companion(comm, parent, unknowns, companion, matrix, err)
    MPI_Comm, intent(in) :: comm
    type(fft_operator_t), target, intent(inout) :: parent
    integer, intent(in) :: unknowns(:)
    type(fft_operator_t), target, intent(inout) :: companion
    Mat, intent(out) :: matrix
    type(error_t), intent(inout) :: err
    integer :: parent_slot(size(unknowns)), slot_parent(size(unknowns)), a, s, t, ps, pt

    if (.not. allocated(parent%table%lattice)) then
      call raise(err, 'internal error: the FFT companion needs its parent''s lattice (keep_lattice)')
      return
    end if
    companion%block_size = size(unknowns)
    companion%n_beads = parent%n_beads
    companion%first_bead = parent%first_bead
    companion%n_local = parent%n_local
    companion%self_block = parent%self_block(unknowns, unknowns)
    companion%measure_plans = .false.   ! measuring would cost more than its few products gain
    companion%table%span = parent%table%span
    call move_alloc(parent%table%lattice, companion%table%lattice)
    ! Slots keep the parent's order (even ones first), renumbered 1..size(unknowns).
    parent_slot = parent%slot(unknowns)
    companion%n_even = count(parent_slot <= parent%n_even)
    allocate (companion%slot(size(unknowns)))
    do a = 1, size(unknowns)
      companion%slot(a) = count(parent_slot <= parent_slot(a))
      slot_parent(companion%slot(a)) = parent_slot(a)
    end do
    allocate (companion%kernel_map(size(unknowns) * (size(unknowns) + 1) / 2))
    do t = 1, size(unknowns)
      do s = 1, t
        ps = slot_parent(s)
        pt = slot_parent(t)
        companion%kernel_map(s + t * (t - 1) / 2) = ps + pt * (pt - 1) / 2
      end do
    end do
    call plan_transforms(comm, companion, err)
    ! FFTW's slabs depend on the box and the ranks only, so the frequencies are the parent's.
    if (.not. err%failed .and. companion%n_frequencies /= parent%n_frequencies) &
      call raise(err, 'internal error: the FFT companion has other frequencies than its parent')
    companion%shared_kernel => parent%kernel
    call finish_shell(comm, companion, matrix, err, .false.)
  end subroutine create_fft_companion

  !> Collective: the slab scatter, then the MATSHELL (none if some rank failed).
  subroutine finish_shell(comm, op, matrix, err, keep_lattice)
    MPI_Comm, intent(in) :: comm
    type(fft_operator_t), target, intent(inout) :: op
    Mat, intent(out) :: matrix
    type(error_t), intent(inout) :: err
    logical, intent(in) :: keep_lattice
    PetscErrorCode :: ierr
    PetscInt :: local_size, global_size
    integer :: failed_here, failed_anywhere

    if (.not. err%failed) call make_slab_scatter(comm, op, err)
    ! the scatter holds the sites now
    if (allocated(op%table%lattice) .and. .not. keep_lattice) deallocate (op%table%lattice)
    failed_here = merge(1, 0, err%failed)
    call MPI_Allreduce(failed_here, failed_anywhere, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
    if (failed_anywhere /= 0) then
      if (.not. err%failed) call raise(err, 'the FFT operator could not be set up on another rank')
      call free_fftw(op)
      return
    end if

    local_size = int(op%n_local * op%block_size)
    global_size = int(op%n_beads * op%block_size)
    PetscCallA(MatCreateShell(comm, local_size, local_size, global_size, global_size, op, matrix, ierr))
    PetscCallA(MatShellSetOperation(matrix, MATOP_MULT, apply_fft_operator, ierr))
    PetscCallA(MatSetOption(matrix, MAT_SYMMETRIC, PETSC_TRUE, ierr))
    PetscCallA(MatSetOption(matrix, MAT_SPD, PETSC_TRUE, ierr))
    op%created = .true.
  end subroutine finish_shell

  subroutine destroy_fft_operator(op, matrix)
    type(fft_operator_t), intent(inout) :: op
    Mat, intent(inout) :: matrix
    PetscErrorCode :: ierr
    if (op%created) then
      PetscCallA(VecScatterDestroy(op%to_slab, ierr))
      PetscCallA(VecDestroy(op%slab, ierr))
      PetscCallA(MatDestroy(matrix, ierr))
      op%created = .false.
    end if
    call free_fftw(op)
    if (allocated(op%kernel)) deallocate (op%kernel)
    op%shared_kernel => null()
  end subroutine destroy_fft_operator

  subroutine free_fftw(op)
    type(fft_operator_t), intent(inout) :: op
    if (c_associated(op%forward)) call fftw_destroy_plan(op%forward)
    if (c_associated(op%backward)) call fftw_destroy_plan(op%backward)
    if (c_associated(op%buffer)) call fftw_free(op%buffer)
    op%forward = C_NULL_PTR
    op%backward = C_NULL_PTR
    op%buffer = C_NULL_PTR
    op%real_data => null()
    op%spectrum => null()
  end subroutine free_fftw

  !> Every centre within lattice_tolerance of a point of the unit lattice through the lowest corner
  !> (the same rule as the block table); otherwise name the first bead that is not.
  subroutine check_on_lattice(centres, err)
    real(dp), intent(in) :: centres(:, :)
    type(error_t), intent(inout) :: err
    real(dp) :: corner(3), offset(3)
    integer :: i
    if (size(centres, 2) == 0) then
      call raise(err, 'the FFT operator needs at least one bead')
      return
    end if
    corner = minval(centres, dim=2)
    do i = 1, size(centres, 2)
      offset = centres(:, i) - corner
      if (any(abs(offset - anint(offset)) > lattice_tolerance)) then
        call raise(err, 'the FFT operator needs the beads on a cubic lattice of spacing d: bead ' // str(i) // &
                   ' at (' // str(centres(1, i)) // ', ' // str(centres(2, i)) // ', ' // str(centres(3, i)) // &
                   ') is ' // str(maxval(abs(offset - anint(offset)))) // ' d off the lattice through the lowest ' // &
                   'corner (tolerance ' // str(lattice_tolerance) // '); use the direct operator')
        return
      end if
    end do
  end subroutine check_on_lattice

  !> Slots: the even unknowns first, then the odd ones, each in basis order.
  subroutine order_by_parity(basis, op)
    type(multipole_basis_t), intent(in) :: basis
    type(fft_operator_t), intent(inout) :: op
    integer :: a, next_even, next_odd
    logical :: even(basis%size)
    do a = 1, basis%size
      even(a) = inversion_parity(basis%degree(a), basis%family(a)) == 1
    end do
    op%n_even = count(even)
    allocate (op%slot(basis%size))
    next_even = 0
    next_odd = op%n_even
    do a = 1, basis%size
      if (even(a)) then
        next_even = next_even + 1
        op%slot(a) = next_even
      else
        next_odd = next_odd + 1
        op%slot(a) = next_odd
      end if
    end do
  end subroutine order_by_parity

  !> Inversion parity of a basis density of degree n, family sigma (see the module header).
  pure integer function inversion_parity(n, sigma)
    integer, intent(in) :: n, sigma
    inversion_parity = merge(-1, 1, mod(n + merge(0, 1, sigma == 1), 2) == 1)
  end function inversion_parity

  !> The kernel's storage rests on A(-d) = A(d)^T and A(-d) = P A(d) P: refuse a table that
  !> breaks them beyond rounding (e.g. a basis function without definite parity). A violation
  !> would be structural, so a sample of displacements suffices: about 4096 of the half box,
  !> each block formed from the compact table (lattice_block) for d and for -d.
  subroutine check_symmetries(op, err)
    type(fft_operator_t), intent(in) :: op
    type(error_t), intent(inout) :: err
    integer :: width(3), d(3), a, b, rest
    integer(i8) :: n_half, index, stride
    real(dp) :: signs(op%block_size), largest, worst_transpose, worst_parity
    real(dp), dimension(op%block_size, op%block_size) :: forward, backward
    real(dp), parameter :: tolerance = 1.0e-10_dp
    width = 2 * op%table%span + 1
    n_half = (product(int(width, i8)) - 1) / 2   ! displacements after d = 0 in box order
    stride = max(1_i8, n_half / 4096)
    do a = 1, op%block_size
      signs(a) = merge(1.0_dp, -1.0_dp, op%slot(a) <= op%n_even)
    end do
    largest = 0.0_dp
    worst_transpose = 0.0_dp
    worst_parity = 0.0_dp
    do index = n_half + 1, 2 * n_half, stride   ! 0-based box index of d; n_half is d = 0
      rest = int(index)
      d(1) = mod(rest, width(1)) - op%table%span(1)
      rest = rest / width(1)
      d(2) = mod(rest, width(2)) - op%table%span(2)
      d(3) = rest / width(2) - op%table%span(3)
      forward = lattice_block(op%table, d)
      backward = lattice_block(op%table, -d)
      largest = max(largest, maxval(abs(forward)))
      do b = 1, op%block_size
        worst_transpose = max(worst_transpose, maxval(abs(backward(:, b) - forward(b, :))))
        worst_parity = max(worst_parity, maxval(abs(backward(:, b) - signs(b) * signs * forward(:, b))))
      end do
    end do
    if (max(worst_transpose, worst_parity) > tolerance * largest) &
      call raise(err, 'the FFT operator needs lattice blocks with A(-d) = A(d)^T and A(-d) = P A(d) P; ' // &
                 'the block table breaks them by ' // str(max(worst_transpose, worst_parity) / max(largest, tiny(1.0_dp))) // &
                 ' relative')
  end subroutine check_symmetries

  !> The compact table is needed only until the kernel is transformed.
  subroutine free_canonical_blocks(table)
    type(block_table_t), intent(inout) :: table
    if (allocated(table%canonical_blocks)) deallocate (table%canonical_blocks)
    if (allocated(table%canonical_id)) deallocate (table%canonical_id)
    if (allocated(table%blocks)) deallocate (table%blocks)
  end subroutine free_canonical_blocks

  !> Padded box, axis order, FFTW slabs, the aligned buffer and the two in-place plans.
  subroutine plan_transforms(comm, op, err)
    MPI_Comm, intent(in) :: comm
    type(fft_operator_t), intent(inout) :: op
    type(error_t), intent(inout) :: err
    integer :: padded(3), a, b, swap
    integer(C_INTPTR_T) :: c_order(3), complex_shape(3), howmany, alloc_local, freq_planes, freq_start
    integer(C_INT) :: planner
    real(dp) :: entries
    character(len=:), allocatable :: wisdom_file

    if (.not. fftw_mpi_started) then
      call fftw_mpi_init()
      fftw_mpi_started = .true.
    end if
    ! At least 2: FFTW's MPI planner returned no plan for a size-1 dimension (flat or straight
    ! bead sets); 2 >= 2 span + 1 keeps the convolution exact.
    do a = 1, 3
      padded(a) = fft_size(max(2 * op%table%span(a) + 1, 2))
    end do
    ! The largest padded axis is the slab (slow) axis and the next the Fourier-space slab axis:
    ! the most planes to split over ranks. The fast axis is halved by the r2c transform.
    op%axes = [1, 2, 3]
    do a = 1, 2
      do b = 1, 3 - a
        if (padded(op%axes(b)) > padded(op%axes(b + 1))) then
          swap = op%axes(b)
          op%axes(b) = op%axes(b + 1)
          op%axes(b + 1) = swap
        end if
      end do
    end do
    op%box = padded(op%axes)
    c_order = [integer(C_INTPTR_T) :: op%box(3), op%box(2), op%box(1)]
    complex_shape = [c_order(1), c_order(2), c_order(3) / 2 + 1]
    howmany = op%block_size
    alloc_local = fftw_mpi_local_size_many_transposed(3, complex_shape, howmany, FFTW_MPI_DEFAULT_BLOCK, &
                                                      FFTW_MPI_DEFAULT_BLOCK, comm, op%slab_planes, op%slab_start, &
                                                      freq_planes, freq_start)
    op%n_frequencies = int(freq_planes, i8) * c_order(1) * complex_shape(3)
    ! PETSc's 32-bit indices address the slab vector (nb doubles per padded site).
    entries = real(op%block_size, dp) * real(c_order(1), dp) * real(c_order(2), dp) * 2 * complex_shape(3)
    if (entries > real(huge(1_C_INT), dp)) then
      call raise(err, 'the padded FFT box ' // str(op%box(1)) // ' x ' // str(op%box(2)) // ' x ' // str(op%box(3)) // &
                 ' with ' // str(op%block_size) // ' fields has more entries than 32-bit PETSc indices address')
      return
    end if
    alloc_local = max(alloc_local, howmany)   ! a rank without planes still gets a valid buffer
    op%buffer = fftw_alloc_real(int(2 * alloc_local, C_SIZE_T))
    if (.not. c_associated(op%buffer)) then
      call raise(err, 'could not allocate the FFT buffer (' // str(16.0_dp * alloc_local / 1.0e9_dp) // ' GB)')
      return
    end if
    call c_f_pointer(op%buffer, op%real_data, [2 * alloc_local])
    call c_f_pointer(op%buffer, op%spectrum, [int(howmany, i8), max(op%n_frequencies, 1_i8)])
    ! In place: the real slab and its spectrum share the buffer (which FFTW_MEASURE overwrites
    ! while planning: nothing is in it yet).
    planner = merge(FFTW_MEASURE, FFTW_ESTIMATE, op%measure_plans)
    wisdom_file = ''
    if (op%measure_plans .and. allocated(op%table%cache_file)) then
      if (len_trim(op%table%cache_file) > 0) wisdom_file = trim(op%table%cache_file) // '.fftw_wisdom'
    end if
    op%plans_from_wisdom = .false.
    if (len(wisdom_file) > 0) then
      ! Plans from remembered wisdom only (FFTW_WISDOM_ONLY: no plan if the box is new to it).
      call recall_wisdom(comm, wisdom_file)
      call make_plans(ior(planner, FFTW_WISDOM_ONLY))
      op%plans_from_wisdom = c_associated(op%forward) .and. c_associated(op%backward)
      if (.not. op%plans_from_wisdom) call free_plans()
    end if
    if (.not. op%plans_from_wisdom) call make_plans(planner)
    if (.not. (c_associated(op%forward) .and. c_associated(op%backward))) then
      call raise(err, 'FFTW could not plan the ' // str(op%box(1)) // ' x ' // str(op%box(2)) // ' x ' // &
                 str(op%box(3)) // ' transforms')
    else if (len(wisdom_file) > 0 .and. .not. op%plans_from_wisdom) then
      call remember_wisdom(comm, wisdom_file)
    end if

  contains

    subroutine make_plans(flags)
      integer(C_INT), intent(in) :: flags
      op%forward = fftw_mpi_plan_many_dft_r2c(3, c_order, howmany, FFTW_MPI_DEFAULT_BLOCK, FFTW_MPI_DEFAULT_BLOCK, &
                                              op%real_data, op%spectrum, comm, ior(flags, FFTW_MPI_TRANSPOSED_OUT))
      op%backward = fftw_mpi_plan_many_dft_c2r(3, c_order, howmany, FFTW_MPI_DEFAULT_BLOCK, FFTW_MPI_DEFAULT_BLOCK, &
                                               op%spectrum, op%real_data, comm, ior(flags, FFTW_MPI_TRANSPOSED_IN))
    end subroutine make_plans

    subroutine free_plans()
      if (c_associated(op%forward)) call fftw_destroy_plan(op%forward)
      if (c_associated(op%backward)) call fftw_destroy_plan(op%backward)
      op%forward = C_NULL_PTR
      op%backward = C_NULL_PTR
    end subroutine free_plans
  end subroutine plan_transforms

  !> Collective. Rank 0 reads the wisdom file (missing: nothing; unreadable: a warning) and every
  !> rank gets it. Wisdom only chooses among FFTW's exact algorithms: a file from another machine
  !> costs speed at worst, never accuracy.
  subroutine recall_wisdom(comm, path)
    MPI_Comm, intent(in) :: comm
    character(len=*), intent(in) :: path
    integer :: rank, ierr
    logical :: exists
    call MPI_Comm_rank(comm, rank, ierr)
    if (rank == 0) then
      inquire (file=path, exist=exists)
      if (exists) then
        if (fftw_import_wisdom_from_filename(path // C_NULL_CHAR) == 0) write (error_unit, '(a)') &
          "beadmob: warning: FFTW wisdom file '" // path // "' could not be read; planning anew and rewriting it"
      end if
    end if
    call fftw_mpi_broadcast_wisdom(int(comm, C_INT32_T))
  end subroutine recall_wisdom

  !> Collective. The wisdom of every rank gathered (the recalled and the new plans); rank 0
  !> writes it to a temporary file renamed over `path`: a reader never sees half a file.
  subroutine remember_wisdom(comm, path)
    MPI_Comm, intent(in) :: comm
    character(len=*), intent(in) :: path
    integer :: rank, ierr
    logical :: written
    call fftw_mpi_gather_wisdom(int(comm, C_INT32_T))
    call MPI_Comm_rank(comm, rank, ierr)
    if (rank /= 0) return
    written = fftw_export_wisdom_to_filename(path // '.partial' // C_NULL_CHAR) /= 0
    if (written) written = rename_file(path // '.partial', path)
    if (.not. written) then
      write (error_unit, '(a)') "beadmob: warning: FFTW wisdom file '" // path // "' could not be written"
      call remove_file(path // '.partial')
    end if
  end subroutine remember_wisdom

  !> K^ = FFT(K) / M for the upper triangle over slots, nb entries at a time through the
  !> operator's own plan (no extra plan; the transient memory is the one buffer). Each rank forms
  !> the entries of its own slab's sites from the compact block table (lattice_block_entries),
  !> so the real-space kernel is never held whole on any rank.
  subroutine transform_kernel(op, err, reporting, start)
    type(fft_operator_t), intent(inout) :: op
    type(error_t), intent(inout) :: err
    logical, intent(in) :: reporting   ! a progress line per batch (rank 0)
    real(dp), intent(in) :: start      ! MPI_Wtime of the set-up's start
    integer :: nb, n_packed, batch, n_batches, c, e, i, j, k, s, t, d(3), first, last, stat
    integer, allocatable :: row(:), column(:), unknown(:)
    logical, allocatable :: odd(:)
    integer(i8) :: site, f
    real(dp) :: scale
    logical :: inside

    nb = op%block_size
    n_packed = nb * (nb + 1) / 2
    allocate (op%kernel(n_packed, max(op%n_frequencies, 1_i8)), stat=stat)
    if (stat /= 0) then
      call raise(err, 'could not allocate the FFT kernel (' // &
                 str(8.0_dp * n_packed * op%n_frequencies / 1.0e9_dp) // ' GB on this rank)')
      return
    end if
    ! Packed entry e -> the unknowns (row(e), column(e)) in slots (s, t), s <= t.
    allocate (row(n_packed), column(n_packed), unknown(nb), odd(n_packed))
    do i = 1, nb
      unknown(op%slot(i)) = i
    end do
    e = 0
    do t = 1, nb
      do s = 1, t
        e = e + 1
        row(e) = unknown(s)
        column(e) = unknown(t)
        odd(e) = s <= op%n_even .and. t > op%n_even
      end do
    end do
    ! The 1/M of the inverse transform, folded into the kernel once.
    scale = 1.0_dp / (real(op%box(1), dp) * op%box(2) * op%box(3))

    n_batches = (n_packed - 1) / nb + 1
    do batch = 0, n_batches - 1
      op%real_data = 0.0_dp
      do k = 0, int(op%slab_planes) - 1
        do j = 0, op%box(2) - 1
          do i = 0, op%box(1) - 1
            call displacement_at([i, j, int(op%slab_start) + k], d, inside)
            if (.not. inside) cycle
            site = padded_site(op, i, j, k)
            first = batch * nb + 1
            last = min(batch * nb + nb, n_packed)
            call lattice_block_entries(op%table, d, row(first:last), column(first:last), &
                                       op%real_data(site * nb + 1:site * nb + last - first + 1))
          end do
        end do
      end do
      call fftw_mpi_execute_dft_r2c(op%forward, op%real_data, op%spectrum)
      ! Even entries have a real transform, odd (even-odd slot) ones an imaginary one; the
      ! other part is rounding. Frequency-outer: contiguous writes into the kernel.
      do f = 1, op%n_frequencies
        do c = 1, min(nb, n_packed - batch * nb)
          e = batch * nb + c
          if (odd(e)) then
            op%kernel(e, f) = scale * aimag(op%spectrum(c, f))
          else
            op%kernel(e, f) = scale * real(op%spectrum(c, f), dp)
          end if
        end do
      end do
      ! About every quarter of the batches.
      call progress_line(reporting .and. (4 * (batch + 1)) / n_batches /= (4 * batch) / n_batches, &
                         'FFT kernel: ' // str(min(batch * nb + nb, n_packed)) // ' of ' // &
                         str(n_packed) // ' entries transformed (' // progress_seconds(MPI_Wtime() - start) // ' s)')
    end do

  contains

    !> The displacement (lattice axes) of padded site p (FFT dimension order), and whether it
    !> lies in the table's box [-span, span]^3.
    pure subroutine displacement_at(p, displacement, in_box)
      integer, intent(in) :: p(3)
      integer, intent(out) :: displacement(3)
      logical, intent(out) :: in_box
      integer :: a, axis, s
      in_box = .true.
      do a = 1, 3
        axis = op%axes(a)
        s = op%table%span(axis)
        if (p(a) <= s) then
          displacement(axis) = p(a)
        else if (p(a) >= op%box(a) - s) then
          displacement(axis) = p(a) - op%box(a)
        else
          in_box = .false.
          displacement(axis) = 0
        end if
      end do
    end subroutine displacement_at
  end subroutine transform_kernel

  !> 0-based index of padded site (i, j, k) in this rank's real slab (k counted from the slab
  !> start); the fast dimension has 2 (n/2 + 1) slots (FFTW's in-place r2c padding).
  pure integer(i8) function padded_site(op, i, j, k)
    type(fft_operator_t), intent(in) :: op
    integer, intent(in) :: i, j, k
    padded_site = i + int(2 * (op%box(1) / 2 + 1), i8) * (j + int(op%box(2), i8) * k)
  end function padded_site

  !> The PETSc vector over the real slabs (this rank's part = its slab, no copy) and the scatter
  !> from the bead-distributed vector to it, built once. A VecScatter rather than MPI_Alltoallv:
  !> PETSc works out once which entries cross ranks and to whom, sends only those (beads whose
  !> slab is local are copied), overlaps the messages, and the same object runs in reverse for
  !> the result; an Alltoallv would repack counts and buffers on every product.
  subroutine make_slab_scatter(comm, op, err)
    MPI_Comm, intent(in) :: comm
    type(fft_operator_t), intent(inout) :: op
    type(error_t), intent(inout) :: err
    PetscErrorCode :: ierr
    PetscInt :: slab_length, vector_start, vector_end, first_row, n_rows
    PetscInt, allocatable :: targets(:)
    integer :: rank, n_ranks, nb, owner, l(3), a
    integer(i8) :: info(3), bead, i
    integer(i8), allocatable :: all_info(:, :)
    IS :: from, to
    Vec :: template

    nb = op%block_size
    call MPI_Comm_rank(comm, rank, ierr)
    call MPI_Comm_size(comm, n_ranks, ierr)
    slab_length = int(nb * padded_site(op, 0, 0, int(op%slab_planes)))
    PetscCallA(VecCreateMPIWithArray(comm, 1, slab_length, PETSC_DECIDE, op%real_data, op%slab, ierr))
    PetscCallA(VecGetOwnershipRange(op%slab, vector_start, vector_end, ierr))
    info = [int(vector_start, i8), int(op%slab_start, i8), int(op%slab_planes, i8)]
    allocate (all_info(3, 0:n_ranks - 1))
    call MPI_Allgather(info, 3, MPI_INTEGER8, all_info, 3, MPI_INTEGER8, comm, ierr)

    allocate (targets(op%n_local * nb))
    do i = 1, op%n_local
      bead = op%first_bead + i - 1
      l = op%table%lattice(op%axes, bead)   ! fast, middle, slow
      owner = -1
      do a = 0, n_ranks - 1
        if (l(3) >= all_info(2, a) .and. l(3) < all_info(2, a) + all_info(3, a)) owner = a
      end do
      if (owner < 0) then
        call raise(err, 'internal error: no FFT slab holds lattice plane ' // str(l(3)))
        PetscCallA(VecDestroy(op%slab, ierr))
        return
      end if
      do a = 1, nb
        targets((i - 1) * nb + a) = int(all_info(1, owner) + &
                                        nb * padded_site(op, l(1), l(2), int(l(3) - all_info(2, owner))) + &
                                        op%slot(a) - 1)
      end do
    end do
    first_row = int((op%first_bead - 1) * nb)
    n_rows = int(op%n_local * nb)
    PetscCallA(ISCreateStride(comm, n_rows, first_row, 1, from, ierr))
    PetscCallA(ISCreateGeneral(comm, n_rows, targets, PETSC_COPY_VALUES, to, ierr))
    PetscCallA(VecCreateMPI(comm, n_rows, PETSC_DETERMINE, template, ierr))
    PetscCallA(VecScatterCreate(template, from, op%slab, to, op%to_slab, ierr))
    PetscCallA(VecDestroy(template, ierr))
    PetscCallA(ISDestroy(from, ierr))
    PetscCallA(ISDestroy(to, ierr))
  end subroutine make_slab_scatter

  !> MATOP_MULT: y = A x.
  subroutine apply_fft_operator(matrix, x, y, ierr)
    Mat :: matrix
    Vec :: x, y
    PetscErrorCode :: ierr
    type(fft_operator_t), pointer :: op
    PetscScalar, pointer :: local_x(:), local_y(:), slab(:)
    integer(i8) :: i, row
    integer :: nb

    PetscCall(MatShellGetContext(matrix, op, ierr))
    nb = op%block_size
    ! Sites without a bead hold zero; the scatter fills the bead sites.
    PetscCall(VecGetArrayF90(op%slab, slab, ierr))
    op%real_data = 0.0_dp
    PetscCall(VecRestoreArrayF90(op%slab, slab, ierr))
    PetscCall(VecScatterBegin(op%to_slab, x, op%slab, INSERT_VALUES, SCATTER_FORWARD, ierr))
    PetscCall(VecScatterEnd(op%to_slab, x, op%slab, INSERT_VALUES, SCATTER_FORWARD, ierr))

    ! The FFTs write the array behind the PETSc vector: bracket them with Get/Restore so that
    ! PETSc's object state (cached norms etc.) knows.
    PetscCall(VecGetArrayF90(op%slab, slab, ierr))
    call fftw_mpi_execute_dft_r2c(op%forward, op%real_data, op%spectrum)
    if (associated(op%shared_kernel)) then
      call multiply_spectrum(nb, op%n_even, op%n_frequencies, op%shared_kernel, op%spectrum, op%kernel_map)
    else
      call multiply_spectrum(nb, op%n_even, op%n_frequencies, op%kernel, op%spectrum)
    end if
    call fftw_mpi_execute_dft_c2r(op%backward, op%spectrum, op%real_data)
    PetscCall(VecRestoreArrayF90(op%slab, slab, ierr))

    PetscCall(VecScatterBegin(op%to_slab, op%slab, y, INSERT_VALUES, SCATTER_REVERSE, ierr))
    PetscCall(VecScatterEnd(op%to_slab, op%slab, y, INSERT_VALUES, SCATTER_REVERSE, ierr))

    PetscCall(VecGetArrayReadF90(x, local_x, ierr))
    PetscCall(VecGetArrayF90(y, local_y, ierr))
    do i = 1, op%n_local
      row = (i - 1) * nb
      local_y(row + 1:row + nb) = local_y(row + 1:row + nb) + matmul(op%self_block, local_x(row + 1:row + nb))
    end do
    PetscCall(VecRestoreArrayF90(y, local_y, ierr))
    PetscCall(VecRestoreArrayReadF90(x, local_x, ierr))
    ierr = 0
  end subroutine apply_fft_operator

  !> spectrum(:, f) <- K^(f) spectrum(:, f) for every frequency f; K^(f) is kernel(:, f), or with
  !> `map` (a companion) kernel(map, f), gathered into a fixed-size copy (no temporary per frequency).
  pure subroutine multiply_spectrum(nb, n_even, n_frequencies, kernel, spectrum, map)
    integer, intent(in) :: nb, n_even
    integer(i8), intent(in) :: n_frequencies
    real(dp), intent(in) :: kernel(:, :)
    complex(C_DOUBLE_COMPLEX), intent(inout) :: spectrum(:, :)
    integer, intent(in), optional :: map(:)
    real(dp) :: gathered(nb * (nb + 1) / 2)
    integer(i8) :: f
    if (present(map)) then
      do f = 1, n_frequencies
        gathered = kernel(map, f)
        call multiply_frequency(nb, n_even, gathered, spectrum(:, f))
      end do
    else
      do f = 1, n_frequencies
        call multiply_frequency(nb, n_even, kernel(:, f), spectrum(:, f))
      end do
    end if
  end subroutine multiply_spectrum

  !> x <- K^ x, K^ = [R_ee, i J_eo; -i J_eo^T, R_oo] from its packed upper triangle `packed`
  !> (module header), in real arithmetic: with K' = [R_ee, J_eo; J_eo^T, R_oo] (the packed numbers
  !> themselves, real symmetric) and x = u + i v,
  !>   K' [u_e; -v_o] = [Re y_e; -Im y_o],   K' [v_e; u_o] = [Im y_e; Re y_o],
  !> two real vectors through one pass over the triangle: column t gives w(:, s) += K'(s, t) z(:, t)
  !> for s < t and, by symmetry, w(:, t) += K'(s, t) z(:, s).
  pure subroutine multiply_frequency(nb, n_even, packed, spectrum)
    integer, intent(in) :: nb, n_even
    real(dp), intent(in) :: packed(:)
    complex(C_DOUBLE_COMPLEX), intent(inout) :: spectrum(:)
    real(dp) :: z(2, nb), w(2, nb), k_st, column_sum(2)
    integer :: s, t, top
    z(1, 1:n_even) = real(spectrum(1:n_even), dp)
    z(2, 1:n_even) = aimag(spectrum(1:n_even))
    z(1, n_even + 1:nb) = -aimag(spectrum(n_even + 1:nb))
    z(2, n_even + 1:nb) = real(spectrum(n_even + 1:nb), dp)
    w = 0.0_dp
    top = 0
    do t = 1, nb
      column_sum = 0.0_dp
      do s = 1, t - 1
        k_st = packed(top + s)
        w(:, s) = w(:, s) + k_st * z(:, t)
        column_sum = column_sum + k_st * z(:, s)
      end do
      w(:, t) = w(:, t) + column_sum + packed(top + t) * z(:, t)
      top = top + t
    end do
    spectrum(1:n_even) = cmplx(w(1, 1:n_even), w(2, 1:n_even), kind=C_DOUBLE_COMPLEX)
    spectrum(n_even + 1:nb) = cmplx(w(2, n_even + 1:nb), -w(1, n_even + 1:nb), kind=C_DOUBLE_COMPLEX)
  end subroutine multiply_frequency
end module beadmob_fft_operator
