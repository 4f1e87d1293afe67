!> The friction of a bead model on all ranks: the multipole basis of order L, the distributed
!> bead operator with its block table, the six rigid-motion solves about the reference point,
!> and the lubrication correction (theory.md T3-T9).
module beadmob_friction_job
#include "petsc/finclude/petscmat.h"
  use petscmat
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t, block_range, agree_on_error
  use beadmob_multipole_basis, only: multipole_basis_t, make_multipole_basis
  use beadmob_pair_blocks, only: rigid_projection
  use beadmob_multipole_operator, only: multipole_operator_t, operator_options_t
  use beadmob_operator_catalog, only: new_operator
  use beadmob_near_field_matrix, only: assemble_near_field
  use beadmob_bead_block_preconditioner, only: bead_block_preconditioner_t, make_bead_block_preconditioner
  use beadmob_resources, only: peak_resident_bytes
  use beadmob_rigid_body_solve, only: solve_statistics_t, motion_solver_t, create_motion_solver, use_checkpoint, &
                                      find_symmetry, solve_motions, keep_solution_part, bead_forces_of_solutions, &
                                      destroy_motion_solver, strain_statistics_t, pose_strains, &
                                      strain_grand_resistance, keep_strain_solution_part, add_bead_stresslets
  use beadmob_bead_stresslet, only: stresslet_pattern_response
  use beadmob_linear_flow, only: n_strain_modes, strain_projection, strain_rotation
  use beadmob_progress, only: progress_line, progress_seconds
  use beadmob_checkpoint_file, only: reals_digest
  use beadmob_lubrication, only: lubrication_table_t, make_shared_lubrication_table, add_lubrication, reference_order
  use beadmob_friction_diagnostics, only: friction_diagnostics_t
  use beadmob_error_estimate, only: error_estimate_t
  use beadmob_flow_response, only: flow_response_t
  use beadmob_brownian_numbers, only: brownian_numbers_t
  use beadmob_operator_error_bar, only: operator_error_t
  use beadmob_accuracy_choice, only: accuracy_choice_t
  use beadmob_friction_settings, only: friction_settings_t
  use beadmob_job_plan, only: job_plan_t, make_job_plan
  use beadmob_operator_error, only: operator_sample_t, sample_operator_error, operator_error_rows
  use beadmob_pfft_operator, only: pfft_operator_t
  implicit none
  private
  public :: friction_settings_t, friction_result_t, friction_of_model, friction_of_plan, phase_names, companion_orders

  character(len=*), parameter :: phase_names(6) = [character(len=11) :: 'blocks', 'near_field', 'solve', &
                                                   'companion', 'lubrication', 'total']


  type :: friction_result_t
    real(dp) :: friction(6, 6) = 0.0_dp           ! with lubrication when asked for
    real(dp) :: multipole_friction(6, 6) = 0.0_dp ! order L alone
    real(dp) :: multipole_coefficients(5) = 0.0_dp ! the paper's coefficients of the order-L friction alone
    !> Health of friction and multipole_friction (set by the driver, friction_diagnostics.f90)
    type(friction_diagnostics_t) :: diagnostics, multipole_diagnostics
    type(solve_statistics_t) :: solves
    !> With settings%flow (theory.md T19): the grand resistance between the six rigid motions and
    !> the five strain modes about the reference point (order L, model coordinates; its first 6 x 6
    !> block is multipole_friction), the strain solves' record, and the same of the companion
    logical :: flow = .false.
    real(dp) :: grand_resistance(6 + n_strain_modes, 6 + n_strain_modes) = 0.0_dp
    real(dp) :: companion_grand_resistance(6 + n_strain_modes, 6 + n_strain_modes) = 0.0_dp
    type(strain_statistics_t) :: strain_solves, companion_strain_solves
    !> The free body's response and its bar (set by the driver, flow_response.f90)
    type(flow_response_t) :: flow_response
    !> Diffusion, relaxation times and (with the flow) [eta] (set by the driver, brownian_numbers.f90)
    type(brownian_numbers_t) :: brownian
    !> The settings an accuracy target chose (set by the driver; target 0 = none asked for)
    type(accuracy_choice_t) :: accuracy
    integer :: unknowns_per_bead = 0
    !> Lattice symmetries of the bead set about the reference point (1: none but the identity;
    !> 0: not looked for, use_symmetry off)
    integer :: symmetry_group_order = 0
    !> The axes (columns, model coordinates) of the frame the motions were solved in: the
    !> identity, or the body frame of an off-lattice body whose symmetries show only there
    !> (solve_frame); the friction matrices are always in model coordinates.
    real(dp) :: solve_axes(3, 3) = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], [3, 3])
    integer :: hydrodynamic_beads = 0             ! beads in the solve (fewer than N for a shell model)
    !> The plan the job ran (job_plan.f90): its Krylov solves (motions less symmetries) and its
    !> estimate of the peak memory per rank (bytes) and of the wall time (s)
    integer :: planned_solves = 0
    real(dp) :: estimated_peak_memory_bytes = 0.0_dp, estimated_seconds = 0.0_dp
    character(len=16) :: operator_name = ''        ! the operator used: direct, fft, pfft or dense
    character(len=:), allocatable :: operator_reason   ! why (job_plan.f90, choose_operator)
    logical :: replicated_products = .false.       ! whole on every rank (replicated_operator.F90)
    real(dp) :: near_field_radius = 0.0_dp
    integer :: near_field_cluster = 0
    integer :: pfft_stencil = 0                    ! the pfft operator's (0: another operator)
    real(dp) :: pfft_near_radius = 0.0_dp
    integer(i8) :: near_field_pairs = 0            ! pair blocks in the preconditioning matrix
    logical :: on_lattice = .false.
    integer(i8) :: computed_blocks = 0
    integer(i8) :: cached_blocks = 0               ! lattice blocks read from the table cache
    character(len=1024) :: cache_file = ''         ! the table cache used ('' = none)
    logical :: plans_from_wisdom = .false.         ! FFT plans remembered with the cache (fft_operator.F90)
    logical :: by_mirror_class = .false.           ! FFT products by mirror class (fft_operator.F90)
    integer :: lubrication_pairs = 0
    integer :: lubrication_reference_order = 0
    type(lubrication_table_t) :: lubrication_table
    real(dp) :: seconds(size(phase_names)) = 0.0_dp   ! wall time per phase (max over ranks)
    real(dp) :: peak_memory_bytes = 0.0_dp   ! peak resident set size, max over ranks
    !> Peak resident set size reached by the end of each phase, max over ranks (the peak is
    !> monotonic: a phase's own need shows as the step from the previous phase)
    real(dp) :: phase_peak_memory_bytes(size(phase_names) - 1) = 0.0_dp
    !> With settings%bead_forces: (36, this rank's beads), see bead_forces_of_solutions.
    real(dp), allocatable :: bead_forces(:, :)
    !> The companion of order L - 1 (companion_order 0: none was solved): its friction with the
    !> lubrication correction of its order when that is on, the order-(L - 1) friction alone,
    !> its unknowns per bead and its solves.
    integer :: companion_order = 0
    integer :: companion_potential_order = 0
    integer :: companion_unknowns_per_bead = 0
    real(dp) :: companion_friction(6, 6) = 0.0_dp
    real(dp) :: companion_multipole_friction(6, 6) = 0.0_dp
    type(solve_statistics_t) :: companion_solves
    !> The error bar made from the two (set by the driver, error_estimate.f90)
    type(error_estimate_t) :: estimate
    !> The approximate operator's error measured on a sample of rows (operator_error.F90, theory.md
    !> T16; rows 0: none, an exact operator), its terms in model coordinates
    type(operator_sample_t) :: operator_sample
    !> Its bound in the mobility (set by the driver, operator_error_bar.f90; available .false.: none)
    type(operator_error_t) :: operator_error
  end type friction_result_t

contains

  !> Collective. The friction job of the model `centres` about reference_point, planned here for
  !> the ranks of ctx (the library's entry; the driver plans first, for its dry run and memory
  !> check, and runs that plan with friction_of_plan).
  subroutine friction_of_model(ctx, settings, centres, reference_point, job_result, err)
    type(run_context_t), intent(in) :: ctx
    type(friction_settings_t), intent(in) :: settings
    real(dp), intent(in) :: centres(:, :), reference_point(3)
    type(friction_result_t), intent(out) :: job_result
    type(error_t), intent(inout) :: err
    type(job_plan_t) :: plan
    call make_job_plan(ctx, settings, centres, reference_point, ctx%n_ranks, 1.0_dp, plan, err)
    if (err%failed) return
    call friction_of_plan(ctx, settings, plan, job_result, err)
  end subroutine friction_of_model

  !> Collective. The friction job as planned (job_plan.f90): the solve beads in the solve frame,
  !> the operator chosen there. Solved in the body frame, the friction zeta' of the turned beads
  !> gives zeta = R zeta' R^T, R = diag(Q, Q), Q the body axes (columns), and so for the companion.
  subroutine friction_of_plan(ctx, settings, plan, job_result, err)
    type(run_context_t), intent(in) :: ctx
    type(friction_settings_t), intent(in) :: settings
    type(job_plan_t), intent(in) :: plan
    type(friction_result_t), intent(out) :: job_result
    type(error_t), intent(inout) :: err
    real(dp) :: rotation(6, 6), grand_rotation(6 + n_strain_modes, 6 + n_strain_modes)
    integer :: k
    type(friction_settings_t) :: planned

    if (plan%body_frame) call progress_line(settings%progress .and. ctx%rank == 0, 'solving in the body frame: ' // &
      str(plan%n_solves) // ' solves for the six motions (' // str(plan%lab_solves) // ' in the model''s coordinates)')
    if (allocated(plan%operator_reason)) call progress_line(settings%progress .and. ctx%rank == 0, 'operator ' // &
      trim(plan%operator_name) // ': ' // plan%operator_reason)
    ! The settings with the plan's choices (the pfft near radius may be raised, job_plan.f90)
    planned = settings
    if (plan%pfft_near_radius > 0.0_dp) planned%pfft_near_radius = plan%pfft_near_radius
    call friction_of_beads(ctx, planned, plan%solve_centres, plan%reference_point, plan%operator_name, &
                           plan%replicated_products, plan%symmetry_group, job_result, err)
    if (allocated(plan%operator_reason)) job_result%operator_reason = plan%operator_reason
    job_result%planned_solves = plan%n_solves
    job_result%estimated_peak_memory_bytes = plan%estimate%peak
    job_result%estimated_seconds = plan%estimate%seconds_total
    if (err%failed .or. .not. plan%body_frame) return
    job_result%solve_axes = plan%solve_axes
    rotation = 0.0_dp
    rotation(1:3, 1:3) = plan%solve_axes
    rotation(4:6, 4:6) = plan%solve_axes
    job_result%multipole_friction = turned_back(job_result%multipole_friction)
    job_result%friction = turned_back(job_result%friction)
    job_result%companion_multipole_friction = turned_back(job_result%companion_multipole_friction)
    job_result%companion_friction = turned_back(job_result%companion_friction)
    if (job_result%flow) then
      ! Strain amplitudes turn with D(Q) (linear_flow.f90), the motions with diag(Q, Q).
      grand_rotation = 0.0_dp
      grand_rotation(1:6, 1:6) = rotation
      grand_rotation(7:, 7:) = strain_rotation(plan%solve_axes)
      job_result%grand_resistance = matmul(grand_rotation, matmul(job_result%grand_resistance, transpose(grand_rotation)))
      job_result%companion_grand_resistance = matmul(grand_rotation, &
        matmul(job_result%companion_grand_resistance, transpose(grand_rotation)))
    end if
    do k = 1, job_result%operator_sample%rows
      job_result%operator_sample%terms(:, :, k) = turned_back(job_result%operator_sample%terms(:, :, k))
      job_result%operator_sample%second(:, :, k) = turned_back(job_result%operator_sample%second(:, :, k))
    end do

  contains

    !> R zeta' R^T: a friction of the body frame in the model's coordinates.
    pure function turned_back(body_friction) result(friction)
      real(dp), intent(in) :: body_friction(6, 6)
      real(dp) :: friction(6, 6)
      friction = matmul(rotation, matmul(body_friction, transpose(rotation)))
    end function turned_back
  end subroutine friction_of_plan


  !> Collective. The friction job on the bead set `centres` (all beads in the solve) with the
  !> operator and the symmetry group (about reference_point) the plan found.
  subroutine friction_of_beads(ctx, settings, centres, reference_point, operator_name, replicated, symmetry_group, &
                               job_result, err)
    type(run_context_t), intent(in) :: ctx
    type(friction_settings_t), intent(in) :: settings
    real(dp), intent(in) :: centres(:, :), reference_point(3)
    character(len=*), intent(in) :: operator_name
    logical, intent(in) :: replicated   ! the operator whole on every rank (replicated_operator.F90)
    logical, intent(in) :: symmetry_group(:)
    type(friction_result_t), intent(out) :: job_result
    type(error_t), intent(inout) :: err
    type(multipole_basis_t) :: basis
    class(multipole_operator_t), allocatable, target :: op
    type(operator_options_t) :: options
    type(bead_block_preconditioner_t), allocatable, target :: bead_blocks
    type(motion_solver_t) :: solver
    real(dp), allocatable :: projection(:, :), self(:, :), own_strain(:, :)
    ! An order-1 job's strains: the projected fields of the strained beads (their stresslets)
    real(dp), allocatable :: strained_response(:, :)
    real(dp) :: start, lubrication_sum(6, 6), local(6, 6), pair_sum_start
    Mat :: matrix, near_field
    integer(i8) :: first, count
    integer :: local_pairs, phase
    PetscErrorCode :: ierr   ! also the MPI error code (both default integers)
    PetscLogStage :: stages(size(phase_names) - 1)
    character(len=32) :: stage_name
    type(lubrication_table_t) :: companion_table
    ! the companion (theory.md T14): its basis, its unknowns in the order-L basis, its start
    type(multipole_basis_t) :: low
    integer, allocatable :: unknowns(:)
    real(dp), allocatable :: low_start(:, :), low_strain_start(:, :)
    ! control first (settings%control_rtol): the companion's solutions, the order-L solves' start
    real(dp), allocatable :: low_solution(:, :), low_strain_solution(:, :)
    real(dp) :: companion_seconds
    logical :: report, with_companion, control_first, own_near_field, solver_made

    ! One -log_view stage per phase (the last phase name, 'total', is the sum).
    do phase = 1, size(stages)
      stage_name = 'beadmob ' // phase_names(phase)
      ! Registered once per program (a program may compute several frictions).
      PetscCallA(PetscLogStageGetId(stage_name, stages(phase), ierr))
      if (stages(phase) < 0) then
        PetscCallA(PetscLogStageRegister(stage_name, stages(phase), ierr))
      end if
    end do
    start = MPI_Wtime()
    report = settings%progress .and. ctx%rank == 0
    control_first = settings%control_rtol > 0.0_dp .and. settings%multipole_order >= 2
    with_companion = (settings%error_estimate .and. settings%multipole_order >= 2 .and. all(settings%motions)) .or. &
                     control_first
    PetscCallA(PetscLogStagePush(stages(1), ierr))
    basis = make_multipole_basis(settings%multipole_order, settings%potential_order)
    job_result%unknowns_per_bead = basis%size
    job_result%hydrodynamic_beads = size(centres, 2)
    allocate (projection(basis%size, 6))
    call rigid_projection(basis, projection)
    job_result%flow = settings%flow
    if (settings%flow) then
      allocate (own_strain(basis%size, n_strain_modes))
      call strain_projection(basis, own_strain)
    end if
    call block_range(ctx, size(centres, 2, kind=i8), first, count)
    job_result%operator_name = operator_name
    call progress_line(report, 'phase blocks: ' // str(size(centres, 2)) // ' beads in the solve, ' // &
                       str(basis%size) // ' unknowns each, ' // trim(job_result%operator_name) // ' operator')
    job_result%cache_file = settings%cache_file
    options%cache_file = trim(settings%cache_file)
    ! 'auto': measured plans pay when they are remembered (wisdom next to the cache), not when
    ! each run measures anew (bench/side_by_side/fft_planner.md).
    options%measure_plans = settings%fft_planner == 'measure' .or. &
                            (settings%fft_planner == 'auto' .and. len_trim(settings%cache_file) > 0)
    options%report = report
    options%mirror_classes = settings%fft_mirror_classes
    options%pfft_stencil = settings%pfft_stencil
    options%pfft_near_radius = settings%pfft_near_radius
    if (with_companion) options%companion_unknowns = companion_unknowns(basis)
    call new_operator(job_result%operator_name, op, replicated)
    job_result%replicated_products = replicated
    own_near_field = .false.
    solver_made = .false.
    ! Every failure leaves the block through one exit below (the operator released, the phase's
    ! -log_view stage closed); each is agreed on by the ranks, or the same on every rank.
    job: block
      call op%create(ctx%comm, basis, centres, first, count, options, err)
      call agree_on_error(ctx, err)
      if (err%failed) exit job
      matrix = op%matrix
      job_result%on_lattice = op%on_lattice
      job_result%computed_blocks = op%computed_blocks
      job_result%cached_blocks = op%cached_blocks
      job_result%plans_from_wisdom = op%plans_from_wisdom
      job_result%by_mirror_class = op%by_mirror_class
      if (job_result%operator_name == 'pfft') then
        job_result%pfft_stencil = settings%pfft_stencil
        job_result%pfft_near_radius = settings%pfft_near_radius
      end if
      self = op%self_block
      call mark(1)

      job_result%near_field_radius = settings%near_field_radius
      job_result%near_field_cluster = settings%near_field_cluster
      call precondition(op, basis, self, settings%near_field_radius, settings%near_field_cluster, bead_blocks, near_field, &
                        own_near_field, job_result%near_field_pairs, err)
      if (err%failed) exit job   ! the same self block on every rank
      call mark(2)

      companion_seconds = 0.0_dp
      if (control_first) then
        companion_seconds = MPI_Wtime()
        call set_up_companion()
        call companion_friction(settings%control_rtol, err)
        if (err%failed) exit job
        companion_seconds = MPI_Wtime() - companion_seconds
      end if
      call create_motion_solver(solver, ctx%comm, matrix, near_field, basis%size, size(centres, 2, kind=i8), first, count, &
                                settings%krylov_rtol, 'solve', report, bead_blocks, op, settings%solve_apart, &
                                settings%deflation)
      solver_made = .true.
      if (len_trim(settings%checkpoint_file) > 0) call use_checkpoint(solver, trim(settings%checkpoint_file), &
        checkpoint_key(settings, centres, reference_point, basis%size, job_result%operator_name))
      solver%stop_after_solves = settings%stop_after_solves
      if (control_first) call start_from_companion()
      if (settings%flow) call pose_strains(solver, projection, own_strain, centres, reference_point)
      call solve_level(solver, op, basis, projection, job_result%multipole_friction, job_result%solves, err)
      if (err%failed) exit job   ! the test stop: the same solve count on every rank
      call mask_uncomputed(job_result%solves, job_result%multipole_friction)
      if (settings%flow) then
        call strain_grand_resistance(solver, job_result%grand_resistance, job_result%strain_solves)
        ! Order 1: the beads' own stresslets by Faxen's law, from a pair sum (bead_stresslet.f90).
        if (basis%order == 1) then
          pair_sum_start = MPI_Wtime()
          allocate (strained_response(basis%size * count, n_strain_modes))
          call stresslet_pattern_response(centres, first, count, projection, strained_response)
          call add_bead_stresslets(solver, strained_response, job_result%grand_resistance)
          call progress_line(report, 'bead stresslets (order 1, Faxen''s law): pair sum over ' // &
                             str(size(centres, 2)) // ' beads, ' // progress_seconds(MPI_Wtime() - pair_sum_start) // ' s')
        end if
      end if
      if (allocated(solver%symmetry)) job_result%symmetry_group_order = solver%symmetry%group_order
      ! The pfft far field's error on a sample of rows (theory.md T16), before the solutions go;
      ! its bound needs the whole friction (all six motions)
      if (job_result%operator_name == 'pfft' .and. all(settings%motions)) call sample_far_field_error()
      if (settings%bead_forces) then
        allocate (job_result%bead_forces(36, count))
        call bead_forces_of_solutions(solver, projection, job_result%bead_forces)
      end if
      if (with_companion .and. .not. control_first) then
        ! The companion's start: the order L - 1 part of the order-L solutions.
        call set_up_companion()
        allocate (low_start(size(unknowns) * count, 6))
        call keep_solution_part(solver, unknowns, low_start)
        if (settings%flow) then
          allocate (low_strain_start(size(unknowns) * count, n_strain_modes))
          call keep_strain_solution_part(solver, unknowns, low_strain_start)
        end if
      end if
      call destroy_motion_solver(solver)
      solver_made = .false.
      call op%free_batches()   ! the companion has buffers of its own
      call mark(3)

      if (with_companion .and. .not. control_first) call companion_friction(settings%krylov_rtol, err)
      if (err%failed) exit job
      call release_operator()
      call mark(4)
      ! A companion solved first is timed as its phase, not as the solve's.
      job_result%seconds(3) = job_result%seconds(3) - companion_seconds
      job_result%seconds(4) = job_result%seconds(4) + companion_seconds

      job_result%friction = job_result%multipole_friction
      job_result%companion_friction = job_result%companion_multipole_friction
      if (settings%lubrication) then
        call lubricated(settings%multipole_order, settings%potential_order, job_result%lubrication_table, job_result%friction)
        if (with_companion .and. .not. err%failed) then
          call lubricated(job_result%companion_order, job_result%companion_potential_order, companion_table, &
                          job_result%companion_friction)
        end if
        if (err%failed) exit job
        job_result%lubrication_reference_order = reference_order
      end if
      call mark(5)
    end block job
    if (err%failed) then
      if (solver_made) call destroy_motion_solver(solver)
      if (allocated(op)) call release_operator()
      PetscCallA(PetscLogStagePop(ierr))
      return
    end if
    job_result%seconds(size(phase_names)) = MPI_Wtime() - start
    call MPI_Allreduce(MPI_IN_PLACE, job_result%seconds, size(job_result%seconds), MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr)
    call MPI_Allreduce(peak_resident_bytes(), job_result%peak_memory_bytes, 1, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr)
    call MPI_Allreduce(MPI_IN_PLACE, job_result%phase_peak_memory_bytes, size(job_result%phase_peak_memory_bytes), &
                       MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr)

  contains

    !> job_result%operator_sample: the terms of the exact minus the pfft product on the rows
    !> operator_error_rows chooses (all up to its budget), for the solutions of order L.
    subroutine sample_far_field_error()
      integer :: rows
      rows = operator_error_rows(size(centres, 2, kind=i8), basis%size, settings%operator_error_rows)
      select type (op)
      type is (pfft_operator_t)   ! its axial table, made for its near pairs
        call sample_operator_error(ctx%comm, basis, self, centres, first, count, solver%solution, solver%rhs, &
                                   solver%residual, rows, job_result%operator_sample, op%axial)
      class default
        call sample_operator_error(ctx%comm, basis, self, centres, first, count, solver%solution, solver%rhs, &
                                   solver%residual, rows, job_result%operator_sample)
      end select
      call progress_line(report, 'far-field error: ' // str(rows) // ' exact rows of ' // str(size(centres, 2)) // &
                         ' beads (' // progress_seconds(job_result%operator_sample%seconds) // ' s)')
    end subroutine sample_far_field_error

    !> The companion's orders, basis and unknowns in the order-L basis.
    subroutine set_up_companion()
      call companion_orders(settings%multipole_order, settings%potential_order, job_result%companion_order, &
                            job_result%companion_potential_order)
      low = make_multipole_basis(job_result%companion_order, job_result%companion_potential_order)
      unknowns = companion_unknowns(basis)
    end subroutine set_up_companion

    !> Control first: the order-L solves start from the companion's solutions on its unknowns
    !> (zero on the others), each bead's block of basis%size numbers.
    subroutine start_from_companion()
      solver%initial_guess = embedded(low_solution)
      if (settings%flow) solver%strain_initial_guess = embedded(low_strain_solution)
    end subroutine start_from_companion

    !> Vectors of the companion's unknowns (columns) as vectors of the order-L ones.
    pure function embedded(low_vectors) result(vectors)
      real(dp), intent(in) :: low_vectors(:, :)
      real(dp) :: vectors(basis%size * count, size(low_vectors, 2))
      integer(i8) :: bead
      vectors = 0.0_dp
      do bead = 1, count
        vectors(basis%size * (bead - 1) + unknowns, :) = low_vectors(low%size * (bead - 1) + 1:low%size * bead, :)
      end do
    end function embedded

    !> The companion of order L - 1 on the same beads: the sub-basis of the order-L one, its operator
    !> read from the order-L operator (create_*_companion, no new quadrature or kernel), the
    !> single-bead preconditioner, the same motions and symmetries, Krylov tolerance rtol; not
    !> checkpointed. Solved first (control_first), from zero, its solutions kept as the order-L start.
    subroutine companion_friction(rtol, err)
      real(dp), intent(in) :: rtol
      type(error_t), intent(inout) :: err
      class(multipole_operator_t), allocatable, target :: low_op
      type(bead_block_preconditioner_t), allocatable, target :: low_blocks
      type(motion_solver_t) :: low_solver
      Mat :: low_preconditioning
      logical :: low_own_near_field
      integer(i8) :: no_pairs
      integer :: k
      real(dp), allocatable :: low_response(:, :)

      job_result%companion_unknowns_per_bead = low%size
      if (control_first) then
        call progress_line(report, 'phase companion: order L = ' // str(job_result%companion_order) // ', ' // &
                           str(low%size) // ' unknowns per bead, the control problem, the start of order L')
      else
        call progress_line(report, 'phase companion: order L = ' // str(job_result%companion_order) // ', ' // &
                           str(low%size) // ' unknowns per bead, for the error estimate')
      end if
      call op%create_companion(ctx%comm, unknowns, low_op, err)
      call agree_on_error(ctx, err)
      if (.not. err%failed) then
        ! As for order L, without pair blocks: the dense operator's own factorisation, else the
        ! single-bead blocks.
        call precondition(low_op, low, self(unknowns, unknowns), 0.0_dp, 0, low_blocks, low_preconditioning, &
                          low_own_near_field, no_pairs, err)
      end if
      if (.not. err%failed) then
        call create_motion_solver(low_solver, ctx%comm, low_op%matrix, low_preconditioning, low%size, &
                                  size(centres, 2, kind=i8), first, count, rtol, 'companion solve', &
                                  report, low_blocks, low_op, settings%solve_apart, &
                                  settings%deflation)
        call move_alloc(low_start, low_solver%initial_guess)
        if (settings%flow) then
          call move_alloc(low_strain_start, low_solver%strain_initial_guess)
          call pose_strains(low_solver, projection(unknowns, :), own_strain(unknowns, :), centres, reference_point)
        end if
        call solve_level(low_solver, low_op, low, projection(unknowns, :), job_result%companion_multipole_friction, &
                         job_result%companion_solves, err)
        if (.not. err%failed) call mask_uncomputed(job_result%companion_solves, job_result%companion_multipole_friction)
        if (.not. err%failed .and. settings%flow) call strain_grand_resistance(low_solver, &
          job_result%companion_grand_resistance, job_result%companion_strain_solves)
        if (.not. err%failed .and. settings%flow .and. control_first .and. low%order == 1) then
          ! As an order-1 job's (the control samples'): the beads' own stresslets by Faxen's law.
          allocate (low_response(low%size * count, n_strain_modes))
          call stresslet_pattern_response(centres, first, count, projection(unknowns, :), low_response)
          call add_bead_stresslets(low_solver, low_response, job_result%companion_grand_resistance)
        end if
        if (.not. err%failed .and. control_first) then
          allocate (low_solution(low%size * count, 6))
          call keep_solution_part(low_solver, [(k, k=1, low%size)], low_solution)
          if (settings%flow) then
            allocate (low_strain_solution(low%size * count, n_strain_modes))
            call keep_strain_solution_part(low_solver, [(k, k=1, low%size)], low_strain_solution)
          end if
        end if
        call destroy_motion_solver(low_solver)
      end if
      call low_op%destroy()
    end subroutine companion_friction

    !> Collective. The motions of one level (order L or its companion) with `level_solver`: the
    !> symmetries of the beads in `level_basis` (none for an operator solved exactly, whose
    !> factorisation costs a triangular solve per motion), then the requested motions' solves and
    !> their friction.
    subroutine solve_level(level_solver, level_op, level_basis, level_projection, friction, stats, err)
      type(motion_solver_t), intent(inout) :: level_solver
      class(multipole_operator_t), intent(in) :: level_op
      type(multipole_basis_t), intent(in) :: level_basis
      real(dp), intent(in) :: level_projection(:, :)
      real(dp), intent(out) :: friction(6, 6)
      type(solve_statistics_t), intent(out) :: stats
      type(error_t), intent(inout) :: err
      if (settings%use_symmetry .and. .not. level_op%assembled) then
        call find_symmetry(level_solver, level_basis, centres, reference_point, symmetry_group, err)
        if (err%failed) return
      end if
      call solve_motions(level_solver, level_projection, centres, reference_point, settings%motions, friction, stats, err)
    end subroutine solve_level

    !> The preconditioner of an operator: its own Cholesky factorisation when it is assembled (the
    !> dense operator, by MUMPS in the solver), the single-bead blocks (`blocks` allocated) when no
    !> pair is within `radius` (d) or the same `cluster` cube, else the assembled near-field
    !> matrix of those pairs (`owned`: to be destroyed with the operator).
    subroutine precondition(level_op, level_basis, self_block, radius, cluster, blocks, preconditioning, owned, pairs, err)
      class(multipole_operator_t), intent(in) :: level_op
      type(multipole_basis_t), intent(in) :: level_basis
      real(dp), intent(in) :: self_block(:, :), radius
      integer, intent(in) :: cluster
      type(bead_block_preconditioner_t), allocatable, intent(inout) :: blocks
      Mat, intent(out) :: preconditioning
      logical, intent(out) :: owned
      integer(i8), intent(out) :: pairs
      type(error_t), intent(inout) :: err
      integer(i8) :: local_pairs
      owned = .false.
      pairs = 0
      preconditioning = level_op%matrix
      if (level_op%assembled) return
      if (radius < 1.0_dp .and. cluster < 2) then
        allocate (blocks)
        call make_bead_block_preconditioner(self_block, blocks, err)
      else
        call assemble_near_field(ctx%comm, level_basis, self_block, centres, first, count, radius, cluster, &
                                 preconditioning, local_pairs)
        owned = .true.
        call MPI_Allreduce(local_pairs, pairs, 1, MPI_INTEGER8, MPI_SUM, ctx%comm, ierr)
      end if
    end subroutine precondition

    !> friction += the lubrication correction of order (order, potential_order): every rank gets
    !> the same small table (kept in `table`), the pair sum is split by rows.
    subroutine lubricated(order, potential_order, table, friction)
      integer, intent(in) :: order, potential_order
      type(lubrication_table_t), intent(out) :: table
      real(dp), intent(inout) :: friction(6, 6)
      call make_shared_lubrication_table(ctx%comm, order, potential_order, centres, &
                                         settings%lubrication_cutoff * (1.0_dp + 1.0e-9_dp), trim(settings%cache_file), &
                                         table, err)
      call agree_on_error(ctx, err)
      if (err%failed) return
      local = 0.0_dp
      call add_lubrication(table, centres, reference_point, int(first), int(first + count - 1), local, local_pairs)
      call MPI_Allreduce(local, lubrication_sum, 36, MPI_DOUBLE_PRECISION, MPI_SUM, ctx%comm, ierr)
      call MPI_Allreduce(local_pairs, job_result%lubrication_pairs, 1, MPI_INTEGER, MPI_SUM, ctx%comm, ierr)
      friction = friction + lubrication_sum
    end subroutine lubricated

    !> The operator and the near-field matrix assembled for it, once (the dense operator's is its
    !> own); the operator is gone afterwards.
    subroutine release_operator()
      if (own_near_field) then
        PetscCallA(MatDestroy(near_field, ierr))
      end if
      own_near_field = .false.
      call op%destroy()
      deallocate (op)
    end subroutine release_operator

    !> seconds(phase) = time since the end of the previous phase; the next -log_view stage begins.
    subroutine mark(phase)
      integer, intent(in) :: phase
      job_result%seconds(phase) = MPI_Wtime() - start - sum(job_result%seconds(1:phase - 1))
      job_result%phase_peak_memory_bytes(phase) = peak_resident_bytes()
      PetscCallA(PetscLogStagePop(ierr))
      if (phase < size(stages)) then
        PetscCallA(PetscLogStagePush(stages(phase + 1), ierr))
        call progress_line(report, 'phase ' // trim(phase_names(phase + 1)) // ' (' // &
                           progress_seconds(MPI_Wtime() - start) // ' s into the friction job)')
      end if
    end subroutine mark
  end subroutine friction_of_beads

  !> The companion's order (L - 1) and potential order (L2 - 1, at least 0): one order lower in both
  !> families, so its basis is a subset of the order-L one (multipole_basis.f90).
  pure subroutine companion_orders(order, potential_order, low_order, low_potential_order)
    integer, intent(in) :: order, potential_order
    integer, intent(out) :: low_order, low_potential_order
    low_order = order - 1
    low_potential_order = max(potential_order - 1, 0)
  end subroutine companion_orders

  !> The companion's unknowns in the order-L basis `basis`: the functions of order L - 1 (companion_orders).
  pure function companion_unknowns(basis) result(unknowns)
    type(multipole_basis_t), intent(in) :: basis
    integer, allocatable :: unknowns(:)
    integer :: low_order, low_potential_order
    call companion_orders(basis%order, basis%potential_order, low_order, low_potential_order)
    unknowns = sub_basis(basis, make_multipole_basis(low_order, low_potential_order))
  end function companion_unknowns

  !> Index in `basis` of each function of `low` (same degree, family and harmonic; the functions
  !> and their normalisation do not depend on the truncation, multipole_basis.f90).
  pure function sub_basis(basis, low) result(unknowns)
    type(multipole_basis_t), intent(in) :: basis, low
    integer :: unknowns(low%size), a, b
    unknowns = 0
    do a = 1, low%size
      do b = 1, basis%size
        if (basis%degree(b) == low%degree(a) .and. basis%family(b) == low%family(a) .and. &
            basis%harmonic(b) == low%harmonic(a)) unknowns(a) = b
      end do
    end do
  end function sub_basis

  !> Entries between two motions not computed are unknown (NaN).
  pure subroutine mask_uncomputed(solves, friction)
    type(solve_statistics_t), intent(in) :: solves
    real(dp), intent(inout) :: friction(6, 6)
    integer :: motion
    do motion = 1, 6
      where (solves%source < 0 .and. solves%source(motion) < 0) friction(:, motion) = ieee_value(1.0_dp, ieee_quiet_nan)
    end do
  end subroutine mask_uncomputed

  !> The part of a checkpoint's key the friction job knows (rigid_body_solve.F90 adds the Krylov
  !> settings used): everything the solutions depend on. The beads in the solve enter by a digest
  !> of their coordinates' bits, since a bead file can change under an unchanged input.
  function checkpoint_key(settings, centres, reference_point, unknowns_per_bead, operator_name) result(key)
    type(friction_settings_t), intent(in) :: settings
    real(dp), intent(in) :: centres(:, :), reference_point(3)
    integer, intent(in) :: unknowns_per_bead
    character(len=*), intent(in) :: operator_name
    character(len=:), allocatable :: key
    character(len=160) :: line
    character(len=1), parameter :: nl = new_line('a')
    key = 'beadmob checkpoint key 1' // nl
    if (allocated(settings%checkpoint_input)) key = key // settings%checkpoint_input
    write (line, '(a, 3es25.17)') 'reference point:', reference_point
    key = key // 'beads in the solve: ' // str(size(centres, 2)) // ', coordinates digest ' // &
          reals_digest(centres) // nl // trim(line) // nl // &
          'unknowns per bead: ' // str(unknowns_per_bead) // nl // &
          'operator: ' // trim(operator_name) // ', fft planner ' // trim(settings%fft_planner) // nl // &
          'near field: radius ' // str(settings%near_field_radius) // ', cluster ' // &
          str(settings%near_field_cluster) // nl
  end function checkpoint_key


end module beadmob_friction_job
