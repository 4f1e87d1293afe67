!> Reproducible pseudo-random numbers for the test programs: a value depends on an integer seed
!> only, so 1 and 2 ranks fill a distributed vector with the same entries.
module beadmob_random_vectors
#include "petsc/finclude/petscvec.h"
  use petscvec
  use beadmob_kinds, only: dp, i8
  implicit none
  private
  public :: hash_uniform, fill_random

contains

  !> A uniform number in (0, 1) from an integer: three steps of the Park-Miller generator
  !> (multiplier 16807, modulus 2^31 - 1; no integer overflow in 64 bits).
  pure real(dp) function hash_uniform(seed)
    integer(i8), intent(in) :: seed
    integer(i8), parameter :: modulus = 2147483647_i8
    integer(i8) :: z
    integer :: step
    z = mod(abs(seed), modulus - 1) + 1
    do step = 1, 3
      z = mod(16807_i8 * z, modulus)
    end do
    hash_uniform = real(z, dp) / real(modulus, dp)
  end function hash_uniform

  !> Entries in (-1/2, 1/2) from the global index, the stream number and `offset` (default 0:
  !> another offset, another family of streams) only.
  subroutine fill_random(v, stream, offset)
    Vec, intent(inout) :: v
    integer, intent(in) :: stream
    integer(i8), intent(in), optional :: offset
    PetscScalar, pointer :: values(:)
    PetscInt :: start, finish, k
    PetscErrorCode :: ierr
    integer(i8) :: shift
    shift = 0
    if (present(offset)) shift = offset
    PetscCallA(VecGetOwnershipRange(v, start, finish, ierr))
    PetscCallA(VecGetArrayF90(v, values, ierr))
    do k = start, finish - 1
      values(k - start + 1) = hash_uniform(int(k, i8) * 7919_i8 + stream * 104729_i8 + shift) - 0.5_dp
    end do
    PetscCallA(VecRestoreArrayF90(v, values, ierr))
  end subroutine fill_random
end module beadmob_random_vectors
