!> The bead-interaction operator as a PETSc MATSHELL, distributed by beads: each rank owns a
!> contiguous block of beads (block size = unknowns per bead) and computes, for its beads i,
!>   y_i = S x_i + sum_{j /= i} P(r_i - r_j) x_j
!> with S the single-bead block and P the two-bead block of the hydrodynamic model. The whole
!> x is gathered on every rank once per product (direct O(N^2) operator; the FFT operator of a
!> later issue replaces the sum).
module beadmob_bead_operator
#include "petsc/finclude/petscmat.h"
  use petscmat
  use beadmob_kinds, only: dp, i8
  implicit none
  private
  public :: bead_operator_t, create_bead_operator, destroy_bead_operator, pair_block_interface, self_block_interface

  abstract interface
    pure subroutine pair_block_interface(r, block)
      import :: dp
      real(dp), intent(in) :: r(3)
      real(dp), intent(out) :: block(:, :)
    end subroutine pair_block_interface
    pure subroutine self_block_interface(block)
      import :: dp
      real(dp), intent(out) :: block(:, :)
    end subroutine self_block_interface
  end interface

  !> The MATSHELL context: what a product needs, set once.
  type :: bead_operator_t
    integer :: block_size = 0
    integer(i8) :: n_beads = 0, first_bead = 1, n_local = 0
    real(dp), allocatable :: centres(:, :)
    real(dp), allocatable :: self_block(:, :)
    procedure(pair_block_interface), pointer, nopass :: pair_block => null()
    VecScatter :: gather
    Vec :: gathered
  end type bead_operator_t

  interface
    subroutine MatCreateShell(comm, m_local, n_local, m, n, context, matrix, ierr)
      use petscmat
      import :: bead_operator_t
      MPI_Comm :: comm
      PetscInt :: m_local, n_local, m, n
      type(bead_operator_t) :: context
      Mat :: matrix
      PetscErrorCode :: ierr
    end subroutine MatCreateShell
    subroutine MatShellGetContext(matrix, context, ierr)
      use petscmat
      import :: bead_operator_t
      Mat :: matrix
      type(bead_operator_t), pointer :: context
      PetscErrorCode :: ierr
    end subroutine MatShellGetContext
  end interface

contains

  !> `op` must stay in place (not be moved or copied) while `matrix` lives: PETSc keeps its address.
  subroutine create_bead_operator(comm, centres, first_bead, n_local, block_size, self_block, pair_block, op, matrix)
    MPI_Comm, intent(in) :: comm
    real(dp), intent(in) :: centres(:, :)
    integer(i8), intent(in) :: first_bead, n_local
    integer, intent(in) :: block_size
    procedure(self_block_interface) :: self_block
    procedure(pair_block_interface) :: pair_block
    type(bead_operator_t), target, intent(inout) :: op
    Mat, intent(out) :: matrix
    PetscErrorCode :: ierr
    PetscInt :: local_size, global_size
    Vec :: template

    op%block_size = block_size
    op%n_beads = size(centres, 2, kind=i8)
    op%first_bead = first_bead
    op%n_local = n_local
    op%centres = centres
    allocate (op%self_block(block_size, block_size))
    call self_block(op%self_block)
    op%pair_block => pair_block
    local_size = int(n_local * block_size)
    global_size = int(op%n_beads * block_size)
    PetscCallA(MatCreateShell(comm, local_size, local_size, global_size, global_size, op, matrix, ierr))
    PetscCallA(MatShellSetOperation(matrix, MATOP_MULT, apply_bead_operator, ierr))
    PetscCallA(MatShellSetOperation(matrix, MATOP_GET_DIAGONAL, bead_operator_diagonal, ierr))
    PetscCallA(MatSetOption(matrix, MAT_SYMMETRIC, PETSC_TRUE, ierr))
    PetscCallA(MatCreateVecs(matrix, template, PETSC_NULL_VEC, ierr))
    PetscCallA(VecScatterCreateToAll(template, op%gather, op%gathered, ierr))
    PetscCallA(VecDestroy(template, ierr))
  end subroutine create_bead_operator

  subroutine destroy_bead_operator(op, matrix)
    type(bead_operator_t), intent(inout) :: op
    Mat, intent(inout) :: matrix
    PetscErrorCode :: ierr
    PetscCallA(VecScatterDestroy(op%gather, ierr))
    PetscCallA(VecDestroy(op%gathered, ierr))
    PetscCallA(MatDestroy(matrix, ierr))
  end subroutine destroy_bead_operator

  !> MATOP_MULT: y = A x.
  subroutine apply_bead_operator(matrix, x, y, ierr)
    Mat :: matrix
    Vec :: x, y
    PetscErrorCode :: ierr
    type(bead_operator_t), pointer :: op
    PetscScalar, pointer :: all_x(:), local_y(:)
    real(dp), allocatable :: block(:, :)
    integer(i8) :: i, j
    integer :: nb
    integer(i8) :: row, column

    PetscCall(MatShellGetContext(matrix, op, ierr))
    nb = op%block_size
    PetscCall(VecScatterBegin(op%gather, x, op%gathered, INSERT_VALUES, SCATTER_FORWARD, ierr))
    PetscCall(VecScatterEnd(op%gather, x, op%gathered, INSERT_VALUES, SCATTER_FORWARD, ierr))
    PetscCall(VecGetArrayReadF90(op%gathered, all_x, ierr))
    PetscCall(VecGetArrayF90(y, local_y, ierr))
    allocate (block(nb, nb))
    do i = 1, op%n_local
      row = (i - 1) * nb
      column = (op%first_bead + i - 2) * nb
      local_y(row + 1:row + nb) = matmul(op%self_block, all_x(column + 1:column + nb))
      do j = 1, op%n_beads
        if (j == op%first_bead + i - 1) cycle
        call op%pair_block(op%centres(:, op%first_bead + i - 1) - op%centres(:, j), block)
        column = (j - 1) * nb
        local_y(row + 1:row + nb) = local_y(row + 1:row + nb) + matmul(block, all_x(column + 1:column + nb))
      end do
    end do
    PetscCall(VecRestoreArrayF90(y, local_y, ierr))
    PetscCall(VecRestoreArrayReadF90(op%gathered, all_x, ierr))
    ierr = 0
  end subroutine apply_bead_operator

  !> MATOP_GET_DIAGONAL: the diagonal of the single-bead blocks (for PCJACOBI).
  subroutine bead_operator_diagonal(matrix, diagonal, ierr)
    Mat :: matrix
    Vec :: diagonal
    PetscErrorCode :: ierr
    type(bead_operator_t), pointer :: op
    PetscScalar, pointer :: values(:)
    integer(i8) :: i
    integer :: k
    PetscCall(MatShellGetContext(matrix, op, ierr))
    PetscCall(VecGetArrayF90(diagonal, values, ierr))
    do i = 1, op%n_local
      do k = 1, op%block_size
        values((i - 1) * op%block_size + k) = op%self_block(k, k)
      end do
    end do
    PetscCall(VecRestoreArrayF90(diagonal, values, ierr))
    ierr = 0
  end subroutine bead_operator_diagonal
end module beadmob_bead_operator
