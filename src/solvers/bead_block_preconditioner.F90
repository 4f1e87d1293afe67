!> The single-bead preconditioner (block Jacobi with one block per bead) as a PETSc PCSHELL.
!> The beads are identical, so every diagonal block of the operator is the same self block S
!> (theory.md T6): applying S^-1 to all of this rank's beads is one matrix product
!> (nb x nb) x (nb x n_local). No block-diagonal matrix is assembled or factorised, which the
!> MUMPS route needs (method.md, "Preconditioning"); bench/preconditioners/preconditioners.md compares both.
module beadmob_bead_block_preconditioner
#include "petsc/finclude/petscksp.h"
  use petscksp
  use beadmob_kinds, only: dp
  use beadmob_lapack, only: dgemm, dpotrf, dpotri
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  implicit none
  private
  public :: bead_block_preconditioner_t, make_bead_block_preconditioner, attach_bead_block_preconditioner

  !> The PCSHELL context: S^-1 (symmetric, full storage).
  type :: bead_block_preconditioner_t
    integer :: block_size = 0
    real(dp), allocatable :: inverse(:, :)
  end type bead_block_preconditioner_t

  ! PCShellSetContext/GetContext with this module's context type (PETSc's Fortran stubs take
  ! any object by reference).
  interface
    subroutine PCShellSetContext(pc, context, ierr)
      use petscksp
      import :: bead_block_preconditioner_t
      PC :: pc
      type(bead_block_preconditioner_t) :: context
      PetscErrorCode :: ierr
    end subroutine PCShellSetContext
    subroutine PCShellGetContext(pc, context, ierr)
      use petscksp
      import :: bead_block_preconditioner_t
      PC :: pc
      type(bead_block_preconditioner_t), pointer :: context
      PetscErrorCode :: ierr
    end subroutine PCShellGetContext
  end interface

contains

  !> The context for self block `self_block` (SPD; the same on every rank, so a failure is too).
  subroutine make_bead_block_preconditioner(self_block, context, err)
    real(dp), intent(in) :: self_block(:, :)
    type(bead_block_preconditioner_t), intent(out) :: context
    type(error_t), intent(inout) :: err
    integer :: nb, info, column

    nb = size(self_block, 1)
    context%block_size = nb
    context%inverse = self_block
    call dpotrf('U', nb, context%inverse, nb, info)
    if (info == 0) call dpotri('U', nb, context%inverse, nb, info)
    if (info /= 0) then
      call raise(err, 'the single-bead block is not positive definite (LAPACK info ' // str(info) // ')')
      return
    end if
    do column = 1, nb - 1   ! dpotri fills the upper triangle
      context%inverse(column + 1:nb, column) = context%inverse(column, column + 1:nb)
    end do
  end subroutine make_bead_block_preconditioner

  !> Makes `pc` the single-bead preconditioner. `context` must stay in place while `pc` lives
  !> (PETSc keeps its address).
  subroutine attach_bead_block_preconditioner(pc, context)
    PC, intent(in) :: pc
    type(bead_block_preconditioner_t), target, intent(in) :: context
    PetscErrorCode :: ierr
    PetscCallA(PCSetType(pc, PCSHELL, ierr))
    PetscCallA(PCShellSetContext(pc, context, ierr))
    PetscCallA(PCShellSetApply(pc, apply_bead_blocks, ierr))
    PetscCallA(PCShellSetName(pc, 'single-bead blocks', ierr))
  end subroutine attach_bead_block_preconditioner

  !> PCApply: y_i = S^-1 x_i for every local bead i.
  subroutine apply_bead_blocks(pc, x, y, ierr)
    PC :: pc
    Vec :: x, y
    PetscErrorCode :: ierr
    type(bead_block_preconditioner_t), pointer :: context
    PetscScalar, pointer :: local_x(:), local_y(:)
    integer :: nb, n_local

    PetscCall(PCShellGetContext(pc, context, ierr))
    nb = context%block_size
    PetscCall(VecGetArrayReadF90(x, local_x, ierr))
    PetscCall(VecGetArrayF90(y, local_y, ierr))
    n_local = size(local_x) / nb
    if (n_local > 0) call dgemm('N', 'N', nb, n_local, nb, 1.0_dp, context%inverse, nb, local_x, nb, 0.0_dp, local_y, nb)
    PetscCall(VecRestoreArrayF90(y, local_y, ierr))
    PetscCall(VecRestoreArrayReadF90(x, local_x, ierr))
    ierr = 0
  end subroutine apply_bead_blocks
end module beadmob_bead_block_preconditioner
