!> Friction of a rigid bead model: six Krylov solves A q = c, one per unit rigid motion
!> (translations along x, y, z; rotations about x, y, z through the reference point), with c the
!> projections of the bead surface velocities on the multipole basis; the force and torque of
!> the solved multipoles give the 6x6 friction matrix (theory.md T5; Cichocki et al., J. Chem.
!> Phys. 100, 3780 (1994), section II). zeta_mn = c_m . q_n is evaluated in its variational form
!> c_m . q_n + q_m . r_n (r_n = c_n - A q_n the residual), whose error is quadratic in the solver
!> error, -e_m^T A e_n, instead of linear: the friction is then accurate far below the Krylov
!> tolerance, symmetric, and independent of the number of ranks to rounding.
!> Default Krylov method: CG, since A is the Galerkin matrix of the Stokes single-layer operator in
!> an orthonormal basis, symmetric positive definite (theory.md T6). Preconditioner: the
!> single-bead blocks (a PCSHELL, beadmob_bead_block_preconditioner) when given, else the
!> Cholesky factorisation by MUMPS of the assembled near-field matrix (beadmob_near_field_matrix).
!> Default relative tolerance 1e-3: with the variational friction the solver error of the paper's
!> coefficients is then ~1e-4 (the paper cone: 7e-5), 30x below the truncation error of L = 2
!> (0.2 % against L = 3), so a tighter default would cost time for no accuracy
!> (bench/accuracy/solver_tolerance.md). Every -ksp_/-pc_ option applies.
module beadmob_rigid_body_solve
#include "petsc/finclude/petscksp.h"
  use petscksp
  use, intrinsic :: iso_fortran_env, only: error_unit
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use hdf5, only: hid_t
  use beadmob_vector_algebra, only: cross
  use beadmob_kinds, only: dp, i8
  use beadmob_bead_block_preconditioner, only: bead_block_preconditioner_t, attach_bead_block_preconditioner
  use beadmob_motion_symmetry, only: motion_symmetry_t, find_motion_symmetry, derive_solution, destroy_motion_symmetry, &
                                     derive_strain_solution
  use beadmob_multipole_basis, only: multipole_basis_t
  use beadmob_linear_flow, only: n_strain_modes, strain_velocity
  use beadmob_bead_stresslet, only: bead_self_stresslet
  use beadmob_multipole_operator, only: multipole_operator_t
  use beadmob_lockstep_cg, only: krylov_limits_t, solve_lockstep
  use beadmob_deflation_space, only: deflation_space_t, make_deflation_space, destroy_deflation_space
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t, make_run_context, agree_on_error
  use beadmob_progress, only: progress_line, progress_seconds
  use beadmob_checkpoint_file, only: saved_solve_t, checkpoint_writer_t, begin_checkpoint, write_checkpoint_motion, &
                                     commit_checkpoint, open_checkpoint, read_checkpoint_motion, close_checkpoint, &
                                     fnv1a_hex, checkpoint_matches, checkpoint_other_key
  implicit none
  private
  public :: solve_statistics_t, motion_solver_t, create_motion_solver, use_checkpoint, find_symmetry, solve_motions, &
            keep_solution_part, bead_forces_of_solutions, destroy_motion_solver, motion_names, &
            strain_statistics_t, pose_strains, strain_grand_resistance, keep_strain_solution_part, strain_names, &
            add_bead_stresslets

  character(len=*), parameter :: motion_names(6) = [character(len=3) :: 'U_x', 'U_y', 'U_z', 'W_x', 'W_y', 'W_z']
  character(len=*), parameter :: strain_names(n_strain_modes) = [character(len=3) :: 'E_1', 'E_2', 'E_3', 'E_4', 'E_5']

  !> What the five strain solves of a body held still in an ambient strain report (theory.md T19).
  type :: strain_statistics_t
    integer :: iterations(n_strain_modes) = 0
    integer :: converged_reason(n_strain_modes) = 0
    real(dp) :: true_relative_residual(n_strain_modes) = -1.0_dp
    !> lambda_max / lambda_min of M A from these solves' Lanczos coefficients (0: none)
    real(dp) :: condition_estimate = 0.0_dp
    !> 1: solved together (lockstep_cg.F90), 0: one KSPSolve after another
    integer :: solved_together = 0
    !> Vectors of the coarse space the strain solves were deflated by (0: none)
    integer :: deflation_vectors = 0
    !> 1: the strain's solution was loaded from the checkpoint instead of solved
    integer :: resumed(n_strain_modes) = 0
    !> 0: solved (or resumed); k: derived from strain k by a symmetry of the beads (motion_symmetry.F90)
    integer :: source(n_strain_modes) = 0
    !> ||G - G^T|| / ||G|| of the plain estimate of the grand resistance G_mn = c_m . q_n
    real(dp) :: plain_symmetry_error = 0.0_dp
  end type strain_statistics_t

  !> What each solve reports (recorded in the result file).
  type :: solve_statistics_t
    integer :: iterations(6) = 0
    integer :: converged_reason(6) = 0
    !> 0: solved; m > 0: derived from motion m by a symmetry (motion_symmetry.F90); -1: not
    !> computed (not requested; its true residual is then recorded as -1)
    integer :: source(6) = 0
    real(dp) :: true_relative_residual(6) = 0.0_dp
    character(len=80) :: ksp_type = '', pc_type = ''
    !> 1: the motions solved here ran together (lockstep_cg.F90, one batched product per
    !> iteration); 0: one KSPSolve after another, or nothing solved
    integer :: solved_together = 0
    !> Vectors of the coarse space the solves together were deflated by (deflation_space.F90;
    !> 0: none)
    integer :: deflation_vectors = 0
    real(dp) :: relative_tolerance = 0.0_dp
    !> ||Z - Z^T|| / ||Z|| of the plain estimate Z_mn = c_m . q_n (a measure of the solver error)
    real(dp) :: plain_symmetry_error = 0.0_dp
    !> max |q_m . r_n| / max |zeta|: size of the variational correction (the plain estimate's error)
    real(dp) :: variational_correction = 0.0_dp
    !> 1: the motion's solution was loaded from the checkpoint instead of solved
    integer :: resumed(6) = 0
    !> sqrt(r^T M r / c^T M c) of each computed motion, M the preconditioner (-1: not computed)
    real(dp) :: natural_relative_residual(6) = -1.0_dp
    !> lambda_max / lambda_min of the preconditioned operator M A from the Lanczos coefficients
    !> of the CG solves (largest over this call's solves; a lower bound of the true ratio,
    !> close after the iterations a solve takes); 0 when nothing was solved here
    real(dp) :: condition_estimate = 0.0_dp
    !> lambda_min of M A from the same Lanczos coefficients (smallest over this call's solves; an
    !> upper estimate of the true one); 0 when nothing was solved here
    real(dp) :: smallest_eigenvalue = 0.0_dp
    !> What the solver error of the friction is at most (theory.md T5, "Solver error bound"):
    !> |zeta_mn - zeta_mn(exact solve)| <= bound sqrt(zeta_mm zeta_nn) between computed motions
    !> (-1: no bound, see solver_error_bound)
    real(dp) :: solver_error_bound = -1.0_dp
  end type solve_statistics_t

  !> The Krylov solver of the rigid-motion systems A q_m = c_m of one operator: its KSP and
  !> preconditioner, the six right-hand sides, solutions and residuals, the symmetries it derives
  !> motions by, how it reports and what it saves. Made by create_motion_solver, set up further
  !> by use_checkpoint, find_symmetry and its public components, run by solve_motions, read by
  !> keep_solution_part and bead_forces_of_solutions, released by destroy_motion_solver.
  type :: motion_solver_t
    type(run_context_t) :: ctx
    Mat :: matrix
    KSP :: ksp
    PC :: pc
    !> The preconditioner is the single-bead blocks (a PCSHELL), not a factorisation
    logical :: single_bead_blocks = .false.
    Vec :: template, preconditioned
    Vec :: rhs(6), solution(6), residual(6)
    !> The strain problems (solve_strains; made on first use): right-hand sides, solutions, residuals
    logical :: with_strains = .false.
    Vec :: strain_rhs(n_strain_modes), strain_solution(n_strain_modes), strain_residual(n_strain_modes)
    !> Allocated (nb n_local x 5): each strain solve starts from its column (the companion's)
    real(dp), allocatable :: strain_initial_guess(:, :)
    !> pose_strains was called: solve_motions solves the strains too, recorded here
    logical :: strains_posed = .false.
    type(strain_statistics_t) :: strain_stats
    !> Strains loaded from the checkpoint, solved by this call, and their saved records
    logical :: strain_loaded(n_strain_modes) = .false., strain_solved(n_strain_modes) = .false.
    type(saved_solve_t) :: strain_saved(n_strain_modes)
    integer :: nb = 0                              ! unknowns per bead
    integer(i8) :: first_bead = 1, n_local = 0, n_total = 0
    !> Rank 0 prints a progress line per solve, beginning with `label` (e.g. 'companion solve')
    logical :: progress = .false.
    character(len=:), allocatable :: label
    !> Checkpoint of the solved motions (checkpoint_file.f90; '' = none) and its key: what the
    !> solutions depend on, the Krylov settings actually used included (use_checkpoint)
    character(len=:), allocatable :: checkpoint_file, key
    logical :: saving = .false.
    logical :: loaded(6) = .false.
    logical :: solved(6) = .false.     ! solved by this call of solve_motions so far
    type(saved_solve_t) :: saved(6)
    !> A test of the resume: stop with an error right after this many solves have been saved,
    !> as a kill at a wall-time limit would (0 = never)
    integer :: stop_after_solves = 0
    !> Allocated (nb n_local x 6): each solve starts from its column instead of zero (the
    !> companion from the order-L solution, friction_job.F90)
    real(dp), allocatable :: initial_guess(:, :)
    !> Allocated by find_symmetry: the motions that follow from others are derived, not solved
    type(motion_symmetry_t), allocatable :: symmetry
    !> The motions are solved together (lockstep_cg.F90: one batched product of `op` per
    !> iteration) when the Krylov method is CG in the preconditioned norm, as KSP would solve
    !> them one at a time with `limits`; otherwise one KSPSolve after another.
    logical :: together = .false.
    !> Motions solved together are deflated by their coarse space (deflation_space.F90) where
    !> at least two of them are coupled (motion_symmetry_t%coupled)
    logical :: deflate = .false.
    class(multipole_operator_t), pointer :: op => null()
    type(krylov_limits_t) :: limits
  end type motion_solver_t

  !> A loaded solution must give the true residual it was saved with (to rounding, which varies
  !> with the number of ranks): otherwise it does not solve this run's system and is solved again.
  real(dp), parameter :: resumed_residual_tolerance = 1.0e-3_dp

contains

  !> Collective. The solver of `matrix` (nb unknowns per bead; this rank owns beads
  !> first_bead..first_bead+n_local-1 of n_total): CG (theory.md T6) with the single-bead blocks
  !> when bead_blocks is given (preconditioning_matrix then unused), else the Cholesky
  !> factorisation by MUMPS of preconditioning_matrix; relative_tolerance unless -ksp_rtol is
  !> given. Every -ksp_/-pc_ option applies. bead_blocks must outlive the solver. With `op` (the
  !> operator of `matrix`, which must outlive the solver too) and not `apart`, the motions are
  !> solved together when the Krylov method allows it (motion_solver_t%together), and deflated
  !> when `deflate` (motion_solver_t%deflate).
  subroutine create_motion_solver(solver, comm, matrix, preconditioning_matrix, nb, n_total, first_bead, n_local, &
                                  relative_tolerance, label, progress, bead_blocks, op, apart, deflate)
    type(motion_solver_t), intent(out) :: solver
    MPI_Comm, intent(in) :: comm
    Mat, intent(in) :: matrix, preconditioning_matrix
    integer, intent(in) :: nb
    integer(i8), intent(in) :: n_total, first_bead, n_local
    real(dp), intent(in) :: relative_tolerance
    character(len=*), intent(in) :: label
    logical, intent(in) :: progress
    type(bead_block_preconditioner_t), intent(in), optional, target :: bead_blocks
    class(multipole_operator_t), intent(inout), optional, target :: op
    logical, intent(in), optional :: apart, deflate
    PetscErrorCode :: ierr
    integer :: motion
    KSPType :: ksp_type
    KSPNormType :: norm_type
    PetscReal :: rtol, abstol, dtol
    PetscInt :: max_iterations

    solver%ctx = make_run_context(comm)
    solver%matrix = matrix
    solver%nb = nb
    solver%n_total = n_total
    solver%first_bead = first_bead
    solver%n_local = n_local
    solver%label = label
    solver%progress = progress
    solver%checkpoint_file = ''
    PetscCallA(KSPCreate(comm, solver%ksp, ierr))
    PetscCallA(KSPSetType(solver%ksp, KSPCG, ierr))
    PetscCallA(KSPGetPC(solver%ksp, solver%pc, ierr))
    solver%single_bead_blocks = present(bead_blocks)
    if (present(bead_blocks)) then
      PetscCallA(KSPSetOperators(solver%ksp, matrix, matrix, ierr))
      call attach_bead_block_preconditioner(solver%pc, bead_blocks)
    else
      PetscCallA(KSPSetOperators(solver%ksp, matrix, preconditioning_matrix, ierr))
      PetscCallA(PCSetType(solver%pc, PCCHOLESKY, ierr))
      PetscCallA(PCFactorSetMatSolverType(solver%pc, MATSOLVERMUMPS, ierr))
    end if
    PetscCallA(KSPSetTolerances(solver%ksp, relative_tolerance, PETSC_DEFAULT_REAL, PETSC_DEFAULT_REAL, PETSC_DEFAULT_INTEGER, ierr))
    PetscCallA(KSPSetFromOptions(solver%ksp, ierr))
    ! The Lanczos coefficients that CG has anyway give the spectrum's ends (the error bound).
    PetscCallA(KSPSetComputeSingularValues(solver%ksp, PETSC_TRUE, ierr))
    ! The preconditioner set up now: the bound applies it to resumed and derived motions too.
    PetscCallA(KSPSetUp(solver%ksp, ierr))
    if (present(op)) then
      PetscCallA(KSPGetType(solver%ksp, ksp_type, ierr))
      PetscCallA(KSPGetNormType(solver%ksp, norm_type, ierr))
      solver%together = ksp_type == KSPCG .and. norm_type == KSP_NORM_PRECONDITIONED
      if (present(apart)) solver%together = solver%together .and. .not. apart
      if (present(deflate)) solver%deflate = solver%together .and. deflate
      PetscCallA(KSPGetTolerances(solver%ksp, rtol, abstol, dtol, max_iterations, ierr))
      solver%limits = krylov_limits_t(rtol, abstol, dtol, int(max_iterations))
      solver%op => op
    end if
    PetscCallA(MatCreateVecs(matrix, solver%template, PETSC_NULL_VEC, ierr))
    PetscCallA(VecDuplicate(solver%template, solver%preconditioned, ierr))
    do motion = 1, 6
      PetscCallA(VecDuplicate(solver%template, solver%rhs(motion), ierr))
      PetscCallA(VecDuplicate(solver%template, solver%solution(motion), ierr))
      PetscCallA(VecDuplicate(solver%template, solver%residual(motion), ierr))
    end do
  end subroutine create_motion_solver

  !> Save each solved motion to checkpoint_file and resume from it: job_key is everything the
  !> solutions depend on but the Krylov settings, which are added here (the ones actually used,
  !> after -ksp_ / -pc_ options). An empty file name: no checkpoint.
  subroutine use_checkpoint(solver, checkpoint_file, job_key)
    type(motion_solver_t), intent(inout) :: solver
    character(len=*), intent(in) :: checkpoint_file, job_key
    KSPType :: ksp_type
    PCType :: pc_type
    PetscReal :: rtol, abstol, dtol
    PetscInt :: max_iterations
    PetscErrorCode :: ierr
    solver%checkpoint_file = checkpoint_file
    solver%saving = len(checkpoint_file) > 0
    if (.not. solver%saving) return
    PetscCallA(KSPGetType(solver%ksp, ksp_type, ierr))
    PetscCallA(PCGetType(solver%pc, pc_type, ierr))
    PetscCallA(KSPGetTolerances(solver%ksp, rtol, abstol, dtol, max_iterations, ierr))
    solver%key = job_key // 'krylov: ' // trim(ksp_type) // ', preconditioner ' // trim(pc_type) // &
                 ', rtol ' // real_text(rtol) // ', abstol ' // real_text(abstol) // ', dtol ' // real_text(dtol) // &
                 ', max_it ' // str(int(max_iterations)) // new_line('a')
  end subroutine use_checkpoint

  !> Collective. The symmetry group in_group of the bead set `centres` about reference_point (the
  !> plan's, find_symmetry_group) in `basis` (motion_symmetry.F90): the motions it gives are
  !> derived from others by solve_motions.
  subroutine find_symmetry(solver, basis, centres, reference_point, in_group, err)
    type(motion_solver_t), intent(inout) :: solver
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :), reference_point(3)
    logical, intent(in) :: in_group(:)
    type(error_t), intent(inout) :: err
    allocate (solver%symmetry)
    call find_motion_symmetry(solver%ctx%comm, basis, centres, reference_point, in_group, solver%first_bead, &
                              solver%n_local, solver%template, solver%symmetry, err, with_strains=solver%strains_posed)
    ! The same replicated centres everywhere: only a resource failure differs.
    call agree_on_error(solver%ctx, err)
  end subroutine find_symmetry

  !> Collective. The requested rigid motions about reference_point (with the sources of derived
  !> ones), solved, derived by the symmetries or resumed from the checkpoint, and the friction
  !> zeta_mn = c_m . q_n + q_m . r_n between them. projection(:, m): the basis projection of unit
  !> motion m of one bead about its centre (its transpose gives force and torque from the
  !> multipoles); `centres` holds all beads. friction(m, n) = c_m . q_n for m not computed, n
  !> computed (first order in the solver error, the variational form needs q_m), and 0 where
  !> neither is. err: only the test stop (-stop_after_solves), the same on every rank.
  subroutine solve_motions(solver, projection, centres, reference_point, requested, friction, stats, err)
    type(motion_solver_t), intent(inout) :: solver
    real(dp), intent(in) :: projection(:, :), centres(:, :), reference_point(3)
    logical, intent(in) :: requested(6)
    real(dp), intent(out) :: friction(6, 6)
    type(solve_statistics_t), intent(out) :: stats
    type(error_t), intent(inout) :: err
    logical :: computed(6), stopped, coupled(6, 6)
    logical :: product_ready(6)   ! residual(m) holds A q_m already (residual_products)
    logical, allocatable :: in_coarse_space(:)
    type(deflation_space_t) :: coarse_space
    real(dp) :: started, elapsed, solve_seconds
    integer :: solves_done, solves_planned, k
    integer, allocatable :: to_solve(:)
    PetscErrorCode :: ierr
    PetscScalar, pointer :: values(:)
    PetscReal :: rhs_norm, residual_norm, rtol, abstol, dtol, largest_value, smallest_value
    PetscInt :: iterations, max_iterations
    KSPConvergedReason :: reason
    KSPType :: ksp_type
    PCType :: pc_type
    real(dp) :: arm(3), plain(6, 6), correction(6, 6), residual_square, rhs_square
    Vec, allocatable :: systems(:), unknowns(:)   ! a batch of motions and strains
    integer, allocatable :: strains_to_solve(:)
    PetscBool :: nonzero_start
    integer(i8) :: i, bead
    integer :: motion, other, nb

    nb = solver%nb
    product_ready = .false.
    if (allocated(solver%initial_guess)) then
      PetscCallA(KSPSetInitialGuessNonzero(solver%ksp, PETSC_TRUE, ierr))
    end if
    if (allocated(solver%symmetry)) stats%source = solver%symmetry%source
    computed = requested
    do motion = 1, 6
      if (requested(motion) .and. stats%source(motion) > 0) computed(stats%source(motion)) = .true.
    end do
    do motion = 1, 6   ! a source left out: its derived motions are solved themselves
      if (stats%source(motion) > 0) then
        if (.not. computed(stats%source(motion))) stats%source(motion) = 0
      end if
    end do
    where (.not. computed) stats%source = -1

    solver%loaded = .false.
    solver%solved = .false.
    if (solver%saving) call load_checkpoint(solver, stats%source)
    solves_planned = count(stats%source == 0 .and. .not. solver%loaded)
    solves_done = 0
    solve_seconds = 0.0_dp
    associate (rhs => solver%rhs, solution => solver%solution, residual => solver%residual, &
               loaded => solver%loaded, saved => solver%saved, label => solver%label)
    do motion = 1, 6
      ! c_i = projection (U_i, Omega_i), U_i = V + w x (R_i - R_0), Omega_i = w.
      PetscCallA(VecGetArrayF90(rhs(motion), values, ierr))
      do i = 1, solver%n_local
        bead = solver%first_bead + i - 1
        arm = centres(:, bead) - reference_point
        values(nb * (i - 1) + 1:nb * i) = matmul(projection, rigid_velocity(motion, arm))
      end do
      PetscCallA(VecRestoreArrayF90(rhs(motion), values, ierr))
      if (stats%source(motion) < 0) then
        ! Not computed: q = 0, r = c, so the friction formula below gives c_m . q_n with others.
        PetscCallA(VecZeroEntries(solution(motion), ierr))
        PetscCallA(VecCopy(rhs(motion), residual(motion), ierr))
        stats%iterations(motion) = 0
        stats%converged_reason(motion) = 0
        stats%true_relative_residual(motion) = -1.0_dp
      else if (stats%source(motion) == 0 .and. loaded(motion)) then
        ! Resumed: the record of the solve that made it, and its true residual checked again.
        stats%iterations(motion) = saved(motion)%iterations
        stats%converged_reason(motion) = saved(motion)%converged_reason
        call true_residual(motion)
        if (.not. same_residual(stats%true_relative_residual(motion), saved(motion)%true_relative_residual)) then
          if (solver%ctx%rank == 0) write (error_unit, '(a, es9.2, a, es9.2, a)') 'beadmob: warning: checkpoint ''' // &
            solver%checkpoint_file // ''': motion ' // motion_names(motion) // ' gives the true relative residual', &
            stats%true_relative_residual(motion), ' instead of the saved', saved(motion)%true_relative_residual, &
            '; solved again'
          loaded(motion) = .false.
          solves_planned = solves_planned + 1
        else
          call progress_line(solver%progress, label // ' ' // motion_names(motion) // ': resumed from the checkpoint')
        end if
      end if
    end do

    ! The solves: all at once (solve_lockstep), or one KSPSolve after another.
    to_solve = pack([(motion, motion=1, 6)], stats%source == 0 .and. .not. loaded)
    do k = 1, size(to_solve)
      if (allocated(solver%initial_guess)) then
        PetscCallA(VecGetArrayF90(solution(to_solve(k)), values, ierr))
        values = solver%initial_guess(:, to_solve(k))
        PetscCallA(VecRestoreArrayF90(solution(to_solve(k)), values, ierr))
      else
        PetscCallA(VecZeroEntries(solution(to_solve(k)), ierr))
      end if
    end do
    ! The strains not resumed start as the motions do (a failed or foreign load leaves nothing).
    if (solver%strains_posed) solver%strain_stats%source = strain_sources_of(solver)
    do k = 1, n_strain_modes
      if (.not. solver%strains_posed) exit
      if (solver%strain_loaded(k) .or. solver%strain_stats%source(k) > 0) cycle
      if (allocated(solver%strain_initial_guess)) then
        PetscCallA(VecGetArrayF90(solver%strain_solution(k), values, ierr))
        values = solver%strain_initial_guess(:, k)
        PetscCallA(VecRestoreArrayF90(solver%strain_solution(k), values, ierr))
      else
        PetscCallA(VecZeroEntries(solver%strain_solution(k), ierr))
      end if
    end do
    stopped = .false.
    started = MPI_Wtime()
    if (size(to_solve) > 0 .and. solver%together .and. .not. solver%strains_posed) then
      ! The coarse space: the right-hand sides of the motions that share directions with another
      coupled = .true.
      if (allocated(solver%symmetry)) coupled = solver%symmetry%coupled
      in_coarse_space = [(solver%deflate .and. count(coupled(to_solve(k), to_solve)) >= 2, k=1, size(to_solve))]
      call make_deflation_space(solver%op, solver%pc, rhs(to_solve), in_coarse_space, coarse_space)
      stats%deflation_vectors = coarse_space%size
      call solve_lockstep(solver%op, solver%pc, rhs(to_solve), solution(to_solve), allocated(solver%initial_guess), &
                          solver%limits, finished_together, stopped, coarse_space, converging_together)
      call destroy_deflation_space(coarse_space)
    else if (solver%together .and. solver%strains_posed) then
      ! The motions and the strains in one batch (theory.md T19), deflated by the right-hand sides
      ! of all eleven problems: the strains' slow part is the body's large-scale response.
      strains_to_solve = pack([(k, k=1, n_strain_modes)], .not. solver%strain_loaded .and. &
                              solver%strain_stats%source == 0)
      systems = [rhs(to_solve), solver%strain_rhs(strains_to_solve)]
      unknowns = [solution(to_solve), solver%strain_solution(strains_to_solve)]
      solver%strain_stats%solved_together = 1
      if (size(systems) > 0) then   ! else everything was resumed
        call make_deflation_space(solver%op, solver%pc, [rhs, solver%strain_rhs], &
                                  [(solver%deflate, k=1, 6 + n_strain_modes)], coarse_space)
        stats%deflation_vectors = coarse_space%size
        solver%strain_stats%deflation_vectors = coarse_space%size
        call solve_lockstep(solver%op, solver%pc, systems, unknowns, allocated(solver%initial_guess) .or. &
                            allocated(solver%strain_initial_guess), solver%limits, finished_with_strains, stopped, &
                            coarse_space, converging_with_strains)
        call destroy_deflation_space(coarse_space)
      end if
    else
      do k = 1, size(to_solve)
        started = MPI_Wtime()
        PetscCallA(KSPSolve(solver%ksp, rhs(to_solve(k)), solution(to_solve(k)), ierr))
        PetscCallA(KSPGetIterationNumber(solver%ksp, iterations, ierr))
        PetscCallA(KSPGetConvergedReason(solver%ksp, reason, ierr))
        PetscCallA(KSPComputeExtremeSingularValues(solver%ksp, largest_value, smallest_value, ierr))
        call finish_solve(to_solve(k), int(iterations), int(reason), largest_value, smallest_value, stopped)
        if (stopped) exit
      end do
      if (solver%strains_posed .and. .not. stopped) then
        nonzero_start = merge(PETSC_TRUE, PETSC_FALSE, allocated(solver%strain_initial_guess))
        PetscCallA(KSPSetInitialGuessNonzero(solver%ksp, nonzero_start, ierr))
        do k = 1, n_strain_modes
          if (solver%strain_loaded(k) .or. solver%strain_stats%source(k) > 0) cycle
          PetscCallA(KSPSolve(solver%ksp, solver%strain_rhs(k), solver%strain_solution(k), ierr))
          PetscCallA(KSPGetIterationNumber(solver%ksp, iterations, ierr))
          PetscCallA(KSPGetConvergedReason(solver%ksp, reason, ierr))
          PetscCallA(KSPComputeExtremeSingularValues(solver%ksp, largest_value, smallest_value, ierr))
          call finish_strain(k, int(iterations), int(reason), largest_value, smallest_value)
        end do
      end if
    end if
    if (stopped) return

    ! Derived, not solved; each true residual checks it like a solved one (their products at once).
    do motion = 1, 6
      if (stats%source(motion) <= 0) cycle
      call derive_solution(solver%symmetry, motion, solution(stats%source(motion)), solution(motion))
    end do
    call residual_products(pack([(motion, motion=1, 6)], stats%source > 0))
    do motion = 1, 6
      if (stats%source(motion) <= 0) cycle
      stats%iterations(motion) = 0
      stats%converged_reason(motion) = stats%converged_reason(stats%source(motion))
      call true_residual(motion)
    end do
    ! The strains likewise, in order (each from earlier ones); strain_grand_resistance checks them.
    do k = 1, n_strain_modes
      if (.not. solver%strains_posed) exit
      if (solver%strain_stats%source(k) == 0) cycle
      call derive_strain_solution(solver%symmetry, k, solver%strain_solution)
      solver%strain_stats%iterations(k) = 0
      solver%strain_stats%converged_reason(k) = solver%strain_stats%converged_reason(solver%strain_stats%source(k))
    end do

    ! zeta_mn = c_m . q_n + q_m . r_n (the force and torque of solution n projected on motion m).
    do motion = 1, 6
      do other = 1, 6
        PetscCallA(VecDot(rhs(motion), solution(other), plain(motion, other), ierr))
        PetscCallA(VecDot(solution(motion), residual(other), correction(motion, other), ierr))
      end do
    end do
    end associate
    friction = plain + correction
    stats%plain_symmetry_error = norm2(plain - transpose(plain)) / norm2(plain)
    stats%variational_correction = maxval(abs(correction)) / maxval(abs(friction))
    stats%solver_error_bound = solver_error_bound(stats, solver%n_total * nb)

    PetscCallA(KSPGetType(solver%ksp, ksp_type, ierr))
    PetscCallA(PCGetType(solver%pc, pc_type, ierr))
    PetscCallA(KSPGetTolerances(solver%ksp, rtol, abstol, dtol, max_iterations, ierr))
    stats%ksp_type = ksp_type
    stats%pc_type = pc_type
    if (solver%single_bead_blocks .and. pc_type == PCSHELL) stats%pc_type = 'single-bead blocks (shell)'
    stats%relative_tolerance = rtol
    stats%resumed = merge(1, 0, solver%loaded)
    stats%solved_together = merge(1, 0, size(to_solve) > 0 .and. solver%together)

  contains

    !> The batch of motions and strains: system j is motion to_solve(j) up to size(to_solve), then
    !> strain j - size(to_solve); the strains' residuals are made afterwards (strain_grand_resistance).
    subroutine finished_with_strains(j, its, why, largest, smallest, stop)
      integer, intent(in) :: j, its, why
      real(dp), intent(in) :: largest, smallest
      logical, intent(inout) :: stop
      if (j <= size(to_solve)) then
        call finish_solve(to_solve(j), its, why, largest, smallest, stop)
      else
        call finish_strain(strains_to_solve(j - size(to_solve)), its, why, largest, smallest)
      end if
    end subroutine finished_with_strains

    !> Strain k solved: recorded and, with a checkpoint, saved at once with everything before it
    !> (its record's true residual is the one strain_grand_resistance finds: computed here).
    subroutine finish_strain(k, its, why, largest, smallest)
      integer, intent(in) :: k, its, why
      real(dp), intent(in) :: largest, smallest
      call record_strain_solve(solver, k, its, why, largest, smallest)
      solver%strain_solved(k) = .true.
      if (.not. solver%saving) return
      solver%strain_saved(k) = saved_solve_t(its, why, strain_true_residual(solver, k))
      call save_checkpoint(solver, 0, stats%source)
    end subroutine finish_strain

    subroutine converging_with_strains(js)
      integer, intent(in) :: js(:)
      if (any(js <= size(to_solve))) call residual_products(to_solve(pack(js, js <= size(to_solve))))
    end subroutine converging_with_strains

    !> solve_lockstep's systems ks converge together: their true residuals' products in one batch.
    subroutine converging_together(ks)
      integer, intent(in) :: ks(:)
      call residual_products(to_solve(ks))
    end subroutine converging_together

    !> residual(m) = A q_m for the motions ms, one batched product; true_residual uses them.
    subroutine residual_products(ms)
      integer, intent(in) :: ms(:)
      if (size(ms) == 0) return
      call solver%op%apply_many(solver%solution(ms), solver%residual(ms))
      product_ready(ms) = .true.
    end subroutine residual_products

    !> solve_lockstep's report of system k (motion to_solve(k)).
    subroutine finished_together(k, its, why, largest, smallest, stop)
      integer, intent(in) :: k, its, why
      real(dp), intent(in) :: largest, smallest
      logical, intent(inout) :: stop
      call finish_solve(to_solve(k), its, why, largest, smallest, stop)
    end subroutine finished_together

    !> Motion m solved (its iterations, KSPConvergedReason, the extreme eigenvalues of B A):
    !> recorded, its true residual checked, saved at once (a kill from here on loses nothing of
    !> it) and reported; stop after the test's number of solves (err set, on every rank alike).
    subroutine finish_solve(m, its, why, largest, smallest, stop)
      integer, intent(in) :: m, its, why
      real(dp), intent(in) :: largest, smallest
      logical, intent(inout) :: stop
      stats%iterations(m) = its
      stats%converged_reason(m) = why
      solver%solved(m) = .true.
      if (smallest > 0.0_dp) stats%condition_estimate = max(stats%condition_estimate, largest / smallest)
      if (smallest > 0.0_dp .and. (stats%smallest_eigenvalue <= 0.0_dp .or. smallest < stats%smallest_eigenvalue)) &
        stats%smallest_eigenvalue = smallest
      call true_residual(m)
      solver%saved(m) = saved_solve_t(its, why, stats%true_relative_residual(m))
      if (solver%saving) call save_checkpoint(solver, m, stats%source)
      solves_done = solves_done + 1
      ! Seconds since the solves began (together) or since this one began (apart); what is left
      ! at the average so far.
      elapsed = MPI_Wtime() - started
      if (.not. solver%together) solve_seconds = solve_seconds + elapsed
      if (solver%together) solve_seconds = elapsed
      call progress_line(solver%progress, solver%label // ' ' // motion_names(m) // ': ' // str(its) // &
                         ' iterations, ' // progress_seconds(elapsed) // ' s; ' // &
                         str(solves_planned - solves_done) // ' solves left, ~' // &
                         progress_seconds(solve_seconds / solves_done * (solves_planned - solves_done)) // ' s')
      if (solves_done == solver%stop_after_solves) then
        ! Every rank counts the same solves: they all stop here together.
        call raise(err, 'stopped after ' // str(solves_done) // ' solves as -stop_after_solves asks (a test ' // &
                   'of the resume)' // saved_where())
        stop = .true.
      end if
    end subroutine finish_solve

    !> stats%true_relative_residual(m) = |c - A q| / |c|, with r = c - A q kept for the friction:
    !> the true residual, independent of the preconditioned norm KSP monitors.
    subroutine true_residual(m)
      integer, intent(in) :: m
      if (.not. product_ready(m)) then
        PetscCallA(MatMult(solver%matrix, solver%solution(m), solver%residual(m), ierr))
      end if
      product_ready(m) = .false.
      PetscCallA(VecAYPX(solver%residual(m), -1.0_dp, solver%rhs(m), ierr))
      PetscCallA(VecNorm(solver%residual(m), NORM_2, residual_norm, ierr))
      PetscCallA(VecNorm(solver%rhs(m), NORM_2, rhs_norm, ierr))
      stats%true_relative_residual(m) = residual_norm / rhs_norm
      residual_square = preconditioned_square(solver%residual(m))
      rhs_square = preconditioned_square(solver%rhs(m))
      stats%natural_relative_residual(m) = -1.0_dp   ! a preconditioner that is not SPD: none
      if (residual_square >= 0.0_dp .and. rhs_square > 0.0_dp) &
        stats%natural_relative_residual(m) = sqrt(residual_square / rhs_square)
    end subroutine true_residual

    !> v^T M v, M the preconditioner (positive for CG's SPD preconditioners).
    real(dp) function preconditioned_square(v)
      Vec, intent(in) :: v
      PetscCallA(PCApply(solver%pc, v, solver%preconditioned, ierr))
      PetscCallA(VecDot(v, solver%preconditioned, preconditioned_square, ierr))
    end function preconditioned_square

    function saved_where() result(text)
      character(len=:), allocatable :: text
      text = ''
      if (solver%saving) text = ", saved in '" // solver%checkpoint_file // "'"
    end function saved_where
  end subroutine solve_motions

  !> Collective, before solve_motions (all six motions computed). The five strain problems of the
  !> body held still in the ambient strains E_k about reference_point (theory.md T19): c_k =
  !> translation of each bead by E_k . (R_i - R_0) plus the bead's own strain (strain_projection of
  !> linear_flow.f90). solve_motions then starts those not resumed from solver%strain_initial_guess
  !> when allocated, else from zero, solves them with the motions (in one lockstep batch when the
  !> motions run together), and strain_grand_resistance reads the result.
  subroutine pose_strains(solver, projection, own_strain, centres, reference_point)
    type(motion_solver_t), intent(inout) :: solver
    real(dp), intent(in) :: projection(:, :), own_strain(:, :), centres(:, :), reference_point(3)
    PetscScalar, pointer :: values(:)
    PetscErrorCode :: ierr
    real(dp) :: arm(3)
    integer(i8) :: i
    integer :: k, nb
    nb = solver%nb
    if (.not. solver%with_strains) then
      do k = 1, n_strain_modes
        PetscCallA(VecDuplicate(solver%template, solver%strain_rhs(k), ierr))
        PetscCallA(VecDuplicate(solver%template, solver%strain_solution(k), ierr))
        PetscCallA(VecDuplicate(solver%template, solver%strain_residual(k), ierr))
      end do
      solver%with_strains = .true.
    end if
    solver%strains_posed = .true.
    solver%strain_stats = strain_statistics_t()
    solver%strain_loaded = .false.
    solver%strain_solved = .false.
    do k = 1, n_strain_modes
      PetscCallA(VecGetArrayF90(solver%strain_rhs(k), values, ierr))
      do i = 1, solver%n_local
        arm = centres(:, solver%first_bead + i - 1) - reference_point
        values(nb * (i - 1) + 1:nb * i) = matmul(projection(:, 1:3), strain_velocity(k, arm)) + own_strain(:, k)
      end do
      PetscCallA(VecRestoreArrayF90(solver%strain_rhs(k), values, ierr))
    end do
  end subroutine pose_strains

  !> Collective, after solve_motions solved the posed strains: their true residuals and the grand
  !> resistance between the eleven right-hand sides in the variational form of solve_motions,
  !> grand_mn = c_m . q_n + q_m . r_n (m, n = U_x..W_z, E_1..E_5), and the strain solves' record.
  subroutine strain_grand_resistance(solver, grand, stats)
    type(motion_solver_t), intent(inout) :: solver
    real(dp), intent(out) :: grand(6 + n_strain_modes, 6 + n_strain_modes)
    type(strain_statistics_t), intent(out) :: stats
    Vec :: c(6 + n_strain_modes), q(6 + n_strain_modes), r(6 + n_strain_modes)
    PetscErrorCode :: ierr
    real(dp) :: plain(6 + n_strain_modes, 6 + n_strain_modes), correction(6 + n_strain_modes, 6 + n_strain_modes)
    integer :: k, m, n
    associate (rhs => solver%strain_rhs, solution => solver%strain_solution, residual => solver%strain_residual)
    ! True residuals r = c - A q (one batched product), kept for the variational form.
    if (associated(solver%op)) then
      call solver%op%apply_many(solution, residual)
    else
      do k = 1, n_strain_modes
        PetscCallA(MatMult(solver%matrix, solution(k), residual(k), ierr))
      end do
    end if
    do k = 1, n_strain_modes
      solver%strain_stats%true_relative_residual(k) = strain_residual_from_product(solver, k)
    end do
    c = [solver%rhs, rhs]
    q = [solver%solution, solution]
    r = [solver%residual, residual]
    end associate
    do n = 1, size(c)
      PetscCallA(VecMDot(q(n), size(c), c, plain(:, n), ierr))
      PetscCallA(VecMDot(r(n), size(c), q, correction(:, n), ierr))
    end do
    grand = plain + correction
    solver%strain_stats%plain_symmetry_error = norm2(plain - transpose(plain)) / norm2(plain)
    do m = 1, size(c)   ! symmetric in exact arithmetic (the Galerkin form of a symmetric operator)
      do n = m + 1, size(c)
        grand(m, n) = 0.5_dp * (grand(m, n) + grand(n, m))
        grand(n, m) = grand(m, n)
      end do
    end do
    solver%strain_stats%resumed = merge(1, 0, solver%strain_loaded)
    stats = solver%strain_stats
    call progress_line(solver%progress, solver%label // ' strains: ' // str(sum(stats%iterations)) // &
                       ' iterations in all' // trim(merge(', with the motions', '                  ', &
                       stats%solved_together == 1)))
  end subroutine strain_grand_resistance

  !> Collective, after strain_grand_resistance of an order-1 solve: the beads' own stresslets
  !> (bead_stresslet.f90) added to the strain rows of its grand resistance,
  !>   grand(E_k, n) += N s0 [n = E_k] - sum_j response_kj . q_nj   (n = U_x..W_z, E_1..E_5),
  !> `response` (nb n_local x 5) this rank's part of the strained beads' projected fields. Only the
  !> rows: the stresslets are read from the forces and do not act back on them, so the matrix is
  !> no longer symmetric by what they add (theory.md T19).
  subroutine add_bead_stresslets(solver, response, grand)
    type(motion_solver_t), intent(in) :: solver
    real(dp), intent(in) :: response(:, :)
    real(dp), intent(inout) :: grand(6 + n_strain_modes, 6 + n_strain_modes)
    Vec :: q(6 + n_strain_modes)
    PetscScalar, pointer :: values(:)
    PetscErrorCode :: ierr
    real(dp) :: work(n_strain_modes, 6 + n_strain_modes)
    integer :: k, n
    q = [solver%solution, solver%strain_solution]
    do n = 1, size(q)
      PetscCallA(VecGetArrayReadF90(q(n), values, ierr))
      work(:, n) = matmul(values, response)
      PetscCallA(VecRestoreArrayReadF90(q(n), values, ierr))
    end do
    call MPI_Allreduce(MPI_IN_PLACE, work, size(work), MPI_DOUBLE_PRECISION, MPI_SUM, solver%ctx%comm, ierr)
    do k = 1, n_strain_modes
      grand(6 + k, :) = grand(6 + k, :) - work(k, :)
      grand(6 + k, 6 + k) = grand(6 + k, 6 + k) + real(solver%n_total, dp) * bead_self_stresslet
    end do
  end subroutine add_bead_stresslets

  !> The strains the solver's symmetries derive (strain_statistics_t%source): none without them.
  pure function strain_sources_of(solver) result(source)
    type(motion_solver_t), intent(in) :: solver
    integer :: source(n_strain_modes)
    source = 0
    if (allocated(solver%symmetry)) source = solver%symmetry%strain_source
  end function strain_sources_of

  !> Collective. |c_k - A q_k| / |c_k| of strain k (its residual vector left in strain_residual(k)).
  real(dp) function strain_true_residual(solver, k) result(relative)
    type(motion_solver_t), intent(inout) :: solver
    integer, intent(in) :: k
    PetscErrorCode :: ierr
    PetscCallA(MatMult(solver%matrix, solver%strain_solution(k), solver%strain_residual(k), ierr))
    relative = strain_residual_from_product(solver, k)
  end function strain_true_residual

  !> Collective. As strain_true_residual, with A q_k already in strain_residual(k) (a batched product).
  real(dp) function strain_residual_from_product(solver, k) result(relative)
    type(motion_solver_t), intent(inout) :: solver
    integer, intent(in) :: k
    PetscErrorCode :: ierr
    PetscReal :: rhs_norm, residual_norm
    PetscCallA(VecAYPX(solver%strain_residual(k), -1.0_dp, solver%strain_rhs(k), ierr))
    PetscCallA(VecNorm(solver%strain_residual(k), NORM_2, residual_norm, ierr))
    PetscCallA(VecNorm(solver%strain_rhs(k), NORM_2, rhs_norm, ierr))
    relative = residual_norm / rhs_norm
  end function strain_residual_from_product

  !> A strain solve has stopped (its iterations, KSPConvergedReason, B A's extreme eigenvalues).
  subroutine record_strain_solve(solver, k, its, why, largest, smallest)
    type(motion_solver_t), intent(inout) :: solver
    integer, intent(in) :: k, its, why
    real(dp), intent(in) :: largest, smallest
    solver%strain_stats%iterations(k) = its
    solver%strain_stats%converged_reason(k) = why
    if (smallest > 0.0_dp) solver%strain_stats%condition_estimate = max(solver%strain_stats%condition_estimate, &
                                                                         largest / smallest)
  end subroutine record_strain_solve

  !> kept (size(unknowns) n_local x 5): the entries `unknowns` of each strain solution (the
  !> companion's start, as keep_solution_part for the motions).
  subroutine keep_strain_solution_part(solver, unknowns, kept)
    type(motion_solver_t), intent(in) :: solver
    integer, intent(in) :: unknowns(:)
    real(dp), intent(out) :: kept(:, :)
    call keep_part(solver, solver%strain_solution, unknowns, kept)
  end subroutine keep_strain_solution_part

  !> The motions of a checkpoint with the solver's key into its solutions (solver%loaded).
  !> Another key or an unreadable file: one warning line, nothing loaded, and the file is
  !> overwritten by the first save. Derived motions (source /= 0) are recomputed from their sources.
  subroutine load_checkpoint(solver, source)
    type(motion_solver_t), intent(inout) :: solver
    integer, intent(in) :: source(6)
    type(error_t) :: problem
    integer(hid_t) :: file_id
    integer :: outcome, m
    logical :: found
    real(dp), pointer :: block(:, :)
    real(dp), target :: no_columns(solver%nb, 0)
    PetscScalar, pointer :: values(:)
    PetscErrorCode :: ierr
    integer :: derived_strains(n_strain_modes)
    derived_strains = strain_sources_of(solver)
    call open_checkpoint(solver%ctx, solver%checkpoint_file, solver%key, file_id, outcome, problem)
    if (outcome == checkpoint_matches) then
      do m = 1, 6
        if (source(m) /= 0) cycle
        PetscCallA(VecGetArrayF90(solver%solution(m), values, ierr))
        block => columns(solver, values, no_columns)
        call read_checkpoint_motion(file_id, motion_names(m), block, solver%first_bead, solver%n_total, found, &
                                    solver%saved(m), problem)
        PetscCallA(VecRestoreArrayF90(solver%solution(m), values, ierr))
        solver%loaded(m) = found
        ! The next read is collective: every rank must know that this one failed somewhere.
        call agree_on_error(solver%ctx, problem)
        if (problem%failed) exit
      end do
      ! The strains (theory.md T19), each kept only if it gives the true residual it was saved with.
      do m = 1, n_strain_modes
        if (.not. solver%strains_posed .or. problem%failed) exit
        if (derived_strains(m) > 0) cycle   ! derived again from the others
        PetscCallA(VecGetArrayF90(solver%strain_solution(m), values, ierr))
        block => columns(solver, values, no_columns)
        call read_checkpoint_motion(file_id, strain_names(m), block, solver%first_bead, solver%n_total, found, &
                                    solver%strain_saved(m), problem)
        PetscCallA(VecRestoreArrayF90(solver%strain_solution(m), values, ierr))
        call agree_on_error(solver%ctx, problem)
        if (problem%failed) exit
        if (found) solver%strain_loaded(m) = same_residual(strain_true_residual(solver, m), &
                                                           solver%strain_saved(m)%true_relative_residual)
        if (solver%strain_loaded(m)) then
          solver%strain_stats%iterations(m) = solver%strain_saved(m)%iterations
          solver%strain_stats%converged_reason(m) = solver%strain_saved(m)%converged_reason
        end if
      end do
      call close_checkpoint(file_id, problem)
      call agree_on_error(solver%ctx, problem)
      if (problem%failed) solver%loaded = .false.
      if (problem%failed) solver%strain_loaded = .false.
    end if
    if (solver%ctx%rank == 0) then
      if (problem%failed) then
        write (error_unit, '(a)') "beadmob: warning: checkpoint '" // solver%checkpoint_file // "': " // &
          problem%message // '; ignored, this run overwrites it'
      else if (outcome == checkpoint_other_key) then
        write (error_unit, '(a)') "beadmob: warning: checkpoint '" // solver%checkpoint_file // "' is of another job " // &
          '(its key differs: other input, beads or solver settings); ignored, this run overwrites it'
      end if
    end if
    if (count(solver%strain_loaded) > 0) call progress_line(solver%progress, 'checkpoint: ' // &
                                                            str(count(solver%strain_loaded)) // ' strains to resume')
    if (count(solver%loaded) > 0) call progress_line(solver%progress, 'checkpoint: ' // str(count(solver%loaded)) // &
                                                     ' motions to resume')
  end subroutine load_checkpoint

  !> Collective. Save every motion solved or resumed so far (with `m`, just solved) to a new
  !> checkpoint. A checkpoint that cannot be written gives one warning; the run goes on
  !> without saving (its result does not depend on it).
  subroutine save_checkpoint(solver, m, source)
    type(motion_solver_t), intent(inout) :: solver
    integer, intent(in) :: m, source(6)
    type(error_t) :: problem
    type(checkpoint_writer_t) :: writer
    integer :: k
    real(dp), pointer :: block(:, :)
    real(dp), target :: no_columns(solver%nb, 0)
    PetscScalar, pointer :: values(:)
    PetscErrorCode :: ierr
    call begin_checkpoint(solver%ctx, solver%checkpoint_file, solver%key, solver%n_total, solver%nb, writer, problem)
    if (.not. problem%failed) then
      do k = 1, 6
        if (.not. (k == m .or. solver%loaded(k) .or. (source(k) == 0 .and. solver%solved(k)))) cycle
        PetscCallA(VecGetArrayReadF90(solver%solution(k), values, ierr))
        block => columns(solver, values, no_columns)
        call write_checkpoint_motion(writer, motion_names(k), block, solver%first_bead, solver%n_total, solver%saved(k), &
                                     problem)
        PetscCallA(VecRestoreArrayReadF90(solver%solution(k), values, ierr))
      end do
      do k = 1, n_strain_modes
        if (.not. (solver%strain_loaded(k) .or. solver%strain_solved(k))) cycle
        PetscCallA(VecGetArrayReadF90(solver%strain_solution(k), values, ierr))
        block => columns(solver, values, no_columns)
        call write_checkpoint_motion(writer, strain_names(k), block, solver%first_bead, solver%n_total, &
                                     solver%strain_saved(k), problem)
        PetscCallA(VecRestoreArrayReadF90(solver%strain_solution(k), values, ierr))
      end do
      call commit_checkpoint(solver%ctx, writer, problem)
    end if
    if (problem%failed) then
      solver%saving = .false.
      if (solver%ctx%rank == 0) write (error_unit, '(a)') "beadmob: warning: checkpoint '" // solver%checkpoint_file // &
        "' not written: " // problem%message // '; the run goes on without saving its solves'
    end if
  end subroutine save_checkpoint

  !> This rank's part of a solution vector as (nb, n_local) columns of global beads; on a rank
  !> without beads the caller's zero-size `none`, whatever PETSc returns for no entries.
  function columns(solver, flat, none) result(block)
    type(motion_solver_t), intent(in) :: solver
    PetscScalar, pointer, intent(in) :: flat(:)
    real(dp), target, intent(in) :: none(:, :)
    real(dp), pointer :: block(:, :)
    if (solver%n_local > 0) then
      block(1:solver%nb, 1:solver%n_local) => flat
    else
      block => none
    end if
  end function columns

  !> kept (size(unknowns) n_local x 6): the entries `unknowns` (indices into the unknowns per
  !> bead) of each solution, e.g. the order L - 1 part of an order-L one; 0 for motions not computed.
  subroutine keep_solution_part(solver, unknowns, kept)
    type(motion_solver_t), intent(in) :: solver
    integer, intent(in) :: unknowns(:)
    real(dp), intent(out) :: kept(:, :)
    call keep_part(solver, solver%solution, unknowns, kept)
  end subroutine keep_solution_part

  !> kept(:, m): the entries `unknowns` of every bead of this rank in vectors(m).
  subroutine keep_part(solver, vectors, unknowns, kept)
    type(motion_solver_t), intent(in) :: solver
    Vec, intent(in) :: vectors(:)
    integer, intent(in) :: unknowns(:)
    real(dp), intent(out) :: kept(:, :)
    PetscScalar, pointer :: values(:)
    PetscErrorCode :: ierr
    integer(i8) :: i
    integer :: m
    do m = 1, size(vectors)
      PetscCallA(VecGetArrayReadF90(vectors(m), values, ierr))
      do i = 1, solver%n_local
        kept(size(unknowns) * (i - 1) + 1:size(unknowns) * i, m) = values(solver%nb * (i - 1) + unknowns)
      end do
      PetscCallA(VecRestoreArrayReadF90(vectors(m), values, ierr))
    end do
  end subroutine keep_part

  !> forces (36 x n_local): column i holds, for motion m = 1..6, the force and torque (about its
  !> centre) that bead first_bead+i-1 exerts on the fluid, rows 6(m-1)+1..6m.
  subroutine bead_forces_of_solutions(solver, projection, forces)
    type(motion_solver_t), intent(in) :: solver
    real(dp), intent(in) :: projection(:, :)
    real(dp), intent(out) :: forces(:, :)
    PetscScalar, pointer :: values(:)
    PetscErrorCode :: ierr
    integer(i8) :: i
    integer :: motion, nb
    nb = solver%nb
    do motion = 1, 6
      PetscCallA(VecGetArrayReadF90(solver%solution(motion), values, ierr))
      do i = 1, solver%n_local
        forces(6 * motion - 5:6 * motion, i) = matmul(values(nb * (i - 1) + 1:nb * i), projection)
      end do
      PetscCallA(VecRestoreArrayReadF90(solver%solution(motion), values, ierr))
    end do
  end subroutine bead_forces_of_solutions

  !> Collective. Everything the solver holds (not the matrices or the bead blocks: the caller's).
  subroutine destroy_motion_solver(solver)
    type(motion_solver_t), intent(inout) :: solver
    PetscErrorCode :: ierr
    integer :: m
    do m = 1, 6
      PetscCallA(VecDestroy(solver%rhs(m), ierr))
      PetscCallA(VecDestroy(solver%solution(m), ierr))
      PetscCallA(VecDestroy(solver%residual(m), ierr))
    end do
    if (solver%with_strains) then
      do m = 1, n_strain_modes
        PetscCallA(VecDestroy(solver%strain_rhs(m), ierr))
        PetscCallA(VecDestroy(solver%strain_solution(m), ierr))
        PetscCallA(VecDestroy(solver%strain_residual(m), ierr))
      end do
      solver%with_strains = .false.
    end if
    PetscCallA(VecDestroy(solver%template, ierr))
    PetscCallA(VecDestroy(solver%preconditioned, ierr))
    PetscCallA(KSPDestroy(solver%ksp, ierr))
    if (allocated(solver%symmetry)) then
      call destroy_motion_symmetry(solver%symmetry)
      deallocate (solver%symmetry)
    end if
  end subroutine destroy_motion_solver

  !> The solver error bound of the variational friction (theory.md T5): with e_m the error of
  !> solution m and r_m its residual, zeta_mn - zeta_mn(exact) = -e_m^T A e_n = -r_m^T A^-1 r_n, so
  !> |error_mn| <= ||r_m||_{A^-1} ||r_n||_{A^-1}, and zeta_mm = ||c_m||^2_{A^-1}. In the norms of the
  !> preconditioner M, ||r||^2_{A^-1} <= r^T M r / lambda_min(M A) and ||c||^2_{A^-1} >= c^T M c /
  !> lambda_max(M A): the relative error on the scale sqrt(zeta_mm zeta_nn) is at most eta_m eta_n
  !> kappa(M A), eta the natural relative residuals. Rounding adds about kappa sqrt(n) eps (dot
  !> products of n unknowns through a solve of that condition), the floor of the bound.
  !> -1 (no bound) when no solve here gave a Lanczos estimate of kappa (a Krylov method other
  !> than CG, or every motion resumed or derived) or the preconditioner is not SPD.
  function solver_error_bound(stats, n_unknowns) result(bound)
    type(solve_statistics_t), intent(in) :: stats
    integer(i8), intent(in) :: n_unknowns
    real(dp) :: bound, largest_residual
    bound = -1.0_dp
    if (.not. stats%condition_estimate >= 1.0_dp) return
    if (.not. all(ieee_is_finite(stats%natural_relative_residual))) return
    if (any(stats%natural_relative_residual < 0.0_dp .and. stats%source >= 0)) return
    largest_residual = maxval(stats%natural_relative_residual, mask=stats%source >= 0)
    bound = stats%condition_estimate * max(largest_residual**2, sqrt(real(n_unknowns, dp)) * epsilon(1.0_dp))
  end function solver_error_bound

  !> Whether a resumed solution's true residual is the one it was saved with (rounding aside); a
  !> non-finite one never is (tested first: an ordered comparison with NaN would trap in Debug).
  pure logical function same_residual(now, saved)
    real(dp), intent(in) :: now, saved
    same_residual = ieee_is_finite(now) .and. ieee_is_finite(saved)
    if (same_residual) same_residual = abs(now - saved) <= resumed_residual_tolerance * saved + 1.0e-15_dp
  end function same_residual

  !> A real as text that reads back to the same number (for keys).
  function real_text(value) result(text)
    real(dp), intent(in) :: value
    character(len=:), allocatable :: text
    character(len=32) :: buffer
    write (buffer, '(es24.16e3)') value
    text = trim(adjustl(buffer))
  end function real_text

  pure function rigid_velocity(motion, arm) result(velocity)
    integer, intent(in) :: motion
    real(dp), intent(in) :: arm(3)
    real(dp) :: velocity(6), unit(3)
    velocity = 0.0_dp
    unit = 0.0_dp
    if (motion <= 3) then
      velocity(motion) = 1.0_dp
    else
      unit(motion - 3) = 1.0_dp
      velocity(1:3) = cross(unit, arm)
      velocity(4:6) = unit
    end if
  end function rigid_velocity
end module beadmob_rigid_body_solve
