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
!> (bench/solver_tolerance.md). Every -ksp_/-pc_ option applies.
module beadmob_rigid_body_solve
#include "petsc/finclude/petscksp.h"
  use petscksp
  use beadmob_vector_algebra, only: cross
  use beadmob_kinds, only: dp, i8
  use beadmob_bead_block_preconditioner, only: bead_block_preconditioner_t, attach_bead_block_preconditioner
  use beadmob_motion_symmetry, only: motion_symmetry_t, derive_solution
  implicit none
  private
  public :: solve_statistics_t, rigid_body_friction, motion_names

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
  end type solve_statistics_t

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
  subroutine rigid_body_friction(comm, matrix, preconditioning_matrix, projection, centres, first_bead, n_local, &
                                 reference_point, relative_tolerance, friction, stats, bead_forces, bead_blocks, &
                                 symmetry, requested)
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
    logical :: computed(6)
    KSP :: ksp
    PC :: pc
    Vec :: template
    Vec, allocatable :: rhs(:), solution(:), residual(:)
    PetscErrorCode :: ierr
    PetscScalar, pointer :: values(:)
    PetscReal :: rhs_norm, residual_norm, rtol, abstol, dtol
    PetscInt :: iterations, max_iterations
    KSPConvergedReason :: reason
    KSPType :: ksp_type
    PCType :: pc_type
    real(dp) :: arm(3), plain(6, 6), correction(6, 6)
    integer(i8) :: i, bead
    integer :: motion, other, nb

    nb = size(projection, 1)
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
    PetscCallA(MatCreateVecs(matrix, template, PETSC_NULL_VEC, ierr))
    allocate (rhs(6), solution(6), residual(6))
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
      else
        PetscCallA(VecZeroEntries(solution(motion), ierr))
        PetscCallA(KSPSolve(ksp, rhs(motion), solution(motion), ierr))
        PetscCallA(KSPGetIterationNumber(ksp, iterations, ierr))
        PetscCallA(KSPGetConvergedReason(ksp, reason, ierr))
      end if
      ! True residual r = c - A q, independent of the preconditioned norm KSP monitors.
      PetscCallA(MatMult(matrix, solution(motion), residual(motion), ierr))
      PetscCallA(VecAYPX(residual(motion), -1.0_dp, rhs(motion), ierr))
      PetscCallA(VecNorm(residual(motion), NORM_2, residual_norm, ierr))
      PetscCallA(VecNorm(rhs(motion), NORM_2, rhs_norm, ierr))
      stats%iterations(motion) = int(iterations)
      stats%converged_reason(motion) = int(reason)
      stats%true_relative_residual(motion) = residual_norm / rhs_norm
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

    PetscCallA(KSPGetType(ksp, ksp_type, ierr))
    PetscCallA(PCGetType(pc, pc_type, ierr))
    PetscCallA(KSPGetTolerances(ksp, rtol, abstol, dtol, max_iterations, ierr))
    stats%ksp_type = ksp_type
    stats%pc_type = pc_type
    if (present(bead_blocks) .and. pc_type == PCSHELL) stats%pc_type = 'single-bead blocks (shell)'
    stats%relative_tolerance = rtol
    do motion = 1, 6
      PetscCallA(VecDestroy(rhs(motion), ierr))
      PetscCallA(VecDestroy(solution(motion), ierr))
      PetscCallA(VecDestroy(residual(motion), ierr))
    end do
    PetscCallA(VecDestroy(template, ierr))
    PetscCallA(KSPDestroy(ksp, ierr))
  end subroutine rigid_body_friction

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
