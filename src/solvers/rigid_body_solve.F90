!> Friction of a rigid bead model: six Krylov solves A f = c, one per unit rigid motion
!> (translations along x, y, z, rotations about x, y, z through the reference point), with
!> c the bead velocities of that motion; total force and torque of the solved bead forces
!> give the columns of the 6x6 friction matrix (Cichocki et al., J. Chem. Phys. 100, 3780
!> (1994), section II; here at the level of forces and torques per bead).
module beadmob_rigid_body_solve
#include "petsc/finclude/petscksp.h"
  use petscksp
  use beadmob_vector_algebra, only: cross
  use beadmob_kinds, only: dp, i8
  implicit none
  private
  public :: solve_statistics_t, rigid_body_friction, motion_names

  character(len=*), parameter :: motion_names(6) = [character(len=3) :: 'U_x', 'U_y', 'U_z', 'W_x', 'W_y', 'W_z']

  !> What each solve reports (recorded in the result file).
  type :: solve_statistics_t
    integer :: iterations(6) = 0
    integer :: converged_reason(6) = 0
    real(dp) :: true_relative_residual(6) = 0.0_dp
    character(len=80) :: ksp_type = '', pc_type = ''
    real(dp) :: relative_tolerance = 0.0_dp
  end type solve_statistics_t

contains

  !> Collective. `centres` holds all beads; this rank owns beads first..first+n_local-1,
  !> with 6 unknowns each (force, torque).
  subroutine rigid_body_friction(comm, matrix, centres, first_bead, n_local, reference_point, friction, stats)
    MPI_Comm, intent(in) :: comm
    Mat, intent(in) :: matrix
    real(dp), intent(in) :: centres(:, :), reference_point(3)
    integer(i8), intent(in) :: first_bead, n_local
    real(dp), intent(out) :: friction(6, 6)
    type(solve_statistics_t), intent(out) :: stats
    KSP :: ksp
    PC :: pc
    Vec :: rhs, solution, residual
    PetscErrorCode :: ierr
    PetscScalar, pointer :: values(:)
    PetscReal :: rhs_norm, residual_norm, rtol, abstol, dtol
    PetscInt :: iterations, max_iterations
    KSPConvergedReason :: reason
    KSPType :: ksp_type
    PCType :: pc_type
    real(dp) :: local_sums(6), arm(3), force(3), torque(3)
    integer(i8) :: i, bead
    integer :: motion

    PetscCallA(KSPCreate(comm, ksp, ierr))
    PetscCallA(KSPSetOperators(ksp, matrix, matrix, ierr))
    ! Defaults: CG (the RPY mobility operator is symmetric positive definite) with the
    ! single-bead blocks (diagonal here) as preconditioner; all changeable by -ksp_*/-pc_*.
    PetscCallA(KSPSetType(ksp, KSPCG, ierr))
    PetscCallA(KSPGetPC(ksp, pc, ierr))
    PetscCallA(PCSetType(pc, PCJACOBI, ierr))
    PetscCallA(KSPSetTolerances(ksp, 1.0e-10_dp, PETSC_DEFAULT_REAL, PETSC_DEFAULT_REAL, PETSC_DEFAULT_INTEGER, ierr))
    PetscCallA(KSPSetFromOptions(ksp, ierr))
    PetscCallA(MatCreateVecs(matrix, solution, rhs, ierr))
    PetscCallA(VecDuplicate(rhs, residual, ierr))

    friction = 0.0_dp
    do motion = 1, 6
      ! Bead velocities of the unit rigid motion: U_i = V + w x (r_i - r_0), Omega_i = w.
      PetscCallA(VecGetArrayF90(rhs, values, ierr))
      do i = 1, n_local
        bead = first_bead + i - 1
        arm = centres(:, bead) - reference_point
        values(6 * (i - 1) + 1:6 * i) = rigid_velocity(motion, arm)
      end do
      PetscCallA(VecRestoreArrayF90(rhs, values, ierr))
      PetscCallA(VecZeroEntries(solution, ierr))
      PetscCallA(KSPSolve(ksp, rhs, solution, ierr))
      PetscCallA(KSPGetIterationNumber(ksp, iterations, ierr))
      PetscCallA(KSPGetConvergedReason(ksp, reason, ierr))
      ! True residual ||c - A f|| / ||c||, independent of the preconditioned norm KSP monitors.
      PetscCallA(MatMult(matrix, solution, residual, ierr))
      PetscCallA(VecAYPX(residual, -1.0_dp, rhs, ierr))
      PetscCallA(VecNorm(residual, NORM_2, residual_norm, ierr))
      PetscCallA(VecNorm(rhs, NORM_2, rhs_norm, ierr))
      stats%iterations(motion) = int(iterations)
      stats%converged_reason(motion) = int(reason)
      stats%true_relative_residual(motion) = residual_norm / rhs_norm

      ! Column `motion`: total force and torque about the reference point.
      local_sums = 0.0_dp
      PetscCallA(VecGetArrayReadF90(solution, values, ierr))
      do i = 1, n_local
        bead = first_bead + i - 1
        arm = centres(:, bead) - reference_point
        force = values(6 * (i - 1) + 1:6 * (i - 1) + 3)
        torque = values(6 * (i - 1) + 4:6 * i)
        local_sums(1:3) = local_sums(1:3) + force
        local_sums(4:6) = local_sums(4:6) + torque + cross(arm, force)
      end do
      PetscCallA(VecRestoreArrayReadF90(solution, values, ierr))
      call MPI_Allreduce(local_sums, friction(:, motion), 6, MPI_DOUBLE_PRECISION, MPI_SUM, comm, ierr)
    end do

    PetscCallA(KSPGetType(ksp, ksp_type, ierr))
    PetscCallA(PCGetType(pc, pc_type, ierr))
    PetscCallA(KSPGetTolerances(ksp, rtol, abstol, dtol, max_iterations, ierr))
    stats%ksp_type = ksp_type
    stats%pc_type = pc_type
    stats%relative_tolerance = rtol
    PetscCallA(VecDestroy(rhs, ierr))
    PetscCallA(VecDestroy(solution, ierr))
    PetscCallA(VecDestroy(residual, ierr))
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
