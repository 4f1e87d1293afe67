!> What an operator will cost before it is built (the operator part of the dry run,
!> job_estimate.f90): the sizes of a job, the measured rates of this project's 2-core machine
!> (bench/scaling/scaling.md, "Estimate against measurement"; another machine scales them by its speed),
!> and the memory and time terms each operator reports through multipole_operator_t%cost.
module beadmob_operator_cost
  use beadmob_kinds, only: dp, i8
  use beadmob_block_table, only: canonical_count
  use beadmob_axial_table, only: axial_nodes
  implicit none
  private
  public :: job_size_t, operator_cost_t, canonical_blocks_of, quadrature_seconds, transform_bytes, lattice_blocks_seconds
  public :: fill_seconds, fft_seconds, multiply_seconds, direct_seconds, transpose_fraction, fft_field_seconds, &
            lattice_block_seconds, lattice_entry_seconds

  ! Rates (seconds) measured on the development machine (one core per rank).
  real(dp), parameter :: quadrature_seconds_l2 = 6.5e-4_dp  ! one canonical block at L = 2
  real(dp), parameter :: fill_seconds = 5.0e-8_dp      ! one packed kernel entry of one site (113081-bead sphere)
  real(dp), parameter :: fft_seconds = 0.75e-9_dp      ! per field, per site and log2(sites), one transform
  real(dp), parameter :: multiply_seconds = 1.5e-9_dp  ! per packed entry and frequency
  real(dp), parameter :: direct_seconds = 1.0e-9_dp    ! per block entry of the direct product (off the lattice)
  !> The lattice direct product, whose blocks come from a table in cache: per block a fixed part
  !> and a part per entry (fitted to the friction jobs of lattice bodies of 200-925 beads at
  !> L = 1, 2, 3, bench/operator_check/lattice_crossover.md: 1.2x and 1.7x below 1e-9 per entry)
  real(dp), parameter :: lattice_block_seconds = 8.6e-9_dp, lattice_entry_seconds = 0.6e-9_dp
  !> The FFT products' fixed cost per field and vector (the transforms' calls on small boxes and
  !> the transposes' messages), which decides at a few dozen beads (the same bench: 20-50 beads)
  real(dp), parameter :: fft_field_seconds = 7.0e-6_dp
  !> The transposes of FFTW-MPI (more than one rank) hold message buffers of about half the FFT
  !> buffer on the largest rank (fitted to the 2-rank peaks of bench/scaling/scaling.md).
  real(dp), parameter :: transpose_fraction = 0.5_dp

  !> The sizes an operator's cost depends on.
  type :: job_size_t
    integer(i8) :: solve_beads = 0          ! beads in the solve
    real(dp) :: local_beads = 0             ! on the largest rank
    integer :: n_ranks = 1
    integer :: order = 2                    ! L
    real(dp) :: nb = 0, nb_low = 0          ! unknowns per bead; the companion's (0: none)
    integer :: spans(3) = 0                 ! lattice spans (lattice models) or the pfft grid's
    logical :: on_lattice = .false.
    real(dp) :: near_radius = 0             ! the pfft operator's radius of exact pairs (d)
    integer :: solves = 6                   ! motions solved together (a batched product's vectors)
    logical :: mirrors(3) = .false.         ! lattice axes along which the solve beads are symmetric
  end type job_size_t

  !> Per rank, largest rank: bytes held while the solves run (blocks: pair blocks or canonical
  !> blocks; kernel: the FFT kernel or the block table), bytes held only during the set-up
  !> (transient), and the companion's operator; seconds of the set-up and of one product.
  type :: operator_cost_t
    real(dp) :: blocks = 0, kernel = 0, fft_buffer = 0, transposes = 0, transient = 0, companion = 0
    real(dp) :: seconds_setup = 0, seconds_product = 0, seconds_low_product = 0
    integer(i8) :: canonical_blocks = 0     ! canonical blocks computed (lattice models)
    integer :: fft_box(3) = 0               ! padded box, slow axis last (0: no FFT)
    integer :: frequency_lines = 0          ! middle-axis lines of the spectrum split over the ranks
    logical :: by_mirror_class = .false.    ! the FFT operator's products by mirror class
  end type operator_cost_t

contains

  !> One block by quadrature at order L (pair_blocks.f90), for a touching pair: the fields at the
  !> rule's points (~ points nb, 6.5e-4 s at L = 2) and their product, 6 points nb^2 flops at
  !> 25 Gflop/s (dgemm; measured 0.47 s at L = 16, 3.3 s at L = 24 against 0.63 and 4.5 here).
  pure real(dp) function quadrature_seconds(size)
    type(job_size_t), intent(in) :: size
    real(dp) :: points
    points = ((40 + 1.5_dp * (size%order + 3)) / (2 * log(2.0_dp)) + size%order + 8) * (2 * size%order + 8)
    quadrature_seconds = quadrature_seconds_l2 * points / 532 * size%nb / 16 + 6 * points * size%nb**2 / 2.5e10_dp
  end function quadrature_seconds

  !> The canonical blocks of a lattice model (block_table.f90): 2 L + 6 quadratures of the axial
  !> table, then each block turned from it (about a hundredth of a quadrature), shared over the ranks.
  pure real(dp) function lattice_blocks_seconds(size, canonical_blocks)
    type(job_size_t), intent(in) :: size
    integer(i8), intent(in) :: canonical_blocks
    lattice_blocks_seconds = quadrature_seconds(size) * (axial_nodes(size%order) + real(canonical_blocks, dp) / 100) &
                             / size%n_ranks
  end function lattice_blocks_seconds

  !> Bytes of the 48 lattice symmetries' basis transforms (lattice_symmetry.f90), dense: held by
  !> the lattice block table and again by the motion symmetries (motion_symmetry.F90). At high L
  !> they are what a lattice job holds most of (0.25 GB at L = 16, 45 GB at L = 60).
  pure real(dp) function transform_bytes(size)
    type(job_size_t), intent(in) :: size
    transform_bytes = 2 * 48 * 8 * size%nb**2
  end function transform_bytes

  !> canonical_count of block_table, in 64-bit arithmetic: a box too large to build still gets
  !> its estimate (extent: the spans sorted descending).
  pure integer(i8) function canonical_blocks_of(spans)
    integer, intent(in) :: spans(3)
    real(dp) :: extent(3)
    extent = real([maxval(spans), sum(spans) - maxval(spans) - minval(spans), minval(spans)], dp)
    if (maxval(extent) < 2000.0_dp) then
      canonical_blocks_of = canonical_count(nint(extent))
    else   ! about (e1 e2 e3) / 6 for large boxes
      canonical_blocks_of = int(min((extent(1) + 1) * (extent(2) + 1) * (extent(3) + 1) / 6, 9.0e18_dp), i8)
    end if
  end function canonical_blocks_of
end module beadmob_operator_cost
