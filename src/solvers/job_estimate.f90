!> What a friction job will cost before it is run: unknowns, FFT box, memory per rank and wall
!> time, from the sizes of the bead model alone (no operator is built). The dry run
!> (`beadmob --estimate`) prints it; every run compares its memory with what the node has and
!> refuses, before allocating, a job that cannot fit (docs/scaling.md, "Know before you run").
!>
!> Memory per rank, largest rank (docs/scaling.md lists what each term holds):
!>   base + geometry N + kernel + buffer + transposes + max(canonical, vectors, companion)
!>                                                                                  (FFT operator)
!>   base + geometry N + canonical + expanded box table + vectors                     (direct, lattice)
!>   base + geometry N + N n_local nb^2 8 B + vectors                                 (direct, off-lattice)
!>   the FFT operator's terms for the grid + near pairs n_local (4/3) pi r^3 nb^2 8 B   (pfft, off-lattice)
!>     (at most one bead per d^3 within the near radius r: the lattice's density, above a
!>     jittered cluster's 0.75)
!> (the companion of the error bar, theory.md T14: its FFT buffer, transposes, vectors and start,
!> or for the direct operator its sub-blocks, while the order-L operator is still held)
!> with the FFT sizes of FFTW's slab decomposition (ceil(n/P) planes on the largest rank). Time:
!> quadrature per canonical block, kernel fill per site and entry, FFT and kernel product per
!> product, CG iterations ~ a N^0.17: rates measured on this project's 2-core machine
!> (bench/scaling.md, "Estimate against measurement"); another machine scales them by its speed.
module beadmob_job_estimate
  use beadmob_kinds, only: dp, i8
  use beadmob_multipole_basis, only: basis_size
  use beadmob_block_table, only: canonical_count
  use beadmob_fft_operator, only: fft_size
  implicit none
  private
  public :: job_estimate_t, estimate_job, fft_box_of_spans

  ! Memory constants (bytes), fitted to the peak resident sets of bench/scaling.md.
  real(dp), parameter :: base_bytes = 45.0e6_dp          ! MPI, PETSc, HDF5, FFTW and the program itself
  real(dp), parameter :: geometry_bytes_per_bead = 120.0_dp   ! replicated positions, lattice, indexes
  real(dp), parameter :: vectors_per_unknown = 26.0_dp   ! 18 motion vectors + Krylov work + scatters
  ! Rates (seconds) measured on the development machine (one core per rank).
  real(dp), parameter :: quadrature_seconds_l2 = 6.5e-4_dp  ! one canonical block at L = 2
  real(dp), parameter :: fill_seconds = 6.0e-9_dp      ! one packed kernel entry of one site
  real(dp), parameter :: fft_seconds = 0.75e-9_dp       ! per field, per site and log2(sites), one transform
  real(dp), parameter :: multiply_seconds = 1.5e-9_dp  ! per packed entry and frequency
  real(dp), parameter :: direct_seconds = 1.0e-9_dp    ! per block entry of the direct product
  ! Largest CG iteration count of the solves, a N_solve^p: the full model (bench/scaling.md before
  ! the shell default: 18 at 1e3 to 37 at 1e5 beads) and the one-layer shell (11 at 354 beads in
  ! the solve to 18 at 4e4).
  real(dp), parameter :: full_iterations(2) = [5.2_dp, 0.17_dp], shell_iterations(2) = [6.0_dp, 0.104_dp]
  !> The transposes of FFTW-MPI (more than one rank) hold message buffers of about half the FFT
  !> buffer on the largest rank (fitted to the 2-rank peaks of bench/scaling.md).
  real(dp), parameter :: transpose_fraction = 0.5_dp
  !> The companion's iterations relative to the order-L solve's (started from its solution:
  !> 13, 10, 16, 18 against 17, 14, 22, 19 on the paper cone)
  real(dp), parameter :: companion_iteration_ratio = 0.8_dp

  type :: job_estimate_t
    integer(i8) :: n_beads = 0, solve_beads = 0, unknowns = 0
    integer :: unknowns_per_bead = 0, n_ranks = 1, n_solves = 6, iterations = 0
    character(len=16) :: operator_name = ''
    integer :: fft_box(3) = 0                 ! padded box (slow axis last); 0 for the direct operator
    integer(i8) :: canonical_blocks = 0       ! blocks by quadrature (lattice models)
    !> Per rank, largest rank (bytes)
    real(dp) :: base = 0, geometry = 0, blocks = 0, kernel = 0, fft_buffer = 0, transposes = 0, vectors = 0, peak = 0
    real(dp) :: companion = 0                 ! the error bar's companion (0: none)
    real(dp) :: seconds_blocks = 0, seconds_solve = 0, seconds_companion = 0, seconds_total = 0
  end type job_estimate_t

contains

  !> The padded FFT box (fast, middle, slow axis: increasing sizes) of a bead set whose lattice
  !> spans are `spans` (as fft_operator's plan_transforms chooses it).
  pure function fft_box_of_spans(spans) result(box)
    integer, intent(in) :: spans(3)
    integer :: box(3), padded(3), a
    do a = 1, 3
      padded(a) = fft_size(max(2 * spans(a) + 1, 2))
    end do
    box = [minval(padded), sum(padded) - minval(padded) - maxval(padded), maxval(padded)]
  end function fft_box_of_spans

  !> n_beads: all beads (replicated geometry); solve_beads, spans: the beads in the solve and
  !> their lattice spans (max - min of the integer coordinates; ignored off the lattice);
  !> operator_name: 'fft', 'pfft' or 'direct' as chosen for the job (for 'pfft', spans are those
  !> of its grid and near_radius its radius of exact pairs); n_solves: Krylov solves (6, fewer
  !> with motions or symmetries).
  !> shell: a shell model (fewer CG iterations); oversubscription: ranks per processor on the
  !> busiest node (>= 1), which the times scale by. companion: the error bar's companion solve of
  !> order L - 1 is made too.
  pure function estimate_job(n_beads, solve_beads, spans, on_lattice, order, potential_order, operator_name, &
                             n_ranks, n_solves, shell, oversubscription, companion, near_radius) result(e)
    integer(i8), intent(in) :: n_beads, solve_beads
    integer, intent(in) :: spans(3), order, potential_order, n_ranks, n_solves
    logical, intent(in) :: shell, companion
    real(dp), intent(in) :: oversubscription
    logical, intent(in) :: on_lattice
    character(len=*), intent(in) :: operator_name
    real(dp), intent(in), optional :: near_radius
    type(job_estimate_t) :: e
    real(dp) :: nb, packed, local_beads, block_bytes, sites, frequencies, real_planes, freq_planes, quadrature, &
                products, product_seconds, extent(3), nb_low, low_products, low_product_seconds, low_buffer, near_pairs
    integer :: widths(3)

    e%n_beads = n_beads
    e%solve_beads = solve_beads
    e%unknowns_per_bead = basis_size(order, potential_order)
    e%unknowns = solve_beads * e%unknowns_per_bead
    e%n_ranks = max(n_ranks, 1)
    e%n_solves = n_solves
    e%operator_name = operator_name
    nb = real(e%unknowns_per_bead, dp)
    packed = nb * (nb + 1) / 2
    block_bytes = 8 * nb**2
    local_beads = real((solve_beads + e%n_ranks - 1) / e%n_ranks, dp)
    quadrature = quadrature_seconds_l2 * (nb / 16)**2 * ((order + 10.0_dp) * (2 * order + 10.0_dp)) / (12.0_dp * 14.0_dp)

    e%base = base_bytes
    e%geometry = geometry_bytes_per_bead * n_beads
    e%vectors = vectors_per_unknown * 8 * local_beads * nb
    if (shell) then
      e%iterations = ceiling(shell_iterations(1) * real(max(solve_beads, 1_i8), dp)**shell_iterations(2))
    else
      e%iterations = ceiling(full_iterations(1) * real(max(solve_beads, 1_i8), dp)**full_iterations(2))
    end if
    products = real(n_solves, dp) * (e%iterations + 1) + (6 - n_solves)   ! + the true-residual products
    nb_low = 0
    if (companion .and. order >= 2) nb_low = real(basis_size(order - 1, max(potential_order - 1, 0)), dp)
    low_products = real(n_solves, dp) * (companion_iteration_ratio * e%iterations + 1) + (6 - n_solves)

    if (on_lattice .or. operator_name == 'pfft') then
      ! Canonical displacements: c(k) <= the k-th largest span.
      extent = real([maxval(spans), sum(spans) - maxval(spans) - minval(spans), minval(spans)], dp)
      e%canonical_blocks = canonical_blocks_of(extent)
      e%blocks = block_bytes * e%canonical_blocks
    else
      e%canonical_blocks = 0
    end if

    if (operator_name == 'fft' .or. operator_name == 'pfft') then
      e%fft_box = fft_box_of_spans(spans)
      sites = product(real(e%fft_box, dp))
      ! FFTW slabs: real space split along the slow axis, the transposed spectrum along the middle one.
      real_planes = real(ceiling(real(e%fft_box(3), dp) / e%n_ranks), dp)
      freq_planes = real(ceiling(real(e%fft_box(2), dp) / e%n_ranks), dp)
      frequencies = freq_planes * e%fft_box(3) * (e%fft_box(1) / 2 + 1)
      e%kernel = 8 * packed * frequencies
      e%fft_buffer = 16 * nb * max(frequencies, real_planes * e%fft_box(2) * (e%fft_box(1) / 2 + 1))
      if (e%n_ranks > 1) e%transposes = transpose_fraction * e%fft_buffer
      low_buffer = e%fft_buffer * nb_low / nb
      if (nb_low > 0) e%companion = low_buffer * merge(1 + transpose_fraction, 1.0_dp, e%n_ranks > 1) + &
                                    (vectors_per_unknown + 6) * 8 * local_beads * nb_low
      e%peak = e%base + e%geometry + e%kernel + e%fft_buffer + e%transposes + max(e%blocks, e%vectors, e%companion)
      widths = 2 * spans + 1
      e%seconds_blocks = quadrature * e%canonical_blocks / e%n_ranks &
                         + fill_seconds * packed * product(real(widths, dp)) / e%n_ranks &
                         + ceiling(packed / nb) * fft_seconds * nb * sites * log(sites) / log(2.0_dp) / e%n_ranks
      product_seconds = (2 * fft_seconds * nb * sites * log(sites) / log(2.0_dp) &
                         + multiply_seconds * packed * sites / 2) / e%n_ranks
      low_product_seconds = (2 * fft_seconds * nb_low * sites * log(sites) / log(2.0_dp) &
                             + multiply_seconds * nb_low * (nb_low + 1) / 2 * sites / 2) / e%n_ranks
      if (operator_name == 'pfft' .and. present(near_radius)) then
        ! the near-pair corrections (and the companion's), in the blocks term: held from set-up on
        near_pairs = local_beads * min(real(solve_beads, dp), 4.0_dp / 3.0_dp * acos(-1.0_dp) * near_radius**3)
        e%blocks = e%blocks + near_pairs * (block_bytes + 8 * nb_low**2)
        e%peak = e%base + e%geometry + e%kernel + e%fft_buffer + e%transposes + e%blocks + max(e%vectors, e%companion)
        ! per pair: its share of one BLAS product over 343 kernel blocks, and its turned block
        e%seconds_blocks = e%seconds_blocks + near_pairs * (0.1_dp * direct_seconds * nb**2 * 343 + quadrature / 100)
        product_seconds = product_seconds + direct_seconds * nb**2 * near_pairs
        low_product_seconds = low_product_seconds + direct_seconds * nb_low**2 * near_pairs
      end if
    else
      if (on_lattice) then
        widths = 2 * spans + 1
        e%kernel = block_bytes * product(real(widths, dp))   ! the expanded box table, on every rank
        e%seconds_blocks = quadrature * e%canonical_blocks / e%n_ranks
      else
        e%kernel = block_bytes * real(solve_beads, dp) * local_beads   ! one block per pair of this rank's rows
        e%seconds_blocks = quadrature * real(solve_beads, dp) * local_beads
      end if
      ! The companion copies its sub-blocks while the order-L ones are held.
      if (nb_low > 0) e%companion = e%kernel * (nb_low / nb)**2 + (vectors_per_unknown + 6) * 8 * local_beads * nb_low
      e%peak = e%base + e%geometry + e%blocks + e%kernel + max(e%vectors, e%companion)
      product_seconds = direct_seconds * nb**2 * real(solve_beads, dp) * local_beads
      low_product_seconds = product_seconds * (nb_low / nb)**2
    end if
    e%seconds_blocks = e%seconds_blocks * max(oversubscription, 1.0_dp)
    e%seconds_solve = products * product_seconds * max(oversubscription, 1.0_dp)
    if (nb_low > 0) e%seconds_companion = low_products * low_product_seconds * max(oversubscription, 1.0_dp)
    e%seconds_total = e%seconds_blocks + e%seconds_solve + e%seconds_companion
  end function estimate_job

  !> canonical_count of block_table, in 64-bit arithmetic: a box too large to build still gets
  !> its estimate.
  pure integer(i8) function canonical_blocks_of(extent)
    real(dp), intent(in) :: extent(3)
    if (maxval(extent) < 2000.0_dp) then
      canonical_blocks_of = canonical_count(nint(extent))
    else   ! about (e1 e2 e3) / 6 for large boxes
      canonical_blocks_of = int(min((extent(1) + 1) * (extent(2) + 1) * (extent(3) + 1) / 6, 9.0e18_dp), i8)
    end if
  end function canonical_blocks_of
end module beadmob_job_estimate
