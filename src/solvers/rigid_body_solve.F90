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
  use beadmob_motion_symmetry, only: motion_symmetry_t, derive_solution
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t, make_run_context, agree_on_error
  use beadmob_progress, only: progress_line, progress_seconds
  use beadmob_checkpoint_file, only: saved_solve_t, checkpoint_writer_t, begin_checkpoint, write_checkpoint_motion, &
                                     commit_checkpoint, open_checkpoint, read_checkpoint_motion, close_checkpoint, &
                                     fnv1a_hex, checkpoint_matches, checkpoint_other_key
  implicit none
  private
  public :: solve_statistics_t, solve_control_t, rigid_body_friction, motion_names

  character(len=*), parameter :: motion_names(6) = [character(len=3) :: 'U_x', 'U_y', 'U_z', 'W_x', 'W_y', 'W_z']

  !> What each solve reports (recorded in the result file).
  type :: solve_statistics_t
    integer :: iterations(6) = 0
    integer :: converged_reason(6) = 0
    !> 0: solved; m > 0: derived from motion m by a symmetry (motion_symmetry.F90); -1: not
    !> computed (not requested; its true residual is then recorded as -1)
    integer :: source(6) = 0
    real(dp) :: true_relative_residual(6) = 0.0_dp
    character(len=80) :: ksp_type = '', pc_type = ''
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
    !> What the solver error of the friction is at most (theory.md T5, "Solver error bound"):
    !> |zeta_mn - zeta_mn(exact solve)| <= bound sqrt(zeta_mm zeta_nn) between computed motions
    !> (-1: no bound, see solver_error_bound)
    real(dp) :: solver_error_bound = -1.0_dp
  end type solve_statistics_t

  !> How the solves report and save (friction_job.F90 fills it from its settings).
  type :: solve_control_t
    !> Rank 0 prints a progress line per solve (the caller passes .false. on other ranks)
    logical :: progress = .false.
    !> Checkpoint file of the solved motions (checkpoint_file.f90); '' = none
    character(len=:), allocatable :: checkpoint_file
    !> Everything the solutions depend on but the Krylov settings, which are added here (the ones
    !> actually used, after -ksp_ / -pc_ options)
    character(len=:), allocatable :: checkpoint_key
    !> A test of the resume: stop with an error right after this many solves have been saved,
    !> as a kill at a wall-time limit would (0 = never)
    integer :: stop_after_solves = 0
    !> First word(s) of the progress lines, e.g. 'companion solve' (friction_job.F90)
    character(len=40) :: label = 'solve'
  end type solve_control_t

  !> A loaded solution must give the true residual it was saved with (to rounding, which varies
  !> with the number of ranks): otherwise it does not solve this run's system and is solved again.
  real(dp), parameter :: resumed_residual_tolerance = 1.0e-3_dp

contains

  !> Collective. `centres` holds all beads; this rank owns beads first..first+n_local-1, with
  !> nb = size(projection, 1) unknowns each. projection(:, m): the basis projection of unit motion
  !> m of one bead about its centre (its transpose gives force and torque from the multipoles).
  !> bead_forces, when present (36 x n_local): column i holds, for motion m = 1..6, the force and
  !> torque (about its centre) that bead first+i-1 exerts on the fluid, rows 6(m-1)+1..6m.
  !> bead_blocks, when present, is the preconditioner (preconditioning_matrix then unused).
  !> symmetry, when present, names the motions that follow from others: they are not solved.
  !> requested, when present, names the motions to compute (with the sources of requested
  !> derived ones); friction(m, n) = c_m . q_n for m not computed, n computed (first order in
  !> the solver error, the variational form needs q_m), and 0 where neither is computed.
  !> control, when present, asks for progress lines, the checkpoint and the test stop; err is then
  !> needed too (the test stop and nothing else raises it, the same on every rank).
  !> kept_unknowns and kept (size(kept_unknowns) n_local x 6), when present: the solutions'
  !> entries of those unknowns per bead are copied to kept (e.g. the order L - 1 part of an order-L
  !> solution); initial_guess (nb n_local x 6), when present, starts each solve from its column
  !> instead of zero (the companion solve from the order-L solution, friction_job.F90).
  subroutine rigid_body_friction(comm, matrix, preconditioning_matrix, projection, centres, first_bead, n_local, &
                                 reference_point, relative_tolerance, friction, stats, bead_forces, bead_blocks, &
                                 symmetry, requested, control, err, kept_unknowns, kept, initial_guess)
    MPI_Comm, intent(in) :: comm
    Mat, intent(in) :: matrix, preconditioning_matrix
    real(dp), intent(in) :: projection(:, :), centres(:, :), reference_point(3)
    integer(i8), intent(in) :: first_bead, n_local
    !> Krylov relative tolerance (-ksp_rtol on the command line overrides it; the one used is
    !> recorded in stats)
    real(dp), intent(in) :: relative_tolerance
    real(dp), intent(out) :: friction(6, 6)
    type(solve_statistics_t), intent(out) :: stats
    real(dp), intent(out), optional :: bead_forces(:, :)
    type(bead_block_preconditioner_t), intent(in), optional, target :: bead_blocks
    type(motion_symmetry_t), intent(in), optional :: symmetry
    logical, intent(in), optional :: requested(6)
    type(solve_control_t), intent(in), optional :: control
    type(error_t), intent(inout), optional :: err
    integer, intent(in), optional :: kept_unknowns(:)
    real(dp), intent(out), optional :: kept(:, :)
    real(dp), intent(in), optional :: initial_guess(:, :)
    logical :: computed(6), loaded(6), saving, report
    type(saved_solve_t) :: saved(6)
    type(run_context_t) :: ctx
    character(len=:), allocatable :: checkpoint_file, key, label
    real(dp) :: solve_seconds, started
    integer :: solves_done, solves_planned
    real(dp), target :: no_columns(size(projection, 1), 0)
    KSP :: ksp
    PC :: pc
    Vec :: template, preconditioned
    Vec, allocatable :: rhs(:), solution(:), residual(:)
    PetscErrorCode :: ierr
    PetscScalar, pointer :: values(:)
    PetscReal :: rhs_norm, residual_norm, rtol, abstol, dtol, largest_value, smallest_value
    PetscInt :: iterations, max_iterations
    KSPConvergedReason :: reason
    KSPType :: ksp_type
    PCType :: pc_type
    real(dp) :: arm(3), plain(6, 6), correction(6, 6), residual_square, rhs_square
    integer(i8) :: i, bead, n_total
    integer :: motion, other, nb

    nb = size(projection, 1)
    n_total = size(centres, 2, kind=i8)
    ctx = make_run_context(comm)
    if (present(kept)) kept = 0.0_dp   ! motions not computed
    report = .false.
    checkpoint_file = ''
    label = 'solve'
    if (present(control)) then
      report = control%progress
      label = trim(control%label)
      if (allocated(control%checkpoint_file)) checkpoint_file = control%checkpoint_file
    end if
    PetscCallA(KSPCreate(comm, ksp, ierr))
    PetscCallA(KSPSetType(ksp, KSPCG, ierr))
    PetscCallA(KSPGetPC(ksp, pc, ierr))
    if (present(bead_blocks)) then
      PetscCallA(KSPSetOperators(ksp, matrix, matrix, ierr))
      call attach_bead_block_preconditioner(pc, bead_blocks)
    else
      PetscCallA(KSPSetOperators(ksp, matrix, preconditioning_matrix, ierr))
      PetscCallA(PCSetType(pc, PCCHOLESKY, ierr))
      PetscCallA(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS, ierr))
    end if
    PetscCallA(KSPSetTolerances(ksp, relative_tolerance, PETSC_DEFAULT_REAL, PETSC_DEFAULT_REAL, PETSC_DEFAULT_INTEGER, ierr))
    PetscCallA(KSPSetFromOptions(ksp, ierr))
    ! The Lanczos coefficients that CG has anyway give the spectrum's ends (the error bound).
    PetscCallA(KSPSetComputeSingularValues(ksp, PETSC_TRUE, ierr))
    ! The preconditioner set up now: the bound applies it to resumed and derived motions too.
    PetscCallA(KSPSetUp(ksp, ierr))
    if (present(initial_guess)) then
      PetscCallA(KSPSetInitialGuessNonzero(ksp, PETSC_TRUE, ierr))
    end if
    PetscCallA(MatCreateVecs(matrix, template, PETSC_NULL_VEC, ierr))
    allocate (rhs(6), solution(6), residual(6))
    PetscCallA(VecDuplicate(template, preconditioned, ierr))
    do motion = 1, 6
      PetscCallA(VecDuplicate(template, rhs(motion), ierr))
      PetscCallA(VecDuplicate(template, solution(motion), ierr))
      PetscCallA(VecDuplicate(template, residual(motion), ierr))
    end do

    if (present(symmetry)) stats%source = symmetry%source
    computed = .true.
    if (present(requested)) then
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
    end if

    ! The checkpoint's key: the caller's part and the Krylov settings actually used.
    saving = len(checkpoint_file) > 0
    loaded = .false.
    if (saving) then
      PetscCallA(KSPGetType(ksp, ksp_type, ierr))
      PetscCallA(PCGetType(pc, pc_type, ierr))
      PetscCallA(KSPGetTolerances(ksp, rtol, abstol, dtol, max_iterations, ierr))
      key = control%checkpoint_key // 'krylov: ' // trim(ksp_type) // ', preconditioner ' // trim(pc_type) // &
            ', rtol ' // real_text(rtol) // ', abstol ' // real_text(abstol) // ', dtol ' // real_text(dtol) // &
            ', max_it ' // str(int(max_iterations)) // new_line('a')
      call load_checkpoint()
    end if
    solves_planned = count(stats%source == 0 .and. .not. loaded)
    solves_done = 0
    solve_seconds = 0.0_dp
    do motion = 1, 6
      ! c_i = projection (U_i, Omega_i), U_i = V + w x (R_i - R_0), Omega_i = w.
      PetscCallA(VecGetArrayF90(rhs(motion), values, ierr))
      do i = 1, n_local
        bead = first_bead + i - 1
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
        cycle
      else if (stats%source(motion) > 0) then
        ! Derived, not solved; its true residual below checks it like a solved one.
        call derive_solution(symmetry, motion, solution(stats%source(motion)), solution(motion))
        iterations = 0
        reason = stats%converged_reason(stats%source(motion))
        call true_residual(motion)
      else if (loaded(motion)) then
        ! Resumed: the record of the solve that made it, and its true residual checked again.
        iterations = saved(motion)%iterations
        reason = saved(motion)%converged_reason
        call true_residual(motion)
        if (.not. same_residual(stats%true_relative_residual(motion), saved(motion)%true_relative_residual)) then
          if (ctx%rank == 0) write (error_unit, '(a, es9.2, a, es9.2, a)') 'beadmob: warning: checkpoint ''' // &
            checkpoint_file // ''': motion ' // motion_names(motion) // ' gives the true relative residual', &
            stats%true_relative_residual(motion), ' instead of the saved', saved(motion)%true_relative_residual, &
            '; solved again'
          loaded(motion) = .false.
          solves_planned = solves_planned + 1
        else
          call progress_line(report, label // ' ' // motion_names(motion) // ': resumed from the checkpoint')
        end if
      end if
      if (stats%source(motion) == 0 .and. .not. loaded(motion)) then
        started = MPI_Wtime()
        if (present(initial_guess)) then
          PetscCallA(VecGetArrayF90(solution(motion), values, ierr))
          values = initial_guess(:, motion)
          PetscCallA(VecRestoreArrayF90(solution(motion), values, ierr))
        else
          PetscCallA(VecZeroEntries(solution(motion), ierr))
        end if
        PetscCallA(KSPSolve(ksp, rhs(motion), solution(motion), ierr))
        PetscCallA(KSPGetIterationNumber(ksp, iterations, ierr))
        PetscCallA(KSPGetConvergedReason(ksp, reason, ierr))
        PetscCallA(KSPComputeExtremeSingularValues(ksp, largest_value, smallest_value, ierr))
        if (smallest_value > 0.0_dp) stats%condition_estimate = max(stats%condition_estimate, &
                                                                    largest_value / smallest_value)
        call true_residual(motion)
        saved(motion) = saved_solve_t(int(iterations), int(reason), stats%true_relative_residual(motion))
        ! Saved at once: a kill from here on loses nothing of this solve.
        if (saving) call save_checkpoint(motion)
        solves_done = solves_done + 1
        solve_seconds = solve_seconds + (MPI_Wtime() - started)
        call progress_line(report, label // ' ' // motion_names(motion) // ': ' // str(int(iterations)) // &
                           ' iterations, ' // progress_seconds(MPI_Wtime() - started) // ' s; ' // &
                           str(solves_planned - solves_done) // ' solves left, ~' // &
                           progress_seconds(solve_seconds / solves_done * (solves_planned - solves_done)) // ' s')
        if (present(control) .and. present(err)) then
          if (solves_done == control%stop_after_solves) then
            ! Every rank counts the same solves: they all stop here together.
            call raise(err, 'stopped after ' // str(solves_done) // ' solves as -stop_after_solves asks (a test ' // &
                       'of the resume)' // saved_where())
            call release()
            return
          end if
        end if
      end if
      stats%iterations(motion) = int(iterations)
      stats%converged_reason(motion) = int(reason)
      if (present(kept_unknowns) .and. present(kept)) then
        PetscCallA(VecGetArrayReadF90(solution(motion), values, ierr))
        do i = 1, n_local
          kept(size(kept_unknowns) * (i - 1) + 1:size(kept_unknowns) * i, motion) = values(nb * (i - 1) + kept_unknowns)
        end do
        PetscCallA(VecRestoreArrayReadF90(solution(motion), values, ierr))
      end if
      if (present(bead_forces)) then
        PetscCallA(VecGetArrayReadF90(solution(motion), values, ierr))
        do i = 1, n_local
          bead_forces(6 * motion - 5:6 * motion, i) = matmul(values(nb * (i - 1) + 1:nb * i), projection)
        end do
        PetscCallA(VecRestoreArrayReadF90(solution(motion), values, ierr))
      end if
    end do

    ! zeta_mn = c_m . q_n + q_m . r_n (the force and torque of solution n projected on motion m).
    do motion = 1, 6
      do other = 1, 6
        PetscCallA(VecDot(rhs(motion), solution(other), plain(motion, other), ierr))
        PetscCallA(VecDot(solution(motion), residual(other), correction(motion, other), ierr))
      end do
    end do
    friction = plain + correction
    stats%plain_symmetry_error = norm2(plain - transpose(plain)) / norm2(plain)
    stats%variational_correction = maxval(abs(correction)) / maxval(abs(friction))
    stats%solver_error_bound = solver_error_bound(stats, n_total * nb)

    PetscCallA(KSPGetType(ksp, ksp_type, ierr))
    PetscCallA(PCGetType(pc, pc_type, ierr))
    PetscCallA(KSPGetTolerances(ksp, rtol, abstol, dtol, max_iterations, ierr))
    stats%ksp_type = ksp_type
    stats%pc_type = pc_type
    if (present(bead_blocks) .and. pc_type == PCSHELL) stats%pc_type = 'single-bead blocks (shell)'
    stats%relative_tolerance = rtol
    stats%resumed = merge(1, 0, loaded)
    call release()

  contains

    !> stats%true_relative_residual(m) = |c - A q| / |c|, with r = c - A q kept for the friction:
    !> the true residual, independent of the preconditioned norm KSP monitors.
    subroutine true_residual(m)
      integer, intent(in) :: m
      PetscCallA(MatMult(matrix, solution(m), residual(m), ierr))
      PetscCallA(VecAYPX(residual(m), -1.0_dp, rhs(m), ierr))
      PetscCallA(VecNorm(residual(m), NORM_2, residual_norm, ierr))
      PetscCallA(VecNorm(rhs(m), NORM_2, rhs_norm, ierr))
      stats%true_relative_residual(m) = residual_norm / rhs_norm
      residual_square = preconditioned_square(residual(m))
      rhs_square = preconditioned_square(rhs(m))
      stats%natural_relative_residual(m) = -1.0_dp   ! a preconditioner that is not SPD: none
      if (residual_square >= 0.0_dp .and. rhs_square > 0.0_dp) &
        stats%natural_relative_residual(m) = sqrt(residual_square / rhs_square)
    end subroutine true_residual

    !> v^T M v, M the preconditioner (positive for CG's SPD preconditioners).
    real(dp) function preconditioned_square(v)
      Vec, intent(in) :: v
      PetscCallA(PCApply(pc, v, preconditioned, ierr))
      PetscCallA(VecDot(v, preconditioned, preconditioned_square, ierr))
    end function preconditioned_square

    !> The motions of a checkpoint with this run's key into `solution` (loaded). Another key or
    !> an unreadable file: one warning line, nothing loaded, and the file is overwritten by the
    !> first save.
    subroutine load_checkpoint()
      type(error_t) :: problem
      integer(hid_t) :: file_id
      integer :: outcome, m
      logical :: found
      real(dp), pointer :: block(:, :)
      call open_checkpoint(ctx, checkpoint_file, key, file_id, outcome, problem)
      if (outcome == checkpoint_matches) then
        do m = 1, 6
          if (stats%source(m) /= 0) cycle   ! derived motions are recomputed from their sources
          PetscCallA(VecGetArrayF90(solution(m), values, ierr))
          block => columns(values)
          call read_checkpoint_motion(file_id, motion_names(m), block, first_bead, n_total, found, saved(m), problem)
          PetscCallA(VecRestoreArrayF90(solution(m), values, ierr))
          loaded(m) = found
          ! The next read is collective: every rank must know that this one failed somewhere.
          call agree_on_error(ctx, problem)
          if (problem%failed) exit
        end do
        call close_checkpoint(file_id, problem)
        call agree_on_error(ctx, problem)
        if (problem%failed) loaded = .false.
      end if
      if (ctx%rank == 0) then
        if (problem%failed) then
          write (error_unit, '(a)') "beadmob: warning: checkpoint '" // checkpoint_file // "': " // problem%message // &
            '; ignored, this run overwrites it'
        else if (outcome == checkpoint_other_key) then
          write (error_unit, '(a)') "beadmob: warning: checkpoint '" // checkpoint_file // "' is of another job " // &
            '(its key differs: other input, beads or solver settings); ignored, this run overwrites it'
        end if
      end if
      if (count(loaded) > 0) call progress_line(report, 'checkpoint: ' // str(count(loaded)) // ' motions to resume')
    end subroutine load_checkpoint

    !> Collective. Save every motion solved or resumed so far (with `m`, just solved) to a new
    !> checkpoint. A checkpoint that cannot be written gives one warning; the run goes on
    !> without saving (its result does not depend on it).
    subroutine save_checkpoint(m)
      integer, intent(in) :: m
      type(error_t) :: problem
      type(checkpoint_writer_t) :: writer
      integer :: k
      real(dp), pointer :: block(:, :)
      call begin_checkpoint(ctx, checkpoint_file, key, n_total, nb, writer, problem)
      if (.not. problem%failed) then
        do k = 1, 6
          if (.not. (k == m .or. loaded(k) .or. (stats%source(k) == 0 .and. k < m))) cycle
          PetscCallA(VecGetArrayReadF90(solution(k), values, ierr))
          block => columns(values)
          call write_checkpoint_motion(writer, motion_names(k), block, first_bead, n_total, saved(k), problem)
          PetscCallA(VecRestoreArrayReadF90(solution(k), values, ierr))
        end do
        call commit_checkpoint(ctx, writer, problem)
      end if
      if (problem%failed) then
        saving = .false.
        if (ctx%rank == 0) write (error_unit, '(a)') "beadmob: warning: checkpoint '" // checkpoint_file // &
          "' not written: " // problem%message // '; the run goes on without saving its solves'
      end if
    end subroutine save_checkpoint

    !> This rank's part of a solution vector as (nb, n_local) columns of global beads.
    function columns(flat) result(block)
      PetscScalar, pointer, intent(in) :: flat(:)
      real(dp), pointer :: block(:, :)
      if (n_local > 0) then
        block(1:nb, 1:n_local) => flat
      else   ! a rank without beads: a zero-size array, whatever PETSc returns for none
        block => no_columns
      end if
    end function columns

    function saved_where() result(text)
      character(len=:), allocatable :: text
      text = ''
      if (saving) text = ", saved in '" // checkpoint_file // "'"
    end function saved_where

    subroutine release()
      integer :: m
      do m = 1, 6
        PetscCallA(VecDestroy(rhs(m), ierr))
        PetscCallA(VecDestroy(solution(m), ierr))
        PetscCallA(VecDestroy(residual(m), ierr))
      end do
      PetscCallA(VecDestroy(template, ierr))
      PetscCallA(VecDestroy(preconditioned, ierr))
      PetscCallA(KSPDestroy(ksp, ierr))
    end subroutine release
  end subroutine rigid_body_friction

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
