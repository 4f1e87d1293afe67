!> The plan of a friction job, made once before anything large is allocated and followed by
!> everything after it: which beads are in the solve (all, or the shell model's surface layers),
!> the frame they are solved in (the model's coordinates, or the body frame of an off-lattice
!> body whose symmetries show only there), the operator, the solves its symmetries leave, and
!> the estimate of memory and time (job_estimate.f90). The dry run prints it, the memory check
!> refuses by it, the friction job runs it and the result file records it.
module beadmob_job_plan
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_parallel, only: run_context_t, agree_on_error
  use beadmob_unit_lattice, only: on_unit_lattice, lattice_mirrors
  use beadmob_shell_model, only: shell_mask
  use beadmob_body_frame, only: body_frame_t, compute_body_frame
  use beadmob_multipole_basis, only: basis_size
  use beadmob_dense_operator, only: dense_max_unknowns
  use beadmob_motion_symmetry, only: find_symmetry_group, solves_needed, n_symmetries, strain_sources
  use beadmob_linear_flow, only: n_strain_modes
  use beadmob_job_estimate, only: job_estimate_t, estimate_job
  use beadmob_friction_settings, only: friction_settings_t, automatic_shell_layers
  use beadmob_job_defaults, only: is_set
  use beadmob_pfft_operator, only: pfft_expected_error, pfft_radius_for
  use beadmob_strings, only: str, str_significant
  implicit none
  private
  public :: job_plan_t, make_job_plan, choose_operator, operator_spans, requested_accuracy, operator_share, solve_rtol

  !> Models of at most this many beads get the dense operator under 'auto' (choose_operator).
  integer, parameter :: dense_max_beads = 8
  !> The share of an accuracy target that an approximate operator may take (requested_accuracy):
  !> the rest is the truncation's, whose settings the target chose (accuracy_choice.f90)
  real(dp), parameter :: operator_share = 0.1_dp

  type :: job_plan_t
    integer(i8) :: model_beads = 0
    logical :: on_lattice = .false.
    !> The point the rigid motions turn about (the centre of mass of all beads)
    real(dp) :: reference_point(3) = 0.0_dp
    !> Surface layers of the shell model (0: all beads), automatic_shell_layers when the settings
    !> leave it open
    integer :: shell_layers = 0
    !> The beads of the solve, as indices into the model (all, or the shell model's)
    integer, allocatable :: solve_beads(:)
    !> Their centres in the solve frame (turned about the reference point into the body frame
    !> when body_frame)
    real(dp), allocatable :: solve_centres(:, :)
    logical :: body_frame = .false.
    !> The axes (columns, model coordinates) of the solve frame: the identity or the body axes
    real(dp) :: solve_axes(3, 3) = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], &
                                           [3, 3])
    !> direct, fft, pfft or dense
    character(len=16) :: operator_name = ''
    !> The pfft operator's near radius (d): the settings', or raised so that its far field meets
    !> the accuracy the job asks for (choose_operator)
    real(dp) :: pfft_near_radius = 0.0_dp
    !> Why this operator (and radius): a line for the dry run, the progress and the result file
    character(len=:), allocatable :: operator_reason
    !> The operator whole on every rank, batches of products dealt out to the ranks
    !> (replicated_operator.F90; choose_replication)
    logical :: replicated_products = .false.
    !> Krylov solves of the job: the requested motions less those its symmetries give (none are
    !> looked for with use_symmetry off or the dense operator, whose solve is exact); and the
    !> count in the model's own coordinates (equal unless body_frame)
    integer :: n_solves = 6, lab_solves = 6
    !> The lattice symmetries of the solve beads in the solve frame about the reference point
    !> (motion_symmetry.F90; found once, here, with use_symmetry; the job derives motions by them)
    logical :: symmetry_group(n_symmetries) = .false.
    !> The ranks the job is planned for
    integer :: n_ranks = 1
    type(job_estimate_t) :: estimate
  end type job_plan_t

contains

  !> Collective. The plan of the friction job of the model `centres` with `settings`, its rigid
  !> motions about reference_point (the driver: the centre of mass), on n_ranks
  !> ranks (oversubscription: ranks per processor on the busiest node, which the times scale by).
  !> A job that the settings cannot run (the same on every rank) raises err.
  subroutine make_job_plan(ctx, settings, centres, reference_point, n_ranks, oversubscription, plan, err)
    type(run_context_t), intent(in) :: ctx
    type(friction_settings_t), intent(in) :: settings
    real(dp), intent(in) :: centres(:, :), reference_point(3)
    integer, intent(in) :: n_ranks
    real(dp), intent(in) :: oversubscription
    type(job_plan_t), intent(out) :: plan
    type(error_t), intent(inout) :: err
    logical, allocatable :: keep(:)
    integer :: i
    logical :: shell

    if (settings%bead_forces .and. .not. all(settings%motions)) then
      call raise(err, 'bead_forces needs all six motions (motions = ''all'')')
    else if (settings%stop_after_solves < 0) then
      call raise(err, '-stop_after_solves needs a number of solves >= 1')
    else if (all(settings%replicate_products /= [character(len=8) :: 'yes', 'no'])) then
      call raise(err, "-replicate_products must be 'yes' or 'no', got '" // trim(settings%replicate_products) // "'")
    else if (all(settings%fft_planner /= [character(len=8) :: 'measure', 'estimate', 'auto'])) then
      call raise(err, "-fft_planner must be 'measure', 'estimate' or 'auto', got '" // trim(settings%fft_planner) // "'")
    end if
    if (err%failed) return
    plan%model_beads = size(centres, 2, kind=i8)
    plan%n_ranks = max(n_ranks, 1)
    plan%on_lattice = on_unit_lattice(centres)
    plan%reference_point = reference_point

    ! The beads of the solve (same input on every rank: the same outcome everywhere).
    plan%shell_layers = settings%shell_layers
    if (.not. is_set(plan%shell_layers)) plan%shell_layers = automatic_shell_layers(plan%on_lattice, settings%bead_forces)
    shell = plan%shell_layers > 0
    if (shell .and. .not. plan%on_lattice) then
      call raise(err, 'shell_layers needs beads on the unit lattice (a shape, not an off-lattice bead file)')
    else if (shell .and. settings%bead_forces) then
      call raise(err, 'bead_forces needs the full model (shell_layers = 0)')
    else if (shell) then
      call shell_mask(centres, plan%shell_layers, keep, err)
    end if
    if (err%failed) return
    if (shell) then
      plan%solve_beads = pack([(i, i = 1, size(centres, 2))], keep)
    else
      plan%solve_beads = [(i, i = 1, size(centres, 2))]
    end if
    plan%solve_centres = centres(:, plan%solve_beads)

    call choose_solve_frame(ctx, settings, plan, err)
    if (err%failed) return
    call choose_operator(settings, plan%solve_centres, plan%n_ranks, plan%n_solves, shell, plan%operator_name, err, &
                         plan%pfft_near_radius, plan%operator_reason)
    if (err%failed) return
    if (plan%operator_name == 'dense') then
      plan%n_solves = count(settings%motions)
      plan%lab_solves = plan%n_solves
    end if
    call choose_replication(settings%replicate_products, plan, err)
    if (err%failed) return
    plan%estimate = estimate_job(plan%model_beads, size(plan%solve_beads, kind=i8), &
                                 operator_spans(plan%solve_centres, plan%operator_name, settings), plan%on_lattice, &
                                 settings%multipole_order, settings%potential_order, trim(plan%operator_name), plan%n_ranks, &
                                 plan%n_solves, shell, oversubscription, settings%error_estimate .and. all(settings%motions), &
                                 plan%pfft_near_radius, fft_mirrors(plan%solve_centres, settings), &
                                 plan%replicated_products, solve_rtol(settings), merge(strain_solves(), 0, settings%flow))

  contains

    !> The flow's strain solves: five less those the symmetries derive (motion_symmetry.F90).
    integer function strain_solves()
      integer :: source(n_strain_modes), symmetry(n_strain_modes)
      real(dp) :: weights(n_strain_modes, n_strain_modes)
      call strain_sources(plan%symmetry_group, source, symmetry, weights)
      strain_solves = count(source == 0)
    end function strain_solves
  end subroutine make_job_plan

  !> The spans (sites per axis less one) an operator's cost follows: the lattice box of the solve
  !> beads (the FFT box holds twice it), the pfft grid's off the lattice (the beads' extent and a
  !> stencil's width, pfft_operator.F90), none for the direct operator off the lattice.
  function operator_spans(centres, operator_name, settings) result(spans)
    real(dp), intent(in) :: centres(:, :)
    character(len=*), intent(in) :: operator_name
    type(friction_settings_t), intent(in) :: settings
    integer :: spans(3), a
    spans = 0
    if (on_unit_lattice(centres)) then
      spans = nint(maxval(centres, dim=2) - minval(centres, dim=2))
    else if (operator_name == 'pfft') then
      do a = 1, 3
        spans(a) = pfft_span(centres(a, :), settings%pfft_stencil)
      end do
    end if
  end function operator_spans

  !> The lattice axes along which the solve beads are symmetric, which the FFT operator's products
  !> by mirror class use (fft_operator.F90, choose_axes); none off the lattice or with
  !> fft_mirror_classes off.
  function fft_mirrors(centres, settings) result(mirrors)
    real(dp), intent(in) :: centres(:, :)
    type(friction_settings_t), intent(in) :: settings
    logical :: mirrors(3)
    integer, allocatable :: lattice(:, :)
    mirrors = .false.
    if (.not. settings%fft_mirror_classes .or. .not. on_unit_lattice(centres)) return
    lattice = nint(centres - spread(minval(centres, dim=2), 2, size(centres, 2)))
    mirrors = lattice_mirrors(lattice, maxval(lattice, dim=2))
  end function fft_mirrors

  !> plan%replicated_products: asked for ('yes'), on several ranks, for any operator but the dense
  !> one (assembled and factorised as a whole already). Not by default: on this project's 2-core
  !> machine it made the random 1000-bead body's job 7 % faster on a busy day and no faster on a
  !> quiet one, where the distributed product already runs at about 92 % of two whole products,
  !> and it was slower on larger boxes, class products and 4 oversubscribed ranks
  !> (bench/side_by_side/replicated_products.md); it is for more ranks than a small box's
  !> frequency lines, or ranks on several nodes, where transposes cost more.
  subroutine choose_replication(requested, plan, err)
    character(len=*), intent(in) :: requested
    type(job_plan_t), intent(inout) :: plan
    type(error_t), intent(inout) :: err
    plan%replicated_products = requested == 'yes' .and. plan%n_ranks > 1
    if (requested == 'yes' .and. plan%operator_name == 'dense') &
      call raise(err, '-replicate_products yes needs the direct, fft or pfft operator; the dense operator is ' // &
                 'factorised whole already')
  end subroutine choose_replication

  !> The pfft grid's span along one axis: the beads' extent and a stencil's width.
  pure integer function pfft_span(coordinates, stencil)
    real(dp), intent(in) :: coordinates(:)
    integer, intent(in) :: stencil
    pfft_span = ceiling(maxval(coordinates) - minval(coordinates)) + stencil - 1
  end function pfft_span

  !> Collective. The solves the requested motions need after the symmetries of the solve beads
  !> (about the reference point), in the model's coordinates (lab_solves) and, for an off-lattice
  !> body, in its body frame: when that needs fewer (a symmetric body turned by a rotation that
  !> is no lattice symmetry: its symmetries are signed axis permutations only in its own axes),
  !> the solve centres are turned into it. The Galerkin operator is exactly covariant (theory.md
  !> T16): the friction job turns the friction back, zeta = R zeta' R^T, R = diag(Q, Q). Only
  !> when all six motions are asked for and no per-bead output depends on the frame.
  subroutine choose_solve_frame(ctx, settings, plan, err)
    type(run_context_t), intent(in) :: ctx
    type(friction_settings_t), intent(in) :: settings
    type(job_plan_t), intent(inout) :: plan
    type(error_t), intent(inout) :: err
    type(body_frame_t) :: frame
    real(dp), allocatable :: candidate(:, :)
    integer :: body_solves
    logical :: body_group(n_symmetries)
    plan%lab_solves = count(settings%motions)
    plan%n_solves = plan%lab_solves
    if (.not. settings%use_symmetry) return
    call find_symmetry_group(ctx%comm, plan%solve_centres, plan%reference_point, plan%symmetry_group, err)
    call agree_on_error(ctx, err)   ! the same replicated centres everywhere: only a resource failure differs
    if (err%failed) return
    plan%lab_solves = solves_needed(plan%symmetry_group, settings%motions)
    plan%n_solves = plan%lab_solves
    ! (A test stop, -stop_after_solves, fails the job before anything is turned back; it keeps the
    ! frame, so the checkpoint it leaves belongs to the resumed job's solves.)
    if (.not. all(settings%motions) .or. settings%bead_forces .or. plan%on_lattice) return
    ! The same replicated centres on every rank: the same frame and decision everywhere.
    call compute_body_frame(plan%solve_centres, frame, err)
    if (err%failed) return
    candidate = matmul(transpose(frame%axes), plan%solve_centres - spread(plan%reference_point, 2, &
                                                                          size(plan%solve_centres, 2))) + &
                spread(plan%reference_point, 2, size(plan%solve_centres, 2))
    call find_symmetry_group(ctx%comm, candidate, plan%reference_point, body_group, err)
    call agree_on_error(ctx, err)
    if (err%failed) return
    body_solves = solves_needed(body_group, settings%motions)
    if (body_solves >= plan%lab_solves) return
    plan%body_frame = .true.
    plan%symmetry_group = body_group
    plan%solve_axes = frame%axes
    plan%n_solves = body_solves
    call move_alloc(candidate, plan%solve_centres)
  end subroutine choose_solve_frame

  !> The accuracy a job asks of an approximate operator, relative to the largest friction or
  !> mobility entry (0: none): with an accuracy target, operator_share of it (the rest is the
  !> truncation's, whose settings the target chose); otherwise the Krylov tolerance of the solves
  !> (krylov_rtol, or -ksp_rtol), the accuracy a user asks of the friction by it. The default
  !> tolerance (1e-3) is above the pfft far field's expected error at its default near radius
  !> (pfft_expected_error, 5e-4): a default run keeps its operator.
  pure real(dp) function requested_accuracy(settings)
    type(friction_settings_t), intent(in) :: settings
    if (settings%accuracy > 0.0_dp) then
      requested_accuracy = operator_share * settings%accuracy
    else
      requested_accuracy = solve_rtol(settings)
    end if
  end function requested_accuracy

  !> The Krylov tolerance the solves use: -ksp_rtol's when given, else krylov_rtol.
  pure real(dp) function solve_rtol(settings)
    type(friction_settings_t), intent(in) :: settings
    solve_rtol = settings%krylov_rtol
    if (settings%krylov_rtol_on_command_line .and. settings%ksp_rtol_value > 0.0_dp) solve_rtol = settings%ksp_rtol_value
  end function solve_rtol

  !> The operator for a job: as asked, or for 'auto' the one whose estimated wall time is the
  !> smaller (job_estimate.f90, the dry run's cost model: set-up, the solves' products and the
  !> error bar's companion on n_ranks ranks, for the n_solves solves the job's symmetries leave):
  !> on the lattice the direct operator against the FFT operator (by mirror class where the beads
  !> allow it; bench/operator_check/lattice_crossover.md checks the choice against side-by-side
  !> runs at L = 1, 2, 3), off the lattice the direct operator against the precorrected FFT
  !> (bench/offlattice/pfft_crossover.md). First of all, up to dense_max_beads beads (and
  !> dense_max_unknowns unknowns), the dense operator: a few beads at high L are where Krylov
  !> iterations pile up and an exact solve of a few thousand unknowns is cheap
  !> (bench/offlattice/high_order.md: 3-8 beads at L = 8 ... 16 run 1.45-3.8x faster; bodies with many
  !> symmetric beads keep the Krylov path, which wins there).
  !> The pfft operator approximates the far field (theory.md T16): when the job asks for more
  !> accuracy than it is expected to give at the settings' near radius (requested_accuracy,
  !> pfft_expected_error), its near radius is raised until it does (pfft_radius_for; not a radius
  !> given by -pfft_near_radius), and 'auto' weighs the pfft operator at that radius against the
  !> direct one. near_radius: the pfft operator's; reason: why this operator, in words.
  subroutine choose_operator(settings, centres, n_ranks, n_solves, shell, chosen, err, near_radius, reason)
    type(friction_settings_t), intent(in) :: settings
    real(dp), intent(in) :: centres(:, :)
    integer, intent(in) :: n_ranks, n_solves
    logical, intent(in) :: shell       ! the solve beads are a shell model's (its iteration counts)
    character(len=*), intent(out) :: chosen
    type(error_t), intent(inout) :: err
    real(dp), intent(out), optional :: near_radius
    character(len=:), allocatable, intent(out), optional :: reason
    character(len=4) :: fast
    character(len=:), allocatable :: why
    logical :: on_lattice, mirrors(3)
    real(dp) :: radius, wanted, fast_seconds, direct_seconds
    on_lattice = on_unit_lattice(centres)
    ! The pfft operator's near radius: the settings', raised for the accuracy asked for.
    radius = settings%pfft_near_radius
    wanted = requested_accuracy(settings)
    if (.not. settings%pfft_near_radius_given .and. .not. on_lattice) &
      radius = min(pfft_radius_for(settings%pfft_stencil, radius, wanted), max(radius, diameter(centres)))
    why = ''
    select case (trim(settings%operator_name))
    case ('direct', 'fft', 'pfft', 'dense')
      chosen = settings%operator_name
      why = 'as asked (-operator ' // trim(chosen) // ')'
    case ('auto')
      mirrors = fft_mirrors(centres, settings)   ! once, for both estimates
      fast = merge('fft ', 'pfft', on_lattice)
      if (size(centres, 2) <= dense_max_beads .and. &
          size(centres, 2) * basis_size(settings%multipole_order, settings%potential_order) <= dense_max_unknowns) then
        chosen = 'dense'
        why = 'auto: at most ' // str(dense_max_beads) // ' beads, solved exactly'
      else
        fast_seconds = estimated_seconds(trim(fast))
        direct_seconds = estimated_seconds('direct')
        if (fast_seconds < direct_seconds) then
          chosen = fast
        else
          chosen = 'direct'
        end if
        why = 'auto: the smaller estimated time (' // trim(fast) // ' ' // str_significant(fast_seconds, 2) // &
              ' s, direct ' // str_significant(direct_seconds, 2) // ' s)'
      end if
    case default
      chosen = ''
      call raise(err, "-operator must be 'direct', 'fft', 'pfft', 'dense' or 'auto', got '" // &
                 trim(settings%operator_name) // "'")
    end select
    if (chosen /= 'pfft') radius = 0.0_dp
    if (radius > settings%pfft_near_radius) then
      why = why // '; near radius ' // str_significant(radius, 3) // ' d instead of ' // &
            str_significant(settings%pfft_near_radius, 3) // ' d: the far field''s expected error there, ' // &
            str_significant(pfft_expected_error(settings%pfft_stencil, settings%pfft_near_radius), 2) // &
            ', is above the ' // str_significant(wanted, 2) // ' asked for'
    else if (chosen == 'direct' .and. .not. on_lattice .and. settings%operator_name == 'auto' .and. &
             pfft_expected_error(settings%pfft_stencil, settings%pfft_near_radius) > wanted) then
      why = why // '; the pfft operator weighed at the near radius ' // str_significant(radius_for_pfft(), 3) // &
            ' d, where its far field meets the ' // str_significant(wanted, 2) // ' asked for'
    end if
    if (present(near_radius)) near_radius = radius
    if (present(reason)) reason = why

  contains

    !> The near radius the pfft operator was weighed at (radius is 0 once the direct operator won).
    real(dp) function radius_for_pfft()
      radius_for_pfft = min(pfft_radius_for(settings%pfft_stencil, settings%pfft_near_radius, wanted), &
                            max(settings%pfft_near_radius, diameter(centres)))
    end function radius_for_pfft

    !> The dry run's wall time of the job with this operator (the pfft operator at `radius`).
    real(dp) function estimated_seconds(operator_name)
      character(len=*), intent(in) :: operator_name
      type(job_estimate_t) :: e
      e = estimate_job(size(centres, 2, kind=i8), size(centres, 2, kind=i8), &
                       operator_spans(centres, operator_name, settings), on_lattice, &
                       settings%multipole_order, settings%potential_order, operator_name, n_ranks, n_solves, shell, &
                       1.0_dp, settings%error_estimate .and. settings%multipole_order >= 2 .and. all(settings%motions), &
                       radius, mirrors, krylov_rtol=solve_rtol(settings))
      estimated_seconds = e%seconds_total
    end function estimated_seconds
  end subroutine choose_operator

  !> The largest distance between two of the beads (d), bounded from their box's diagonal: beyond
  !> it a near radius makes every pair exact.
  pure real(dp) function diameter(centres)
    real(dp), intent(in) :: centres(:, :)
    diameter = norm2(maxval(centres, dim=2) - minval(centres, dim=2)) + 1.0_dp
  end function diameter
end module beadmob_job_plan
