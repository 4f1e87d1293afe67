!> The multipole friction of a few beads by a dense Cholesky solve (theory.md T5, T6):
!>   zeta = K^T B^T A^-1 B K,
!> A the Galerkin matrix (self and pair blocks), B the rigid projections of every bead and K
!> (6 n x m) the bead velocities (U_i, Omega_i) of m chosen motions. Used for two-bead
!> (lubrication) tables and as an independent check of the distributed solve.
module beadmob_dense_friction
  use beadmob_kinds, only: dp
  use beadmob_lapack, only: dpotrf, dpotrs
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_multipole_basis, only: multipole_basis_t
  use beadmob_pair_blocks, only: pair_block, self_block, rigid_projection
  implicit none
  private
  public :: dense_friction, rigid_motions

contains

  !> motions(6 n, m): rows 6(i-1)+1..6i hold (U_i, Omega_i) of bead i for each motion.
  subroutine dense_friction(basis, centres, motions, friction, err)
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :), motions(:, :)
    real(dp), intent(out) :: friction(:, :)
    type(error_t), intent(inout) :: err
    real(dp), allocatable :: matrix(:, :), rhs(:, :), solution(:, :), block(:, :), projection(:, :)
    integer :: n, nb, i, j, info, m
    n = size(centres, 2)
    nb = basis%size
    m = size(motions, 2)
    allocate (matrix(n * nb, n * nb), rhs(n * nb, m), block(nb, nb), projection(nb, 6))
    call self_block(basis, block)
    do i = 1, n
      matrix((i - 1) * nb + 1:i * nb, (i - 1) * nb + 1:i * nb) = block
    end do
    do i = 1, n
      do j = i + 1, n
        call pair_block(basis, centres(:, i) - centres(:, j), block)
        matrix((i - 1) * nb + 1:i * nb, (j - 1) * nb + 1:j * nb) = block
        matrix((j - 1) * nb + 1:j * nb, (i - 1) * nb + 1:i * nb) = transpose(block)
      end do
    end do
    call rigid_projection(basis, projection)
    do i = 1, n
      rhs((i - 1) * nb + 1:i * nb, :) = matmul(projection, motions(6 * i - 5:6 * i, :))
    end do
    solution = rhs
    call dpotrf('L', n * nb, matrix, n * nb, info)
    if (info /= 0) then
      call raise(err, 'multipole matrix of ' // str(n) // ' beads is not positive definite (dpotrf info ' // &
                 str(info) // ')')
      friction = 0.0_dp
      return
    end if
    call dpotrs('L', n * nb, m, matrix, n * nb, solution, n * nb, info)
    friction = matmul(transpose(rhs), solution)
    friction = 0.5_dp * (friction + transpose(friction))
  end subroutine dense_friction

  !> K (6 n x 6): bead velocities of the six unit rigid motions about `reference`:
  !> U_i = U + Omega x (R_i - reference), Omega_i = Omega.
  pure function rigid_motions(centres, reference) result(motions)
    real(dp), intent(in) :: centres(:, :), reference(3)
    real(dp) :: motions(6 * size(centres, 2), 6), arm(3)
    integer :: i, c
    motions = 0.0_dp
    do i = 1, size(centres, 2)
      arm = centres(:, i) - reference
      do c = 1, 3
        motions(6 * i - 6 + c, c) = 1.0_dp
        motions(6 * i - 3 + c, 3 + c) = 1.0_dp
      end do
      ! Omega x arm, column by column: e_x x arm = (0, -arm_z, arm_y), ...
      motions(6 * i - 5:6 * i - 3, 4) = [0.0_dp, -arm(3), arm(2)]
      motions(6 * i - 5:6 * i - 3, 5) = [arm(3), 0.0_dp, -arm(1)]
      motions(6 * i - 5:6 * i - 3, 6) = [-arm(2), arm(1), 0.0_dp]
    end do
  end function rigid_motions
end module beadmob_dense_friction
