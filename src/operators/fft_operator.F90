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
!> Layout (slab decomposition): the padded box is stored in C order [n0][n1][n2][nb] (Fortran
!> (nb, n2, n1, n0)), the nb multipole fields interleaved so that each pass transforms all of
!> them; real space is split over ranks along n0, Fourier space along n1 (FFTW_MPI_TRANSPOSED_OUT's
!> layout), which saves the transpose back in both directions: the product is pointwise, so the
!> order of the frequencies never matters as long as the kernel is laid out the same way. The
!> products' transforms are pruned to the sites that can hold a bead (pruned_transform.f90); the
!> kernel, which fills the box, is transformed once from one octant of displacements by its mirror
!> parities into the same layout (kernel_spectrum.f90).
!> The mirror of the slow axis halves the kernel kept (find_mirror_signs).
!> On a bead set that is its own mirror image along two lattice axes, the products run by
!> mirror-parity class instead (theory.md T4, "Mirror classes"): those axes are the fast and the
!> middle one, each vector's classes are folded onto the fundamental beads and transformed by
!> cosine and sine transforms (mirror_classes.F90, mirror_transform.f90), and the kernel is kept
!> on the octant of frequencies (mirrored_product, multiply_classes).
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
  use beadmob_fftw
  use beadmob_lapack, only: dgemm
  use beadmob_pruned_transform, only: pruned_transform_t, size_pruned_transform, make_pruned_plans, free_pruned_plans, &
                                      pruned_forward_planes => forward_planes, pruned_forward_line => forward_line, &
                                      pruned_backward_line => backward_line, pruned_backward_planes => backward_planes, &
                                      destroy_pruned_transform
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_progress, only: progress_line, progress_seconds
  use beadmob_multipole_basis, only: multipole_basis_t, inversion_parity
  use beadmob_pair_blocks, only: self_block
  use beadmob_block_table, only: block_table_t, make_block_table, lattice_block
  use beadmob_kernel_spectrum, only: kernel_octant_t, kernel_spectrum
  use beadmob_frequency_rows, only: row_chunk, row_stride_of, rows_frequencies_innermost, chunk_product
  use beadmob_mirror_transform, only: mirror_transform_t, mirror_buffer_t, size_mirror_transform, make_mirror_plans, &
                                      mirror_forward_planes => forward_planes, mirror_forward_line => forward_line, &
                                      mirror_backward_line => backward_line, mirror_backward_planes => backward_planes, &
                                      make_mirror_buffer, destroy_mirror_buffer, &
                                      destroy_mirror_transform, n_classes, class_signs
  use beadmob_mirror_classes, only: mirror_classes_t, make_mirror_classes, destroy_mirror_classes, &
                                    classes_of, fold_class, unfold_class
  use beadmob_unit_lattice, only: lattice_tolerance, lattice_mirrors
  use beadmob_file_system, only: rename_file, remove_file
  use beadmob_multipole_operator, only: multipole_operator_t, operator_options_t
  use beadmob_operator_cost, only: job_size_t, operator_cost_t, canonical_blocks_of, lattice_blocks_seconds, &
                                   fill_seconds, &
                                   fft_seconds, multiply_seconds, transpose_fraction, transform_bytes, &
                                   fft_field_seconds
  implicit none
  private
  public :: fft_operator_t, create_fft_operator, destroy_fft_operator, fft_size, create_fft_companion, fft_cost


  !> The MATSHELL context: kernel, plans, buffer and scatter, set once.
  type, extends(multipole_operator_t) :: fft_operator_t
    !> The lattice (on_lattice, span, lattice, computed_blocks) and its compact block table (the
    !> canonical blocks), freed once the kernel is transformed.
    type(block_table_t) :: table
    integer :: axes(3) = [1, 2, 3]          ! lattice axis of the fast, middle and slow FFT dimension
    integer :: box(3) = 1                   ! padded size of the fast, middle and slow FFT dimension
    !> FFTW_MEASURE plans (timed trial transforms while planning, 11-20 % faster products at a
    !> set-up cost of about fifteen products, but the chosen algorithm, hence the rounding, may
    !> vary from run to run) or FFTW_ESTIMATE plans (reproducible to the last bit). Measured plans are
    !> remembered between runs in FFTW wisdom next to the table cache (<cache file>.fftw_wisdom;
    !> none without a cache): a later run on the same box plans at once (plans_from_wisdom).
    logical :: measure_plans = .true.
    !> The pruned transforms of the nb fields (pruned_transform.f90): buffer, plans, this rank's
    !> data planes and frequencies
    type(pruned_transform_t) :: transform
    !> Slots 1..n_even: the even block of the whole-box frequency product (even under inversion;
    !> the mirror classes' product marks its real block by slow_even instead)
    integer :: n_even = 0
    integer, allocatable :: slot(:)         ! field slot of each unknown
    logical, allocatable :: inversion_even(:)   ! by slot
    !> Mirror classes (mirror_classes.F90): the bead set is symmetric under the mirrors of the
    !> fast and the middle axis, and each product runs class by class on the mirror transform
    !> (mirror_transform.f90) instead of the pruned one. Slots are ordered by their signs
    !> (fast, middle, slow; order_by_mirrors); field_sign(slot, 1:2) the fast and middle ones; class_factor(e, c)
    !> the sign of packed entry e in class c relative to the kernel (theory.md T4).
    logical :: mirrored = .false.
    logical :: use_mirrors = .true.         ! set before create: mirror classes where they apply
    integer :: dense_pass_limit = -1        ! set before create (tests): size_mirror_transform's, -1 its rule
    type(mirror_transform_t) :: reduced
    type(mirror_buffer_t), allocatable :: buffers(:)   ! the first, then the batch's copies
    Vec, allocatable :: buffer_slabs(:)
    type(mirror_classes_t) :: classes
    real(dp), allocatable :: field_sign(:, :), class_factor(:, :)
    logical, allocatable :: slow_even(:)     ! by slot: even along the slow axis (real block)
    !> Sign of each slot's field under the mirror of the slow FFT axis, D = diag(mirror_sign):
    !> K^ at the mirrored frequency (k_slow -> -k_slow) is D K^ D, so the kernel is kept for
    !> k_slow <= n_slow / 2 only (module header).
    real(dp), allocatable :: mirror_sign(:)
    !> Upper triangle of K^(k) / M over slots, packed by columns (entry s + t(t-1)/2 for s <= t),
    !> for this rank's frequencies with k_slow <= n_slow / 2 ([lines][n_slow/2 + 1][n_fast/2 + 1]):
    !> the real part, or for an even-odd entry the imaginary part.
    !> Stored by rows (frequency_rows.f90): the row of n_fast/2 + 1 frequencies of each (line,
    !> k_slow) as (frequency padded to row_stride, packed entry).
    real(dp), allocatable :: kernel(:, :)
    integer :: row_stride = 0
    !> A companion (create_fft_companion) holds no kernel of its own: it reads its entries from
    !> its parent's, entry e of its packed triangle being kernel_map(e) of the parent's.
    real(dp), pointer, contiguous :: shared_kernel(:, :) => null()
    integer, allocatable :: kernel_map(:)
    !> The packed entries the frequency product reads (0-based, the kernel's or kernel_map - 1),
    !> and a factor of one for each (the whole-box product's)
    integer(C_INT), allocatable :: entry_read(:)
    real(dp), allocatable :: unit_factor(:)
    Vec :: slab          ! PETSc view of transform%slab (this rank's data planes)
    VecScatter :: to_slab
    logical :: created = .false.
    MPI_Comm :: comm
    !> Further copies of the transform for products of several vectors at once (apply_many),
    !> made on the first such product: the kernel is streamed once for all of them. At most
    !> max_copies in all, fewer where their buffers would cost more than a quarter of the kernel.
    type(pruned_transform_t), allocatable :: copies(:)
    Vec, allocatable :: copy_slabs(:)
    integer :: batch_wanted = 0   ! the batch size the copies (or class buffers) were made for
  contains
    procedure :: create => create_fft
    procedure :: create_companion => fft_companion
    procedure :: destroy => destroy_fft
    procedure :: apply_many => apply_fft_many
    procedure :: free_batches => free_copies
    procedure, nopass :: cost => fft_cost
  end type fft_operator_t

  !> Vectors one batched product transforms at most (the motions of a job).
  integer, parameter :: max_copies = 6
  !> Time of a cosine or sine pass of FFTW (mirror_transform.f90) against a complex transform of
  !> the same length and lines, as fft_seconds counts it (measured on the paper cone, 2 ranks).
  real(dp), parameter :: r2r_factor = 2.0_dp

  !> One spectrum of a batched product.
  type :: spectrum_ref_t
    complex(C_DOUBLE_COMPLEX), pointer, contiguous :: values(:, :) => null()
  end type spectrum_ref_t

  !> fftw_mpi_init once per process (a second call would be harmless but is not promised).
  logical, save :: fftw_mpi_started = .false.

  abstract interface
    !> Collective: the operator's transform plans with FFTW `flags`; made = all of them on every
    !> rank (otherwise none kept).
    subroutine make_plans_interface(comm, op, flags, made)
      import :: fft_operator_t, C_INT
      MPI_Comm, intent(in) :: comm
      type(fft_operator_t), intent(inout) :: op
      integer(C_INT), intent(in) :: flags
      logical, intent(out) :: made
    end subroutine make_plans_interface
  end interface

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
    this%use_mirrors = options%mirror_classes
    call create_fft_operator(comm, basis, centres, first_bead, n_local, this, matrix, err, options%report, &
                             keep_lattice=allocated(options%companion_unknowns))
    if (err%failed) return
    this%matrix = matrix
    this%on_lattice = .true.
    this%by_mirror_class = this%mirrored
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
  !> once the kernel is transformed), the packed kernel of this rank's frequencies, the FFT buffers
  !> (data planes, transposed data planes and one middle line's spectrum, pruned_transform.f90,
  !> and the batch's copies of them, make_copies)
  !> and FFTW-MPI's transposes; the companion's
  !> buffer. Time: quadrature per canonical block, kernel fill per site and entry, the kernel's
  !> octant transforms; per product the two pruned transforms of nb fields and the kernel product.
  pure subroutine fft_cost(size, cost)
    type(job_size_t), intent(in) :: size
    type(operator_cost_t), intent(out) :: cost
    real(dp) :: nb, packed, sites, freq_planes, data_planes, half, pruned
    integer :: data(3)
    if (count(size%mirrors) >= 2) then
      call mirrored_fft_cost(size, cost)
      return
    end if
    nb = size%nb
    packed = nb * (nb + 1) / 2
    cost%canonical_blocks = canonical_blocks_of(size%spans)
    cost%transient = 8 * nb**2 * cost%canonical_blocks + transform_bytes(size)
    call fft_box_and_data(size%spans, cost%fft_box, data)
    cost%frequency_lines = cost%fft_box(2)
    sites = product(real(cost%fft_box, dp))
    ! Per field, the flops of the pruned transform in units of a site's log2 (module header of
    ! pruned_transform.f90): the fast axis on the data rows, the middle on the data planes, the slow whole.
    pruned = (real(data(3), dp) * data(2) * cost%fft_box(1) * log(real(cost%fft_box(1), dp)) &
              + real(data(3), dp) * cost%fft_box(2) * cost%fft_box(1) * log(real(cost%fft_box(2), dp)) &
              + sites * log(real(cost%fft_box(3), dp))) / log(2.0_dp)
    ! FFTW slabs: real space split along the slow axis, the transposed spectrum along the middle one.
    half = cost%fft_box(1) / 2 + 1
    data_planes = real(ceiling(real(data(3), dp) / size%n_ranks), dp)
    freq_planes = real(ceiling(real(cost%fft_box(2), dp) / size%n_ranks), dp)
    ! k_slow <= n_slow / 2, each row padded to row_stride (frequency_rows.f90)
    cost%kernel = 8 * packed * freq_planes * (cost%fft_box(3) / 2 + 1) * row_stride_of(nint(half))
    cost%fft_buffer = 16 * nb * ((freq_planes * data(3) + data_planes * cost%fft_box(2)) * half &
                                 + 2 * cost%fft_box(3) * half)   ! and one middle line's scratch and spectrum
    if (size%n_ranks > 1) cost%transposes = transpose_fraction * cost%fft_buffer
    call batch_and_setup_cost(size, freq_planes, cost)
    cost%seconds_product = (2 * fft_seconds * nb * pruned + multiply_seconds * packed * sites / 2) / size%n_ranks &
                           + fft_field_seconds * nb
    cost%seconds_low_product = (2 * fft_seconds * size%nb_low * pruned &
                                + multiply_seconds * size%nb_low * (size%nb_low + 1) / 2 * sites / 2) / size%n_ranks &
                               + fft_field_seconds * size%nb_low
  end subroutine fft_cost

  !> fft_cost of an operator whose products run by mirror class (choose_axes, mirror_transform.f90):
  !> the kernel on the octant of frequencies with its middle-axis lines split over the ranks, one
  !> buffer per batched vector (the data planes, the transposed data planes, and the slow-axis
  !> scratch and spectrum of one middle line), and
  !> per product the cosine and sine passes of the fast axis on the fundamental data rows and of the
  !> middle axis on the data planes, the slow axis whole, and the kernel product on the octant.
  pure subroutine mirrored_fft_cost(size, cost)
    type(job_size_t), intent(in) :: size
    type(operator_cost_t), intent(out) :: cost
    real(dp) :: nb, packed, lines, planes, transforms
    integer :: axes(3), data(3), half(2), fundamental(2)
    nb = size%nb
    packed = nb * (nb + 1) / 2
    cost%canonical_blocks = canonical_blocks_of(size%spans)
    cost%transient = 8 * nb**2 * cost%canonical_blocks + transform_bytes(size)
    axes = mirror_axes(size%spans, size%mirrors)
    data = size%spans(axes) + 1
    cost%fft_box = mirror_box(data)
    half = cost%fft_box(1:2) / 2 + 1
    cost%frequency_lines = half(2)
    cost%by_mirror_class = .true.
    fundamental = (data(1:2) + 1) / 2
    lines = real(ceiling(real(half(2), dp) / size%n_ranks), dp)
    planes = real(ceiling(real(data(3), dp) / size%n_ranks), dp)
    cost%kernel = 8 * packed * lines * (cost%fft_box(3) / 2 + 1) * row_stride_of(half(1))   ! rows padded
    cost%fft_buffer = 8 * nb * (planes * half(2) * half(1) + lines * data(3) * half(1) &
                                + (cost%fft_box(3) + 2 * (cost%fft_box(3) / 2 + 1)) * half(1))
    if (size%n_ranks > 1) cost%transposes = transpose_fraction * cost%fft_buffer
    call batch_and_setup_cost(size, lines, cost)
    ! Per field, in the pruned transform's units (a site's log2): the passes of the fast and the
    ! middle axis count r2r_factor of a complex transform of their length, the slow pass a real one.
    transforms = (r2r_factor * (real(fundamental(2), dp) * data(3) * half(1) * log(real(cost%fft_box(1), dp)) &
                                + real(data(3), dp) * half(2) * half(1) * log(real(cost%fft_box(2), dp))) &
                  + real(half(2), dp) * half(1) * cost%fft_box(3) * log(real(cost%fft_box(3), dp))) / log(2.0_dp)
    cost%seconds_product = (2 * fft_seconds * nb * transforms + multiply_seconds * packed * &
                            half(2) * half(1) * (cost%fft_box(3) / 2 + 1)) / size%n_ranks + fft_field_seconds * nb
    cost%seconds_low_product = (2 * fft_seconds * size%nb_low * transforms + multiply_seconds * size%nb_low * &
                                (size%nb_low + 1) / 2 * half(2) * half(1) * (cost%fft_box(3) / 2 + 1)) / size%n_ranks &
                               + fft_field_seconds * size%nb_low
  end subroutine mirrored_fft_cost

  !> The terms fft_cost and mirrored_fft_cost share, from cost%fft_box, cost%kernel, one buffer
  !> (cost%fft_buffer) and the spectrum lines a rank holds: the kernel rounds' own scratch where the
  !> buffer cannot hold one entry (kernel_spectrum.f90: octant, what a rank sends and receives),
  !> the copies of the batch that solves the motions together (make_copies: one per further
  !> motion, within a quarter of the kernel or 64 MiB) for order L and the companion, and the
  !> set-up time: the blocks, then the kernel from its octant with the entries split over the
  !> ranks (each formed at the octant's displacements, three passes of extended lines and the
  !> exchange: about six transform units per point, measured on a 113081-bead sphere).
  pure subroutine batch_and_setup_cost(size, lines, cost)
    type(job_size_t), intent(in) :: size
    real(dp), intent(in) :: lines
    type(operator_cost_t), intent(inout) :: cost
    real(dp) :: nb, half, round_entry, copies, allowance, low_buffer, log_sites
    nb = size%nb
    half = cost%fft_box(1) / 2 + 1
    log_sites = log(product(real(cost%fft_box, dp))) / log(2.0_dp)
    round_entry = 8 * (product(real(cost%fft_box / 2 + 1, dp)) &
                       + (cost%fft_box(2) + size%n_ranks * lines) * (cost%fft_box(3) / 2 + 1) * half)
    if (round_entry > cost%fft_buffer) cost%transient = cost%transient + round_entry
    copies = real(min(max_copies, max(size%solves, 1)) - 1, dp)
    allowance = max(cost%kernel / 4, 2.0_dp**26)
    low_buffer = cost%fft_buffer * size%nb_low / nb
    cost%companion = low_buffer * merge(1 + transpose_fraction, 1.0_dp, size%n_ranks > 1)
    if (low_buffer > 0) cost%companion = cost%companion + low_buffer * min(copies, real(floor(allowance / low_buffer), dp))
    cost%fft_buffer = cost%fft_buffer * (1 + min(copies, real(floor(allowance / cost%fft_buffer), dp)))
    cost%seconds_setup = lattice_blocks_seconds(size, cost%canonical_blocks) &
                         + nb * (nb + 1) / 2 * (fill_seconds * product(real(size%spans + 1, dp)) &
                                                + 6 * fft_seconds * product(real(cost%fft_box / 2 + 1, dp)) * log_sites) &
                         / size%n_ranks
  end subroutine batch_and_setup_cost

  !> The padded box and the data box (span + 1 sites) in the FFT's axis order, as plan_transforms
  !> lays them (the axes sorted by padded size, the first of equal ones first).
  pure subroutine fft_box_and_data(spans, box, data)
    integer, intent(in) :: spans(3)
    integer, intent(out) :: box(3), data(3)
    integer :: axes(3)
    axes = fft_axes(spans)
    box = fft_padded(spans(axes))
    data = spans(axes) + 1
  end subroutine fft_box_and_data

  !> The lattice axes in FFT order: the largest padded axis is the slab (slow) axis and the next
  !> the Fourier-space slab axis, the most planes to split over ranks; the fast axis is halved by
  !> the r2c transform.
  pure function fft_axes(spans) result(axes)
    integer, intent(in) :: spans(3)
    integer :: axes(3), padded(3), a, b, swap
    padded = fft_padded(spans)
    axes = [1, 2, 3]
    do a = 1, 2
      do b = 1, 3 - a
        if (padded(axes(b)) > padded(axes(b + 1))) then
          swap = axes(b)
          axes(b) = axes(b + 1)
          axes(b + 1) = swap
        end if
      end do
    end do
  end function fft_axes

  !> Padded sizes of the given spans: at least 2 (FFTW's MPI planner returned no plan for a size-1
  !> dimension of flat or straight bead sets; 2 >= 2 span + 1 keeps the convolution exact).
  pure function fft_padded(spans) result(padded)
    integer, intent(in) :: spans(3)
    integer :: padded(3), a
    do a = 1, 3
      padded(a) = fft_size(max(2 * spans(a) + 1, 2))
    end do
  end function fft_padded

  subroutine destroy_fft(this)
    class(fft_operator_t), intent(inout) :: this
    Mat :: matrix
    matrix = this%matrix
    call destroy_fft_operator(this, matrix)
  end subroutine destroy_fft

  !> The padded size of an axis that FFTW transforms: the smallest n >= minimum whose prime
  !> factors are 2, 3, 5, 7 (smooth_size), or the next power of two where that is at most 5 %
  !> larger. FFTW's lines of a power-of-two size measure 1.5-3 times faster than those of the
  !> smooth sizes just below it (125: 3.3x, 250: 1.3-1.5x against 128 and 256;
  !> bench/fft_layout/fft_sizes.md), which gains more than the up to 5 % more frequencies cost.
  pure integer function fft_size(minimum)
    integer, intent(in) :: minimum
    integer :: power
    fft_size = smooth_size(minimum)
    power = 1
    do while (power < minimum)
      power = 2 * power
    end do
    if (100 * int(power, i8) <= 105 * int(fft_size, i8)) fft_size = power
  end function fft_size

  !> Smallest n >= minimum whose prime factors are 2, 3, 5, 7.
  pure integer function smooth_size(minimum)
    integer, intent(in) :: minimum
    integer :: rest, p
    integer, parameter :: primes(4) = [2, 3, 5, 7]
    smooth_size = max(minimum, 1)
    do
      rest = smooth_size
      do p = 1, size(primes)
        do while (mod(rest, primes(p)) == 0)
          rest = rest / primes(p)
        end do
      end do
      if (rest == 1) return
      smooth_size = smooth_size + 1
    end do
  end function smooth_size

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
    real(dp), allocatable :: axis_sign(:, :)

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
    if (.not. err%failed) call choose_axes(op)
    if (.not. err%failed .and. op%mirrored) call order_by_mirrors(op)
    if (.not. err%failed) call find_mirror_signs(op, axis_sign, err)
    if (.not. err%failed) then
      if (op%mirrored) then
        call plan_mirror_transform(comm, op, err)
      else
        call plan_transforms(comm, op, err)
      end if
    end if
    if (.not. err%failed) call transform_kernel(comm, op, axis_sign, err, reporting, start)
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
    companion%mirror_sign = parent%mirror_sign(slot_parent)
    companion%inversion_even = parent%inversion_even(slot_parent)
    companion%axes = parent%axes
    companion%mirrored = parent%mirrored
    companion%dense_pass_limit = parent%dense_pass_limit
    allocate (companion%kernel_map(size(unknowns) * (size(unknowns) + 1) / 2))
    do t = 1, size(unknowns)
      do s = 1, t
        ps = slot_parent(s)
        pt = slot_parent(t)
        companion%kernel_map(s + t * (t - 1) / 2) = ps + pt * (pt - 1) / 2
      end do
    end do
    if (companion%mirrored) then
      companion%field_sign = parent%field_sign(slot_parent, :)
      companion%slow_even = parent%slow_even(slot_parent)
      companion%class_factor = parent%class_factor(companion%kernel_map, :)
      call plan_mirror_transform(comm, companion, err)
      ! FFTW's slabs depend on the box and the ranks only, so the frequencies are the parent's.
      if (.not. err%failed .and. companion%reduced%n_frequencies /= parent%reduced%n_frequencies) &
        call raise(err, 'internal error: the FFT companion has other frequencies than its parent')
    else
      call plan_transforms(comm, companion, err)
      if (.not. err%failed .and. companion%transform%n_frequencies /= parent%transform%n_frequencies) &
        call raise(err, 'internal error: the FFT companion has other frequencies than its parent')
    end if
    companion%shared_kernel => parent%kernel
    companion%row_stride = parent%row_stride
    companion%entry_read = companion%kernel_map - 1
    allocate (companion%unit_factor(size(companion%kernel_map)), source=1.0_dp)
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

    if (.not. err%failed) then
      if (op%mirrored) then
        call make_class_maps(comm, op, err)
      else
        call make_slab_scatter(comm, op, err)
      end if
    end if
    ! the scatters hold the sites now
    if (allocated(op%table%lattice) .and. .not. keep_lattice) deallocate (op%table%lattice)
    failed_here = merge(1, 0, err%failed)
    call MPI_Allreduce(failed_here, failed_anywhere, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
    if (failed_anywhere /= 0) then
      if (.not. err%failed) call raise(err, 'the FFT operator could not be set up on another rank')
      call free_fftw(op)
      return
    end if

    op%comm = comm
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
      if (.not. op%mirrored) then
        PetscCallA(VecScatterDestroy(op%to_slab, ierr))
        PetscCallA(VecDestroy(op%slab, ierr))
      end if
      PetscCallA(MatDestroy(matrix, ierr))
      op%created = .false.
    end if
    call free_copies(op)
    call free_fftw(op)
    if (allocated(op%kernel)) deallocate (op%kernel)
    op%shared_kernel => null()
  end subroutine destroy_fft_operator

  subroutine free_fftw(op)
    type(fft_operator_t), intent(inout) :: op
    integer :: k
    PetscErrorCode :: ierr
    call destroy_pruned_transform(op%transform)
    call destroy_mirror_classes(op%classes)
    if (allocated(op%buffer_slabs)) then
      do k = 1, size(op%buffer_slabs)
        PetscCallA(VecDestroy(op%buffer_slabs(k), ierr))
      end do
      deallocate (op%buffer_slabs)
    end if
    if (allocated(op%buffers)) then
      do k = 1, size(op%buffers)
        call destroy_mirror_buffer(op%buffers(k))
      end do
      deallocate (op%buffers)
    end if
    call destroy_mirror_transform(op%reduced)
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
    allocate (op%slot(basis%size), op%inversion_even(basis%size))
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
      op%inversion_even(op%slot(a)) = even(a)
    end do
  end subroutine order_by_parity

  !> The kernel's storage rests on A(-d) = A(d)^T and A(-d) = P A(d) P: refuse a table that
  !> breaks them beyond rounding (e.g. a basis function without definite parity). A violation
  !> would be structural (every generic displacement shows it), so a sample suffices: about 512
  !> displacements spread over the half box (4096 took 4-7 % of a small lattice job),
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
    stride = max(1_i8, n_half / 512)
    do a = 1, op%block_size
      signs(a) = merge(1.0_dp, -1.0_dp, op%inversion_even(op%slot(a)))
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

  !> axis_sign(:, a): D_M of the mirror M of FFT axis a (a lattice symmetry, T4) is diagonal in
  !> the real basis, ±1 per unknown (cos and sin of m phi, and the (n + m) parity along z, keep or
  !> flip their sign), in slot order. A(M d) = D_M A(d) D_M makes every kernel entry even or odd
  !> along each axis (kernel_spectrum.f90; axis_sign is needed only to make the kernel) and gives
  !> K^ at the slow axis' mirrored frequency as D K^ D (op%mirror_sign, the slow axis' column).
  !> Refused if a D_M of the table is not such a diagonal (a basis without that structure).
  subroutine find_mirror_signs(op, axis_sign, err)
    type(fft_operator_t), intent(inout) :: op
    real(dp), allocatable, intent(out) :: axis_sign(:, :)
    type(error_t), intent(inout) :: err
    integer :: mirror, a, axis
    real(dp), parameter :: tolerance = 1.0e-10_dp
    if (.not. allocated(op%table%transforms)) then
      call raise(err, 'internal error: the FFT operator needs the lattice symmetries of its block table')
      return
    end if
    allocate (axis_sign(op%block_size, 3))
    do axis = 1, 3
      mirror = 1 + 2**(op%axes(axis) - 1)   ! identity permutation, one sign flipped (symmetry_matrix)
      associate (d => op%table%transforms(:, :, mirror))
        do a = 1, op%block_size
          axis_sign(op%slot(a), axis) = sign(1.0_dp, d(a, a))
        end do
        if (maxval(abs(abs(d) - identity(op%block_size))) > tolerance) then
          call raise(err, 'the FFT operator needs a basis that a mirror of the lattice maps onto ± itself; the ' // &
                     'mirror of lattice axis ' // str(op%axes(axis)) // ' mixes its functions by ' // &
                     str(maxval(abs(abs(d) - identity(op%block_size)))))
          return
        end if
      end associate
    end do
    op%mirror_sign = axis_sign(:, 3)
    if (op%mirrored) then
      op%field_sign = axis_sign(:, 1:2)
      op%slow_even = axis_sign(:, 3) > 0
    end if
  end subroutine find_mirror_signs

  pure function identity(n) result(matrix)
    integer, intent(in) :: n
    real(dp) :: matrix(n, n)
    integer :: k
    matrix = 0.0_dp
    do k = 1, n
      matrix(k, k) = 1.0_dp
    end do
  end function identity

  !> The compact table is needed only until the kernel is transformed.
  subroutine free_canonical_blocks(table)
    type(block_table_t), intent(inout) :: table
    if (allocated(table%canonical_blocks)) deallocate (table%canonical_blocks)
    if (allocated(table%canonical_id)) deallocate (table%canonical_id)
    if (allocated(table%blocks)) deallocate (table%blocks)
  end subroutine free_canonical_blocks

  !> Padded box, axis order, the pruned transforms' slabs, buffer and plans (pruned_transform.f90).
  subroutine plan_transforms(comm, op, err)
    MPI_Comm, intent(in) :: comm
    type(fft_operator_t), intent(inout) :: op
    type(error_t), intent(inout) :: err
    integer :: failed
    real(dp) :: entries
    PetscErrorCode :: ierr

    if (.not. fftw_mpi_started) then
      call fftw_mpi_init()
      fftw_mpi_started = .true.
    end if
    op%box = fft_padded(op%table%span(op%axes))
    ! PETSc's 32-bit indices address the vector of the data planes (nb doubles per padded site).
    entries = real(op%block_size, dp) * 2 * (op%box(1) / 2 + 1) * op%box(2) * op%box(3)
    if (entries > real(huge(1_C_INT), dp)) then
      call raise(err, 'the padded FFT box ' // str(op%box(1)) // ' x ' // str(op%box(2)) // ' x ' // str(op%box(3)) // &
                 ' with ' // str(op%block_size) // ' fields has more entries than 32-bit PETSc indices address')
      return
    end if
    call size_pruned_transform(comm, op%block_size, op%box, op%table%span(op%axes) + 1, op%transform, err)
    failed = merge(1, 0, err%failed)
    call MPI_Allreduce(MPI_IN_PLACE, failed, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
    if (failed /= 0) then
      if (.not. err%failed) call raise(err, 'the FFT buffer could not be allocated on another rank')
      return
    end if
    call plan_remembered(comm, op, pruned_plans, err)
  end subroutine plan_transforms

  !> make_plans_interface for the pruned transform (make_pruned_plans keeps none on failure).
  subroutine pruned_plans(comm, op, flags, made)
    MPI_Comm, intent(in) :: comm
    type(fft_operator_t), intent(inout) :: op
    integer(C_INT), intent(in) :: flags
    logical, intent(out) :: made
    call make_pruned_plans(comm, op%transform, flags, made)
  end subroutine pruned_plans

  !> make_plans_interface for the mirror transform, on its first buffer.
  subroutine mirror_plans(comm, op, flags, made)
    MPI_Comm, intent(in) :: comm
    type(fft_operator_t), intent(inout) :: op
    integer(C_INT), intent(in) :: flags
    logical, intent(out) :: made
    call make_mirror_plans(comm, op%reduced, op%buffers(1), flags, made)
    if (.not. made) call destroy_mirror_transform(op%reduced)   ! the plans only
  end subroutine mirror_plans

  !> Collective. The operator's plans by `make_plans` with its planner; measured plans from the
  !> wisdom remembered with the table cache where it has them (FFTW_WISDOM_ONLY: none if the box
  !> is new to it), else planned and the wisdom remembered.
  subroutine plan_remembered(comm, op, make_plans, err)
    MPI_Comm, intent(in) :: comm
    type(fft_operator_t), intent(inout) :: op
    procedure(make_plans_interface) :: make_plans
    type(error_t), intent(inout) :: err
    integer(C_INT) :: planner
    logical :: made
    character(len=:), allocatable :: wisdom_file
    planner = merge(FFTW_MEASURE, FFTW_ESTIMATE, op%measure_plans)
    wisdom_file = wisdom_path(op)
    op%plans_from_wisdom = .false.
    if (len(wisdom_file) > 0) then
      call recall_wisdom(comm, wisdom_file)
      call make_plans(comm, op, ior(planner, FFTW_WISDOM_ONLY), op%plans_from_wisdom)
    end if
    made = op%plans_from_wisdom
    if (.not. made) call make_plans(comm, op, planner, made)
    if (.not. made) then
      call raise(err, 'FFTW could not plan the ' // str(op%box(1)) // ' x ' // str(op%box(2)) // ' x ' // &
                 str(op%box(3)) // ' transforms')
    else if (len(wisdom_file) > 0 .and. .not. op%plans_from_wisdom) then
      call remember_wisdom(comm, wisdom_file)
    end if
  end subroutine plan_remembered

  !> The FFTW wisdom file next to the table cache ('' without a cache or with estimated plans).
  function wisdom_path(op) result(path)
    type(fft_operator_t), intent(in) :: op
    character(len=:), allocatable :: path
    path = ''
    if (op%measure_plans .and. allocated(op%table%cache_file)) then
      if (len_trim(op%table%cache_file) > 0) path = trim(op%table%cache_file) // '.fftw_wisdom'
    end if
  end function wisdom_path

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

  !> K^ = FFT(K) / M for the upper triangle over slots at this rank's frequencies with
  !> k_slow <= n_slow / 2, from the octant of displacements by the mirror parities of the
  !> entries (kernel_spectrum.f90); the operator's buffer, not needed before the first product,
  !> is the rounds' scratch.
  subroutine transform_kernel(comm, op, axis_sign, err, reporting, start)
    MPI_Comm, intent(in) :: comm
    type(fft_operator_t), intent(inout) :: op
    real(dp), intent(in) :: axis_sign(:, :)   ! (slot, FFT axis), find_mirror_signs
    type(error_t), intent(inout) :: err
    logical, intent(in) :: reporting   ! a progress line about every quarter (rank 0)
    real(dp), intent(in) :: start      ! MPI_Wtime of the set-up's start
    type(kernel_octant_t) :: octant
    integer :: nb, n_packed, e, i, s, t, stat, failed, row_length
    integer, allocatable :: unknown(:)
    integer(i8) :: kept, rows
    PetscErrorCode :: ierr   ! also the MPI error code

    nb = op%block_size
    n_packed = nb * (nb + 1) / 2
    if (op%mirrored) then
      row_length = op%reduced%half(1)
      rows = op%reduced%lines * (op%box(3) / 2 + 1)
    else
      row_length = op%transform%half
      rows = op%transform%lines * (op%box(3) / 2 + 1)
    end if
    kept = rows * row_length
    op%row_stride = row_stride_of(row_length)
    allocate (op%kernel(n_packed, max(rows * op%row_stride, 1_i8)), stat=stat)
    ! Agreed on by the ranks before the collective transform.
    failed = merge(1, 0, stat /= 0)
    call MPI_Allreduce(MPI_IN_PLACE, failed, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
    if (stat /= 0) then
      call raise(err, 'could not allocate the FFT kernel (' // str(8.0_dp * n_packed * kept / 1.0e9_dp) // &
                 ' GB on this rank)')
      return
    else if (failed /= 0) then
      call raise(err, 'could not allocate the FFT kernel on another rank')
      return
    end if
    ! Packed entry e -> the unknowns (row(e), column(e)) in slots (s, t), s <= t, and its parity
    ! along each FFT axis.
    allocate (unknown(nb), octant%row(n_packed), octant%column(n_packed), octant%parity(n_packed, 3))
    do i = 1, nb
      unknown(op%slot(i)) = i
    end do
    e = 0
    do t = 1, nb
      do s = 1, t
        e = e + 1
        octant%row(e) = unknown(s)
        octant%column(e) = unknown(t)
        octant%parity(e, :) = nint(axis_sign(s, :) * axis_sign(t, :))
        ! The three mirrors make the inversion: an entry odd under it (an even-odd slot pair)
        ! is odd along an odd number of axes.
        if ((op%inversion_even(s) .neqv. op%inversion_even(t)) .neqv. mod(count(octant%parity(e, :) < 0), 2) == 1) then
          call raise(err, 'internal error: the lattice mirrors of kernel entry (' // str(s) // ', ' // str(t) // &
                     ') disagree with its inversion parity')
          return
        end if
      end do
    end do
    octant%box = op%box
    octant%axes = op%axes
    ! The 1/M of the inverse transform, folded into the kernel once.
    if (op%mirrored) then
      octant%first_line = op%reduced%first_line
      octant%lines = op%reduced%lines
      call kernel_spectrum(comm, op%table, octant, 1.0_dp / (real(op%box(1), dp) * op%box(2) * op%box(3)), &
                           op%buffers(1)%all, op%kernel(:, 1:kept), err, reporting, start)
      call find_class_factors(op, octant)
    else
      octant%first_line = op%transform%first_line
      octant%lines = op%transform%lines
      call kernel_spectrum(comm, op%table, octant, 1.0_dp / (real(op%box(1), dp) * op%box(2) * op%box(3)), &
                           op%transform%all, op%kernel(:, 1:kept), err, reporting, start)
    end if
    if (err%failed) return
    call rows_frequencies_innermost(size(op%kernel, kind=i8), op%kernel, n_packed, rows, row_length, op%row_stride)
    op%entry_read = [(e - 1, e = 1, n_packed)]
    allocate (op%unit_factor(n_packed), source=1.0_dp)
  end subroutine transform_kernel

  !> 0-based index of padded site (i, j, k) in this rank's data planes (k counted from its first
  !> plane); the fast dimension has 2 (n/2 + 1) slots (FFTW's in-place r2c padding).
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
    real(C_DOUBLE), pointer :: data_planes(:)

    nb = op%block_size
    call MPI_Comm_rank(comm, rank, ierr)
    call MPI_Comm_size(comm, n_ranks, ierr)
    slab_length = int(nb * padded_site(op, 0, 0, int(op%transform%planes)))
    ! From the data planes' place in the buffer (a rank without planes has a valid address too).
    data_planes => op%transform%all(op%transform%slab_offset + 1:)
    PetscCallA(VecCreateMPIWithArray(comm, 1, slab_length, PETSC_DECIDE, data_planes, op%slab, ierr))
    PetscCallA(VecGetOwnershipRange(op%slab, vector_start, vector_end, ierr))
    info = [int(vector_start, i8), int(op%transform%first_plane, i8), int(op%transform%planes, i8)]
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
    PetscCall(MatShellGetContext(matrix, op, ierr))
    call batched_product(op, [x], [y])
    ierr = 0
  end subroutine apply_fft_operator

  !> multipole_operator_t%apply_many: y(j) = A x(j), as many at once as there are copies of the
  !> transform (made on the first call, collective).
  subroutine apply_fft_many(this, x, y)
    class(fft_operator_t), target, intent(inout) :: this
    Vec, intent(in) :: x(:)
    Vec, intent(in) :: y(:)   ! PETSc handles: the vectors behind them are written
    integer :: first, batch
    if (size(x) == 0) return
    ! Buffers for as many vectors as the largest batch yet (up to max_copies): a first batch
    ! smaller than the later ones (a coarse space of two motions before six in lockstep) must not
    ! keep them at its size.
    if (size(x) > this%batch_wanted .and. this%batch_wanted < max_copies) then
      call free_copies(this)
      if (this%mirrored) then
        call make_class_buffers(this, size(x))
      else
        call make_copies(this, size(x))
      end if
      this%batch_wanted = min(size(x), max_copies)
    end if
    if (this%mirrored) then
      call mirrored_product(this, x, y)
      return
    end if
    batch = 1 + size(this%copies)
    do first = 1, size(x), batch
      call batched_product(this, x(first:min(first + batch - 1, size(x))), y(first:min(first + batch - 1, size(y))))
    end do
  end subroutine apply_fft_many

  !> Collective. Copies of the transform (plans, buffer, the PETSc view of its data planes) for
  !> batched products of up to `wanted` vectors: max_copies at most, and in no more memory than a
  !> quarter of the kernel's (or 64 MiB), so a large job keeps its memory per rank.
  subroutine make_copies(op, wanted)
    type(fft_operator_t), target, intent(inout) :: op
    integer, intent(in) :: wanted
    type(error_t) :: err
    integer :: n_copies, c, failed
    logical :: made
    real(C_DOUBLE), pointer :: data_planes(:)
    PetscInt :: slab_length
    PetscErrorCode :: ierr
    n_copies = copies_allowed(op, wanted, 8.0_dp * max(size(op%transform%all, kind=i8), 1_i8))
    allocate (op%copies(max(n_copies, 0)), op%copy_slabs(max(n_copies, 0)))
    do c = 1, size(op%copies)
      call size_pruned_transform(op%comm, op%block_size, op%box, op%transform%data, op%copies(c), err)
      failed = merge(1, 0, err%failed)
      call MPI_Allreduce(MPI_IN_PLACE, failed, 1, MPI_INTEGER, MPI_MAX, op%comm, ierr)
      made = failed == 0
      ! The plans of the first copy (in FFTW's memory as wisdom now): planning them again is quick.
      if (made) call make_pruned_plans(op%comm, op%copies(c), merge(FFTW_MEASURE, FFTW_ESTIMATE, op%measure_plans), &
                                       made)
      if (.not. made) then   ! no memory for it on some rank: fewer copies, the same products
        call destroy_pruned_transform(op%copies(c))
        op%copies = op%copies(1:c - 1)
        op%copy_slabs = op%copy_slabs(1:c - 1)
        exit
      end if
      slab_length = int(size(op%copies(c)%slab))
      data_planes => op%copies(c)%all(op%copies(c)%slab_offset + 1:)
      PetscCallA(VecCreateMPIWithArray(op%comm, 1, slab_length, PETSC_DECIDE, data_planes, op%copy_slabs(c), ierr))
    end do
  end subroutine make_copies

  !> Collective. Further buffers of buffer_bytes each for batches of up to `wanted` vectors (one
  !> is there already): max_copies in all at most, in no more than a quarter of the kernel's
  !> memory (or 64 MiB), the fewest any rank allows.
  integer function copies_allowed(op, wanted, buffer_bytes) result(n_copies)
    type(fft_operator_t), intent(in) :: op
    integer, intent(in) :: wanted
    real(dp), intent(in) :: buffer_bytes
    real(dp) :: allowance
    PetscErrorCode :: ierr
    allowance = 2.0_dp**26
    if (allocated(op%kernel)) allowance = max(allowance, 2.0_dp * size(op%kernel, kind=i8))
    if (associated(op%shared_kernel)) allowance = max(allowance, 2.0_dp * size(op%shared_kernel, kind=i8))
    n_copies = int(min(real(min(wanted, max_copies) - 1, dp), allowance / buffer_bytes))
    call MPI_Allreduce(MPI_IN_PLACE, n_copies, 1, MPI_INTEGER, MPI_MIN, op%comm, ierr)
  end function copies_allowed

  !> multipole_operator_t%free_batches: the copies of the transform (made again when needed).
  subroutine free_copies(this)
    class(fft_operator_t), intent(inout) :: this
    PetscErrorCode :: ierr
    integer :: c
    if (this%mirrored .and. allocated(this%buffers)) then
      do c = 2, size(this%buffers)
        PetscCallA(VecDestroy(this%buffer_slabs(c), ierr))
        call destroy_mirror_buffer(this%buffers(c))
      end do
      this%buffers = this%buffers(1:1)
      this%buffer_slabs = this%buffer_slabs(1:1)
    end if
    this%batch_wanted = 0
    if (.not. allocated(this%copies)) return
    do c = 1, size(this%copies)
      PetscCallA(VecDestroy(this%copy_slabs(c), ierr))
      call destroy_pruned_transform(this%copies(c))
    end do
    deallocate (this%copies, this%copy_slabs)
  end subroutine free_copies

  !> Collective. y(j) = A x(j), j = 1 .. size(x) <= 1 + size(op%copies): each x scattered to its
  !> copy's data planes and transformed, all spectra multiplied in one pass over the kernel,
  !> transformed back and gathered; then the self term S x.
  subroutine batched_product(op, x, y)
    type(fft_operator_t), target, intent(inout) :: op
    Vec, intent(in) :: x(:), y(:)   ! PETSc handles: the vectors behind y are written
    type(spectrum_ref_t) :: spectra(size(x))
    PetscScalar, pointer :: slab(:)
    PetscErrorCode :: ierr
    type(pruned_transform_t), pointer :: t
    integer :: j, nb, line

    if (op%mirrored) then
      call mirrored_product(op, x, y)
      return
    end if
    nb = op%block_size
    do j = 1, size(x)
      ! Sites without a bead hold zero; the scatter fills the bead sites.
      PetscCallA(VecGetArrayF90(slab_of(j), slab, ierr))
      slab = 0.0_dp
      PetscCallA(VecRestoreArrayF90(slab_of(j), slab, ierr))
      PetscCallA(VecScatterBegin(op%to_slab, x(j), slab_of(j), INSERT_VALUES, SCATTER_FORWARD, ierr))
      PetscCallA(VecScatterEnd(op%to_slab, x(j), slab_of(j), INSERT_VALUES, SCATTER_FORWARD, ierr))
    end do
    ! The FFTs write the arrays behind the PETSc vectors: bracket them with Get/Restore so that
    ! PETSc's object state (cached norms etc.) knows.
    do j = 1, size(x)
      PetscCallA(VecGetArrayF90(slab_of(j), slab, ierr))
      t => transform_of(j)
      call pruned_forward_planes(t)
      spectra(j)%values => t%spectrum
    end do
    ! The slow axis, the kernel's product and back, middle line by middle line: each line's
    ! spectra stay in cache between the transforms and the product.
    do line = 1, int(op%transform%lines)
      do j = 1, size(x)
        call pruned_forward_line(transform_of(j), line)
      end do
      if (associated(op%shared_kernel)) then
        call multiply_spectra(op, op%shared_kernel, spectra, line)
      else
        call multiply_spectra(op, op%kernel, spectra, line)
      end if
      do j = 1, size(x)
        call pruned_backward_line(transform_of(j), line)
      end do
    end do
    do j = 1, size(x)
      t => transform_of(j)
      call pruned_backward_planes(t)
      PetscCallA(VecRestoreArrayF90(slab_of(j), slab, ierr))
    end do
    do j = 1, size(x)
      PetscCallA(VecScatterBegin(op%to_slab, slab_of(j), y(j), INSERT_VALUES, SCATTER_REVERSE, ierr))
      PetscCallA(VecScatterEnd(op%to_slab, slab_of(j), y(j), INSERT_VALUES, SCATTER_REVERSE, ierr))
      call add_self_term(op, x(j), y(j))
    end do

  contains

    function transform_of(k) result(t)
      integer, intent(in) :: k
      type(pruned_transform_t), pointer :: t
      if (k == 1) then
        t => op%transform
      else
        t => op%copies(k - 1)
      end if
    end function transform_of

    function slab_of(k) result(v)
      integer, intent(in) :: k
      Vec :: v
      if (k == 1) then
        v = op%slab
      else
        v = op%copy_slabs(k - 1)
      end if
    end function slab_of
  end subroutine batched_product

  !> spectrum(:, f) <- K^(f) spectrum(:, f) for every frequency f of middle line `line` of every
  !> spectrum (the line's, pruned_transform.f90). K^(f) is the kernel's at the kept frequency g of
  !> f (a companion's entries of it: op%entry_read), times D on both sides where f is the mirror
  !> image of g (k_slow > n_slow / 2). Row by row of kept frequencies, in chunks of row_chunk
  !> (frequency_rows.f90), in the real form of the module header: K' [u_e; -v_o] = [Re y_e; -Im y_o],
  !> K' [v_e; u_o] = [Im y_e; Re y_o] for x = u + i v, and for the image D x' with D K' D.
  subroutine multiply_spectra(op, kernel, spectra, line)
    type(fft_operator_t), intent(in) :: op
    real(dp), intent(in), contiguous, target :: kernel(:, :)
    type(spectrum_ref_t), intent(in) :: spectra(:)
    integer, intent(in) :: line
    real(dp) :: z(row_chunk, 2, op%block_size), w(row_chunk, 2, op%block_size)
    real(dp), pointer, contiguous :: flat(:)
    integer(i8) :: row_start, f, image
    integer :: n_slow, half, slow, offset, n, j, t
    flat(1:size(kernel, kind=i8)) => kernel
    n_slow = op%box(3)
    half = op%transform%half
    z = 0   ! a last, shorter chunk leaves the rest zero
    do slow = 0, n_slow / 2
      row_start = (int(line - 1, i8) * (n_slow / 2 + 1) + slow) * size(kernel, 1) * op%row_stride
      do offset = 0, half - 1, row_chunk
        n = min(row_chunk, half - offset)
        f = offset + int(half, i8) * slow                ! the chunk's frequencies f + 1 .. f + n
        image = offset + int(half, i8) * (n_slow - slow)
        do j = 1, size(spectra)
          associate (x => spectra(j)%values)
            do t = 1, op%block_size
              call to_real_form(x(t, f + 1:f + n), t <= op%n_even, 1.0_dp, z(:, :, t))
            end do
            call chunk_product(op%block_size, op%row_stride, flat(row_start + offset + 1:), op%entry_read, &
                               op%unit_factor, z, w)
            do t = 1, op%block_size
              call from_real_form(w(:, :, t), t <= op%n_even, 1.0_dp, x(t, f + 1:f + n))
            end do
            if (slow == 0 .or. 2 * slow == n_slow) cycle   ! the row is its own image
            do t = 1, op%block_size
              call to_real_form(x(t, image + 1:image + n), t <= op%n_even, op%mirror_sign(t), z(:, :, t))
            end do
            call chunk_product(op%block_size, op%row_stride, flat(row_start + offset + 1:), op%entry_read, &
                               op%unit_factor, z, w)
            do t = 1, op%block_size
              call from_real_form(w(:, :, t), t <= op%n_even, op%mirror_sign(t), x(t, image + 1:image + n))
            end do
          end associate
        end do
      end do
    end do
  end subroutine multiply_spectra

  !> One field's values x = u + i v at a chunk's frequencies, times factor, as the two real
  !> columns chunk_product (frequency_rows.f90) multiplies, in the real form of the module
  !> header: (u, v) for a field even along the slow axis, (-v, u), i.e. -i x, for an odd one. The
  !> rows of z past size(x) are left as they are.
  pure subroutine to_real_form(x, slow_even, factor, z)
    complex(C_DOUBLE_COMPLEX), intent(in) :: x(:)
    logical, intent(in) :: slow_even
    real(dp), intent(in) :: factor
    real(dp), intent(inout) :: z(:, :)   ! (row_chunk, 2)
    integer :: n
    n = size(x)
    if (slow_even) then
      z(1:n, 1) = factor * real(x, dp)
      z(1:n, 2) = factor * aimag(x)
    else
      z(1:n, 1) = -factor * aimag(x)
      z(1:n, 2) = factor * real(x, dp)
    end if
  end subroutine to_real_form

  !> The inverse of to_real_form: x = factor (w1 + i w2) for an even field, factor i (w1 + i w2)
  !> for an odd one.
  pure subroutine from_real_form(w, slow_even, factor, x)
    real(dp), intent(in) :: w(:, :)      ! (row_chunk, 2)
    logical, intent(in) :: slow_even
    real(dp), intent(in) :: factor
    complex(C_DOUBLE_COMPLEX), intent(inout) :: x(:)
    integer :: n
    n = size(x)
    if (slow_even) then
      x = factor * cmplx(w(1:n, 1), w(1:n, 2), kind=C_DOUBLE_COMPLEX)
    else
      x = factor * cmplx(w(1:n, 2), -w(1:n, 1), kind=C_DOUBLE_COMPLEX)
    end if
  end subroutine from_real_form

  !> The FFT axes (op%axes) and whether the products run in mirror classes (op%mirrored): when
  !> the bead set is its own mirror image along at least two lattice axes, two of them are the
  !> fast and the middle axis (the smaller fast), the other the slow one (of three, the largest).
  subroutine choose_axes(op)
    type(fft_operator_t), intent(inout) :: op
    logical :: mirrors(3)
    op%axes = fft_axes(op%table%span)
    op%mirrored = .false.
    if (.not. op%use_mirrors) return
    mirrors = lattice_mirrors(op%table%lattice, op%table%span)
    op%mirrored = count(mirrors) >= 2
    if (op%mirrored) op%axes = mirror_axes(op%table%span, mirrors)
  end subroutine choose_axes

  !> The FFT axes of products by mirror class (two mirrored lattice axes among `mirrors` fast
  !> and middle, the other slow; of three, the largest slow: the most planes to split).
  pure function mirror_axes(spans, mirrors) result(axes)
    integer, intent(in) :: spans(3)
    logical, intent(in) :: mirrors(3)
    integer :: axes(3), slow, a
    axes = fft_axes(spans)
    slow = axes(3)
    do a = 1, 3
      if (.not. mirrors(a)) slow = a
    end do
    axes = [pack(axes, axes /= slow), slow]   ! fft_axes' order: smaller first
  end function mirror_axes

  !> The padded box of products by mirror class for `data` sites per FFT axis: the fast and the
  !> middle even (mirror_transform.f90), each >= 2 data - 1 (the convolution stays exact).
  pure function mirror_box(data) result(box)
    integer, intent(in) :: data(3)
    integer :: box(3)
    box = [even_fft_size(max(2 * data(1) - 1, 2)), even_fft_size(max(2 * data(2) - 1, 2)), &
           fft_size(max(2 * data(3) - 1, 2))]
  end function mirror_box

  !> Slots by the unknowns' mirror signs along the fast, the middle and the slow axis (even
  !> first, stable): the fields of equal fast signs, and of equal fast and middle signs, are
  !> consecutive runs of the mirror transform (two and four runs for every class).
  subroutine order_by_mirrors(op)
    type(fft_operator_t), intent(inout) :: op
    integer :: key(op%block_size), a, axis, new_slot(op%block_size)
    logical :: inversion(op%block_size)
    integer, parameter :: weight(3) = [4, 2, 1]   ! fast, middle, slow
    key = 0
    do axis = 1, 3
      associate (d => op%table%transforms(:, :, 1 + 2**(op%axes(axis) - 1)))
        do a = 1, op%block_size
          if (d(a, a) < 0) key(a) = key(a) + weight(axis)
        end do
      end associate
    end do
    do a = 1, op%block_size
      new_slot(a) = 1 + count(key < key(a)) + count(key(1:a - 1) == key(a))
    end do
    inversion = op%inversion_even
    do a = 1, op%block_size
      op%inversion_even(new_slot(a)) = inversion(op%slot(a))
    end do
    op%slot = new_slot
  end subroutine order_by_mirrors

  !> Smallest even n >= minimum whose prime factors are 2, 3, 5, 7.
  pure integer function even_fft_size(minimum)
    integer, intent(in) :: minimum
    even_fft_size = smooth_size(minimum)
    do while (mod(even_fft_size, 2) /= 0)
      even_fft_size = smooth_size(even_fft_size + 1)
    end do
  end function even_fft_size

  !> Collective. The mirror transform's box (fast and middle even), layout, first buffer and
  !> plans (mirror_transform.f90).
  subroutine plan_mirror_transform(comm, op, err)
    MPI_Comm, intent(in) :: comm
    type(fft_operator_t), intent(inout) :: op
    type(error_t), intent(inout) :: err
    integer :: data(3), failed
    real(dp) :: entries
    logical :: made
    PetscErrorCode :: ierr

    if (.not. fftw_mpi_started) then
      call fftw_mpi_init()
      fftw_mpi_started = .true.
    end if
    data = op%table%span(op%axes) + 1
    op%box = mirror_box(data)
    entries = real(op%block_size, dp) * (op%box(1) / 2 + 1) * (op%box(2) / 2 + 1) * op%box(3)
    if (entries > real(huge(1_C_INT), dp)) then
      call raise(err, 'the FFT box ' // str(op%box(1)) // ' x ' // str(op%box(2)) // ' x ' // str(op%box(3)) // &
                 ' with ' // str(op%block_size) // ' fields has more entries than 32-bit PETSc indices address')
      return
    end if
    ! The products fold and unfold the beads' sites only (mirror_classes.F90).
    call size_mirror_transform(comm, nint(op%field_sign), op%box, data, op%reduced, err, op%dense_pass_limit, &
                               sites=op%table%lattice(op%axes, :))
    allocate (op%buffers(1), op%buffer_slabs(0))
    made = .not. err%failed
    if (made) call make_mirror_buffer(op%reduced, op%buffers(1), made)
    failed = merge(0, 1, made)
    call MPI_Allreduce(MPI_IN_PLACE, failed, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
    if (failed /= 0) then
      if (.not. err%failed) call raise(err, 'the FFT buffer could not be allocated on some rank')
      return
    end if
    call plan_remembered(comm, op, mirror_plans, err)
  end subroutine plan_mirror_transform

  !> class_factor(e, c): in class c the product's packed entry e = (s, t) is the kernel's
  !> times (-1)^(sum_a o_t(a) (1 - o_s(a)) + m + [m >= 2] + m_slow), o(a) = 1 for a field odd
  !> along mirrored axis a in the class, m the entry's odd axes, m_slow 1 if odd along the slow
  !> one: the transform's -i of each sine transform, moved from the fields into the kernel
  !> (theory.md T4, "Mirror classes"), and the kernel's own sign convention (kernel_spectrum.f90).
  subroutine find_class_factors(op, octant)
    type(fft_operator_t), intent(inout) :: op
    type(kernel_octant_t), intent(in) :: octant
    integer :: e, c, a, s, t, exponent, m, class_sign(2), odd_s, odd_t
    allocate (op%class_factor(size(octant%row), n_classes))
    e = 0
    do t = 1, op%block_size
      do s = 1, t
        e = e + 1
        m = count(octant%parity(e, :) < 0)
        do c = 1, n_classes
          class_sign = class_signs(c)
          ! K' of the module header: K = i K' at (slow-even s, slow-odd t), -i K' at (odd, even)
          exponent = m + merge(1, 0, m >= 2) + merge(1, 0, op%slow_even(s) .and. .not. op%slow_even(t))
          do a = 1, 2
            odd_s = merge(1, 0, class_sign(a) * op%field_sign(s, a) < 0)
            odd_t = merge(1, 0, class_sign(a) * op%field_sign(t, a) < 0)
            exponent = exponent + odd_t * (1 - odd_s)
          end do
          op%class_factor(e, c) = merge(1.0_dp, -1.0_dp, mod(exponent, 2) == 0)
        end do
      end do
    end do
  end subroutine find_class_factors

  !> Collective. The PETSc vector over the first buffer's data planes and the beads' classes.
  subroutine make_class_maps(comm, op, err)
    MPI_Comm, intent(in) :: comm
    type(fft_operator_t), intent(inout) :: op
    type(error_t), intent(inout) :: err
    PetscErrorCode :: ierr
    PetscInt :: slab_length
    slab_length = int(op%reduced%planes * op%reduced%half(2) * op%reduced%row)
    deallocate (op%buffer_slabs)
    allocate (op%buffer_slabs(1))
    PetscCallA(VecCreateMPIWithArray(comm, 1, slab_length, PETSC_DECIDE, op%buffers(1)%slab, op%buffer_slabs(1), ierr))
    call make_mirror_classes(comm, op%table%lattice, op%axes, op%first_bead, op%n_local, op%slot, op%field_sign, &
                             op%reduced, op%buffer_slabs(1), op%classes, err)
  end subroutine make_class_maps

  !> Collective. Buffers for batched class products of up to `wanted` items, within the same
  !> allowance as the pruned transform's copies (make_copies).
  subroutine make_class_buffers(op, wanted)
    type(fft_operator_t), target, intent(inout) :: op
    integer, intent(in) :: wanted
    integer :: n_buffers, c, failed
    logical :: made
    type(mirror_buffer_t), allocatable :: buffers(:)
    Vec, allocatable :: slabs(:)
    PetscInt :: slab_length
    PetscErrorCode :: ierr
    n_buffers = 1 + copies_allowed(op, wanted, 8.0_dp * max(size(op%buffers(1)%all, kind=i8), 1_i8))
    allocate (buffers(n_buffers), slabs(n_buffers))
    buffers(1) = op%buffers(1)
    slabs(1) = op%buffer_slabs(1)
    slab_length = int(op%reduced%planes * op%reduced%half(2) * op%reduced%row)
    do c = 2, n_buffers
      call make_mirror_buffer(op%reduced, buffers(c), made)
      failed = merge(0, 1, made)
      call MPI_Allreduce(MPI_IN_PLACE, failed, 1, MPI_INTEGER, MPI_MAX, op%comm, ierr)
      if (failed /= 0) then   ! no memory for it on some rank: fewer buffers, the same products
        call destroy_mirror_buffer(buffers(c))
        n_buffers = c - 1
        exit
      end if
      PetscCallA(VecCreateMPIWithArray(op%comm, 1, slab_length, PETSC_DECIDE, buffers(c)%slab, slabs(c), ierr))
    end do
    op%buffers = buffers(1:n_buffers)
    op%buffer_slabs = slabs(1:n_buffers)
  end subroutine make_class_buffers

  !> Collective. y(j) = A x(j) class by class: each x(j) split into the classes it has (one for
  !> the solves' vectors, mirror_classes.F90), each class folded onto the fundamental sites of a
  !> buffer and transformed, all the batch's spectra multiplied in one pass over the kernel,
  !> transformed back and unfolded into y(j); then the self term S x.
  subroutine mirrored_product(op, x, y)
    type(fft_operator_t), target, intent(inout) :: op
    Vec, intent(in) :: x(:), y(:)   ! PETSc handles: the vectors behind y are written
    integer :: item_vector(n_classes * size(x)), item_class(n_classes * size(x)), classes(n_classes)
    integer :: n_items, n, j, k, first, batch, line
    logical :: started(size(x))
    PetscScalar, pointer :: slab(:)
    PetscErrorCode :: ierr

    n_items = 0
    do j = 1, size(x)
      call classes_of(op%classes, x(j), classes, n)
      item_vector(n_items + 1:n_items + n) = j
      item_class(n_items + 1:n_items + n) = classes(1:n)
      n_items = n_items + n
    end do
    started = .false.
    batch = size(op%buffers)
    do first = 1, n_items, batch
      n = min(batch, n_items - first + 1)
      do k = 1, n
        call fold_class(op%classes, x(item_vector(first + k - 1)), item_class(first + k - 1), op%buffer_slabs(k))
        ! The FFTs write the array behind the PETSc vector: bracketed by Get/Restore.
        PetscCallA(VecGetArrayF90(op%buffer_slabs(k), slab, ierr))
        call mirror_forward_planes(op%reduced, op%buffers(k), item_class(first + k - 1))
      end do
      ! The slow axis, the kernel's product and back, middle line by middle line: each line's
      ! spectra stay in cache between the transforms and the product.
      do line = 1, int(op%reduced%lines)
        do k = 1, n
          call mirror_forward_line(op%reduced, op%buffers(k), line)
        end do
        if (associated(op%shared_kernel)) then
          call multiply_classes(op, op%shared_kernel, item_class(first:first + n - 1), line)
        else
          call multiply_classes(op, op%kernel, item_class(first:first + n - 1), line)
        end if
        do k = 1, n
          call mirror_backward_line(op%reduced, op%buffers(k), line)
        end do
      end do
      do k = 1, n
        call mirror_backward_planes(op%reduced, op%buffers(k), item_class(first + k - 1))
        PetscCallA(VecRestoreArrayF90(op%buffer_slabs(k), slab, ierr))
        j = item_vector(first + k - 1)
        call unfold_class(op%classes, op%buffer_slabs(k), item_class(first + k - 1), y(j), started(j))
        started(j) = .true.
      end do
    end do
    do j = 1, size(x)
      call add_self_term(op, x(j), y(j))
    end do
  end subroutine mirrored_product

  !> y += S x for every bead of this rank: one product (nb x nb) x (nb x n_local).
  subroutine add_self_term(op, x, y)
    type(fft_operator_t), intent(in) :: op
    Vec, intent(in) :: x, y   ! PETSc handles: the vector behind y is written
    PetscScalar, pointer :: local_x(:), local_y(:)
    PetscErrorCode :: ierr
    integer :: nb
    nb = op%block_size
    PetscCallA(VecGetArrayReadF90(x, local_x, ierr))
    PetscCallA(VecGetArrayF90(y, local_y, ierr))
    if (op%n_local > 0) call dgemm('N', 'N', nb, int(op%n_local), nb, 1.0_dp, op%self_block, nb, local_x, nb, 1.0_dp, &
                                   local_y, nb)
    PetscCallA(VecRestoreArrayF90(y, local_y, ierr))
    PetscCallA(VecRestoreArrayReadF90(x, local_x, ierr))
  end subroutine add_self_term

  !> The spectra of middle line `line` of the first size(classes) buffers, buffer k of class
  !> classes(k), times the class's kernel frequency by frequency: row by row, in chunks of
  !> row_chunk frequencies (frequency_rows.f90), each buffer's chunk by the chunk of the kernel's
  !> row (a companion's entries of it: op%entry_read) signed by class_factor. A spectrum row holds
  !> the fast-axis frequencies of one k_slow with the fields at field_base + k field_step
  !> (mirror_transform.f90). In the real form of the module header, K = [R_ee, i J_eo; -i J_eo^T,
  !> R_oo] by the slots' parity along the slow axis.
  subroutine multiply_classes(op, kernel, classes, line)
    type(fft_operator_t), intent(inout) :: op
    real(dp), intent(in), contiguous, target :: kernel(:, :)
    integer, intent(in) :: classes(:), line
    real(dp) :: z(row_chunk, 2, op%block_size), w(row_chunk, 2, op%block_size)
    real(dp), pointer, contiguous :: flat(:)
    integer(i8) :: row_start
    integer :: k, t, half, row, offset, n, first, last, step
    flat(1:size(kernel, kind=i8)) => kernel
    half = op%reduced%half(1)
    z = 0   ! a last, shorter chunk leaves the rest zero
    do row = 1, op%box(3) / 2 + 1
      row_start = (int(line - 1, i8) * (op%box(3) / 2 + 1) + row - 1) * size(kernel, 1) * op%row_stride
      do offset = 0, half - 1, row_chunk
        n = min(row_chunk, half - offset)
        do k = 1, size(classes)
          associate (values => op%buffers(k)%spectrum(:, row))
            do t = 1, op%block_size
              step = op%reduced%field_step(t)
              first = 1 + op%reduced%field_base(t) + offset * step
              last = first + (n - 1) * step
              call to_real_form(values(first:last:step), op%slow_even(t), 1.0_dp, z(:, :, t))
            end do
            call chunk_product(op%block_size, op%row_stride, flat(row_start + offset + 1:), op%entry_read, &
                               op%class_factor(:, classes(k)), z, w)
            do t = 1, op%block_size
              step = op%reduced%field_step(t)
              first = 1 + op%reduced%field_base(t) + offset * step
              last = first + (n - 1) * step
              call from_real_form(w(:, :, t), op%slow_even(t), 1.0_dp, values(first:last:step))
            end do
          end associate
        end do
      end do
    end do
  end subroutine multiply_classes
end module beadmob_fft_operator
