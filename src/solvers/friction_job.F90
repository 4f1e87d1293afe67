!> The friction of a bead model on all ranks: the distributed bead operator of the chosen
!> hydrodynamic level and the six rigid-motion solves about the reference point.
module beadmob_friction_job
#include "petsc/finclude/petscmat.h"
  use petscmat
  use beadmob_kinds, only: dp, i8
  use beadmob_parallel, only: run_context_t, block_range
  use beadmob_rpy_blocks, only: rpy_self_block, rpy_pair_block, rpy_block_size
  use beadmob_bead_operator, only: bead_operator_t, create_bead_operator, destroy_bead_operator
  use beadmob_rigid_body_solve, only: rigid_body_friction, solve_statistics_t
  implicit none
  private
  public :: friction_of_model

contains

  !> Collective. Multipole order 1 without lubrication (the RPY level) is what exists so far;
  !> the input layer rejects other settings before this is reached.
  subroutine friction_of_model(ctx, centres, reference_point, friction, stats)
    type(run_context_t), intent(in) :: ctx
    real(dp), intent(in) :: centres(:, :), reference_point(3)
    real(dp), intent(out) :: friction(6, 6)
    type(solve_statistics_t), intent(out) :: stats
    type(bead_operator_t), target :: op
    Mat :: matrix
    integer(i8) :: first, count
    call block_range(ctx, size(centres, 2, kind=i8), first, count)
    call create_bead_operator(ctx%comm, centres, first, count, rpy_block_size, rpy_self_block, rpy_pair_block, &
                              op, matrix)
    call rigid_body_friction(ctx%comm, matrix, centres, first, count, reference_point, friction, stats)
    call destroy_bead_operator(op, matrix)
  end subroutine friction_of_model
end module beadmob_friction_job
