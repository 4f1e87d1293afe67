!> What a friction job will cost before it is run: unknowns, FFT box, memory per rank and wall
!> time, from the sizes of the bead model alone (no operator is built). The dry run
!> (`beadmob --estimate`) prints it; every run compares its memory with what the node has and
!> refuses, before allocating, a job that cannot fit (docs/scaling.md, "Know before you run").
!>
!> Memory per rank, largest rank (docs/scaling.md lists what each term holds): the program, the
!> replicated geometry, the vectors, and what the operator reports (multipole_operator_t%cost:
!> fft_operator.F90, bead_operator.F90, pfft_operator.F90; the companion of the error bar,
!> theory.md T14, while the order-L operator is still held). Time: the operator's set-up and
!> product times (operator_cost.f90: rates measured on this project's 2-core machine,
!> bench/scaling/scaling.md, "Estimate against measurement"), CG iterations ~ a N^0.17.
module beadmob_job_estimate
  use beadmob_kinds, only: dp, i8
  use beadmob_multipole_basis, only: basis_size
  use beadmob_multipole_operator, only: multipole_operator_t
  use beadmob_operator_catalog, only: new_operator
  use beadmob_operator_cost, only: job_size_t, operator_cost_t
  implicit none
  private
  public :: job_estimate_t, estimate_job

  ! Memory constants (bytes), fitted to the peak resident sets of bench/scaling/scaling.md.
  real(dp), parameter :: base_bytes = 45.0e6_dp          ! MPI, PETSc, HDF5, FFTW and the program itself
  real(dp), parameter :: geometry_bytes_per_bead = 120.0_dp   ! replicated positions, lattice, indexes
  real(dp), parameter :: vectors_per_unknown = 26.0_dp   ! 18 motion vectors + Krylov work + scatters
  !> With the flow (theory.md T19): 15 strain vectors and the lockstep work of five systems (4
  !> each) beside the motions' 18, which stay for the grand resistance
  real(dp), parameter :: flow_vectors_per_unknown = 27.0_dp
  !> An order-1 flow job's pair sum for the beads' own stresslets (bead_stresslet.f90), per pair
  !> of a rank's bead with any bead: 2.42 s for 16210 beads on 2 ranks, 4.91 s on 1 (theory.md T19)
  real(dp), parameter :: bead_stresslet_seconds_per_pair = 1.9e-8_dp
  ! Largest CG iteration count of the solves, a N_solve^p: the full model (bench/scaling/scaling.md before
  ! the shell default: 18 at 1e3 to 37 at 1e5 beads) and the one-layer shell (11 at 354 beads in
  ! the solve to 18 at 4e4).
  real(dp), parameter :: full_iterations(2) = [5.2_dp, 0.17_dp], shell_iterations(2) = [6.0_dp, 0.104_dp]
  !> The companion's iterations relative to the order-L solve's (started from its solution:
  !> 13, 10, 16, 18 against 17, 14, 22, 19 on the paper cone)
  real(dp), parameter :: companion_iteration_ratio = 0.8_dp
  !> The Krylov tolerance the iteration counts above were measured at. A tighter one takes
  !> iterations in proportion to r = log(rtol) / log(fitted_rtol) (CG's error falls geometrically;
  !> 300 jittered beads at L = 1: 14 iterations at 1e-3, 85 at 1e-11). A looser one ends in CG's
  !> slow start, r^looser_exponent: the control solves of continuum jobs (order L - 1 at 1e-2)
  !> took 0.38 (median; 0.26-0.47) of the order-L solve's iterations at 1e-3 over 64 levels of
  !> 270-112k beads (bench/continuum/coverage_control_runs, nonconvex_control_aligned_runs), a
  !> 13.4k-bead cross at L = 1 51 against 135; r alone says 0.67.
  real(dp), parameter :: fitted_rtol = 1.0e-3_dp, looser_exponent = 2.4_dp

  type :: job_estimate_t
    integer(i8) :: n_beads = 0, solve_beads = 0, unknowns = 0
    integer :: unknowns_per_bead = 0, n_ranks = 1, n_solves = 6, iterations = 0
    integer :: strain_solves = 0   ! a flow job's five (theory.md T19), 0 otherwise
    character(len=16) :: operator_name = ''
    integer :: fft_box(3) = 0                 ! padded box (slow axis last); 0 without an FFT
    integer :: frequency_lines = 0            ! spectrum lines split over the ranks
    logical :: by_mirror_class = .false.      ! FFT products by mirror class
    logical :: replicated = .false.           ! the operator whole on every rank (replicated_operator.F90)
    integer(i8) :: canonical_blocks = 0       ! blocks by quadrature (lattice models)
    !> Per rank, largest rank (bytes)
    real(dp) :: base = 0, geometry = 0, blocks = 0, kernel = 0, fft_buffer = 0, transposes = 0, vectors = 0, peak = 0
    real(dp) :: companion = 0                 ! the error bar's companion (0: none)
    real(dp) :: seconds_blocks = 0, seconds_solve = 0, seconds_companion = 0, seconds_total = 0
  end type job_estimate_t

contains

  !> n_beads: all beads (replicated geometry); solve_beads, spans: the beads in the solve and
  !> their lattice spans (max - min of the integer coordinates; off the lattice: the pfft grid's,
  !> else ignored); operator_name: as chosen for the job (its cost: multipole_operator_t%cost);
  !> n_solves: Krylov solves (6, fewer with motions or symmetries).
  !> shell: a shell model (fewer CG iterations); oversubscription: ranks per processor on the
  !> busiest node (>= 1), which the times scale by. companion: the error bar's companion solve of
  !> order L - 1 is made too. near_radius: the pfft operator's.
  !> Memory per rank: base + geometry N + what the operator holds + the largest of its set-up's
  !> transient need, the vectors and the companion (its operator, vectors and start).
  function estimate_job(n_beads, solve_beads, spans, on_lattice, order, potential_order, operator_name, &
                        n_ranks, n_solves, shell, oversubscription, companion, near_radius, mirrors, replicated, &
                        krylov_rtol, strain_solves) result(e)
    integer(i8), intent(in) :: n_beads, solve_beads
    integer, intent(in) :: spans(3), order, potential_order, n_ranks, n_solves
    logical, intent(in) :: shell, companion
    real(dp), intent(in) :: oversubscription
    logical, intent(in) :: on_lattice
    character(len=*), intent(in) :: operator_name
    real(dp), intent(in), optional :: near_radius
    logical, intent(in), optional :: mirrors(3)   ! lattice axes along which the solve beads are symmetric
    !> The operator whole on every rank: its cost on one rank, each rank multiplying its share of
    !> a batch, ceil(n_solves / P) of the n_solves vectors, with their whole copies
    logical, intent(in), optional :: replicated
    !> The solves' Krylov tolerance (default: the one the iteration counts were fitted at)
    real(dp), intent(in), optional :: krylov_rtol
    !> The five strain solves of a flow job (theory.md T19) after the motions' (default 0)
    integer, intent(in), optional :: strain_solves
    type(job_estimate_t) :: e
    class(multipole_operator_t), allocatable :: op
    type(job_size_t) :: size
    type(operator_cost_t) :: cost
    real(dp) :: products, low_products, share
    integer :: strains

    e%n_beads = n_beads
    e%solve_beads = solve_beads
    e%unknowns_per_bead = basis_size(order, potential_order)
    e%unknowns = solve_beads * e%unknowns_per_bead
    e%n_ranks = max(n_ranks, 1)
    e%n_solves = n_solves
    e%operator_name = operator_name
    size%solve_beads = solve_beads
    size%local_beads = real((solve_beads + e%n_ranks - 1) / e%n_ranks, dp)
    size%n_ranks = e%n_ranks
    size%order = order
    size%nb = real(e%unknowns_per_bead, dp)
    if (companion .and. order >= 2) size%nb_low = real(basis_size(order - 1, max(potential_order - 1, 0)), dp)
    size%spans = spans
    size%solves = n_solves
    size%on_lattice = on_lattice
    if (present(near_radius)) size%near_radius = near_radius
    if (present(mirrors)) size%mirrors = mirrors
    if (present(replicated)) e%replicated = replicated .and. e%n_ranks > 1
    if (e%replicated) then
      size%n_ranks = 1
      size%local_beads = real(solve_beads, dp)
    end if
    call new_operator(operator_name, op)
    call op%cost(size, cost)
    if (e%replicated) then
      share = real((n_solves + e%n_ranks - 1) / e%n_ranks, dp) / max(n_solves, 1)
      cost%seconds_product = cost%seconds_product * share
      cost%seconds_low_product = cost%seconds_low_product * share
      size%local_beads = real((solve_beads + e%n_ranks - 1) / e%n_ranks, dp)
    end if

    e%base = base_bytes
    e%geometry = geometry_bytes_per_bead * n_beads
    strains = 0
    if (present(strain_solves)) strains = strain_solves
    e%strain_solves = strains
    e%vectors = vectors_per_unknown * 8 * size%local_beads * size%nb
    if (strains > 0) e%vectors = e%vectors + flow_vectors_per_unknown * 8 * size%local_beads * size%nb
    if (e%replicated) e%vectors = e%vectors + 2 * 8 * share * n_solves * real(solve_beads, dp) * size%nb
    e%canonical_blocks = cost%canonical_blocks
    e%fft_box = cost%fft_box
    e%frequency_lines = cost%frequency_lines
    e%by_mirror_class = cost%by_mirror_class
    e%blocks = cost%blocks + cost%transient
    e%kernel = cost%kernel
    e%fft_buffer = cost%fft_buffer
    e%transposes = cost%transposes
    if (size%nb_low > 0) e%companion = cost%companion + (vectors_per_unknown + 6) * 8 * size%local_beads * size%nb_low
    e%peak = e%base + e%geometry + cost%blocks + e%kernel + e%fft_buffer + e%transposes + &
             max(cost%transient, e%vectors, e%companion)
    if (shell) then
      e%iterations = ceiling(shell_iterations(1) * real(max(solve_beads, 1_i8), dp)**shell_iterations(2))
    else
      e%iterations = ceiling(full_iterations(1) * real(max(solve_beads, 1_i8), dp)**full_iterations(2))
    end if
    if (present(krylov_rtol)) then
      if (krylov_rtol > 0.0_dp .and. krylov_rtol < 1.0_dp) &
        e%iterations = ceiling(e%iterations * (log(krylov_rtol) / log(fitted_rtol))**merge(looser_exponent, 1.0_dp, &
                                                                                            krylov_rtol > fitted_rtol))
    end if
    products = real(n_solves + strains, dp) * (e%iterations + 1) + (6 - n_solves)   ! + the true-residual products
    low_products = real(n_solves + strains, dp) * (companion_iteration_ratio * e%iterations + 1) + (6 - n_solves)
    e%seconds_blocks = cost%seconds_setup * max(oversubscription, 1.0_dp)
    e%seconds_solve = products * cost%seconds_product * max(oversubscription, 1.0_dp)
    if (strains > 0 .and. order == 1) e%seconds_solve = e%seconds_solve + bead_stresslet_seconds_per_pair * &
                                                        size%local_beads * real(solve_beads, dp) * max(oversubscription, 1.0_dp)
    if (size%nb_low > 0) e%seconds_companion = low_products * cost%seconds_low_product * max(oversubscription, 1.0_dp)
    e%seconds_total = e%seconds_blocks + e%seconds_solve + e%seconds_companion
  end function estimate_job
end module beadmob_job_estimate
