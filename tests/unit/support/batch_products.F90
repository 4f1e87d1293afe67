!> The check that a bead operator's batch of products (multipole_operator_t%apply_many) equals its
!> single products, shared by the operator tests.
module beadmob_batch_products
#include "petsc/finclude/petscvec.h"
  use petscvec
  use beadmob_kinds, only: dp
  use beadmob_multipole_operator, only: multipole_operator_t
  implicit none
  private
  public :: batch_difference

contains

  !> Collective. Seven products at once (more than one batch of six), x and u alternating, against
  !> the single products ax = A x and au = A u: the largest max-norm difference over `scale`.
  real(dp) function batch_difference(op, x, u, ax, au, scale) result(worst)
    class(multipole_operator_t), target, intent(inout) :: op
    Vec, intent(in) :: x, u, ax, au
    real(dp), intent(in) :: scale
    Vec :: many_x(7), many_y(7)
    real(dp) :: difference
    PetscErrorCode :: ierr
    integer :: j
    do j = 1, 7
      many_x(j) = merge(x, u, mod(j, 2) == 1)
      PetscCallA(VecDuplicate(x, many_y(j), ierr))
    end do
    call op%apply_many(many_x, many_y)
    worst = 0.0_dp
    do j = 1, 7
      PetscCallA(VecAXPY(many_y(j), -1.0_dp, merge(ax, au, mod(j, 2) == 1), ierr))
      PetscCallA(VecNorm(many_y(j), NORM_INFINITY, difference, ierr))
      worst = max(worst, difference / scale)
      PetscCallA(VecDestroy(many_y(j), ierr))
    end do
  end function batch_difference
end module beadmob_batch_products
