!> The 48 symmetries of the cubic lattice (signed permutations of the axes) acting on the
!> multipole basis. A Stokes flow turned or mirrored by Q is again a Stokes flow, so the two-bead
!> blocks obey A(Q d) = D_Q A(d) D_Q^T, with D_Q(alpha', alpha) = <phi_alpha', T_Q phi_alpha> and
!> (T_Q f)(y) = Q f(Q^T y) (for sigma = 1 densities, y x grad R, the sign det Q of a pseudo-vector
!> comes out of this formula by itself). D_Q is orthogonal and block-diagonal in (n, sigma).
!> A lattice block table then needs quadrature only for displacements with
!> d_1 >= d_2 >= d_3 >= 0 (theory.md T4).
module beadmob_lattice_symmetry
  use beadmob_kinds, only: dp
  use beadmob_multipole_basis, only: multipole_basis_t, evaluate_densities, bead_radius
  use beadmob_quadrature, only: sphere_rule
  use beadmob_lapack, only: dgemm
  implicit none
  private
  public :: n_symmetries, symmetry_matrix, canonical_displacement, basis_transforms

  integer, parameter :: n_symmetries = 48
  integer, parameter :: permutations(3, 6) = reshape([1, 2, 3, 1, 3, 2, 2, 1, 3, 2, 3, 1, 3, 1, 2, 3, 2, 1], [3, 6])

contains

  !> Q of symmetry s (1..48): Q(i, p(i)) = sign_i, so (Q c)_i = sign_i c_p(i).
  pure function symmetry_matrix(s) result(q)
    integer, intent(in) :: s
    integer :: q(3, 3), p, signs, i
    p = (s - 1) / 8 + 1
    signs = mod(s - 1, 8)
    q = 0
    do i = 1, 3
      q(i, permutations(i, p)) = merge(-1, 1, btest(signs, i - 1))
    end do
  end function symmetry_matrix

  !> c = |d| sorted descending, and s with d = Q_s c.
  pure subroutine canonical_displacement(d, c, s)
    integer, intent(in) :: d(3)
    integer, intent(out) :: c(3), s
    integer :: order(3), i, j, swap, p, signs, rank_of(3)
    order = [1, 2, 3]
    ! Axes by decreasing |d| (insertion sort of three).
    do i = 2, 3
      j = i
      do while (j > 1)
        if (abs(d(order(j - 1))) >= abs(d(order(j)))) exit
        swap = order(j); order(j) = order(j - 1); order(j - 1) = swap
        j = j - 1
      end do
    end do
    c = abs(d(order))
    ! Axis i holds component c(rank_of(i)): p(i) = rank_of(i).
    do i = 1, 3
      rank_of(order(i)) = i
    end do
    do p = 1, 6
      if (all(permutations(:, p) == rank_of)) exit
    end do
    signs = 0
    do i = 1, 3
      if (d(i) < 0) signs = ibset(signs, i - 1)
    end do
    s = 8 * (p - 1) + signs + 1
  end subroutine canonical_displacement

  !> transforms(:, :, s) = D_Q for every symmetry, by a quadrature exact for the integrands
  !> (polynomials of degree <= 2(L+1) on the sphere).
  subroutine basis_transforms(basis, transforms)
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(out) :: transforms(:, :, :)
    real(dp), allocatable :: points(:, :), weights(:), here(:, :, :), moved(:, :, :)
    real(dp) :: q(3, 3), diagonal_block(3 * (2 * basis%order + 1), 3 * (2 * basis%order + 1))
    integer :: s, p, n, rows, first, last, block
    call sphere_rule([0.0_dp, 0.0_dp, 1.0_dp], bead_radius, basis%order + 4, 2 * basis%order + 6, points, weights)
    ! The weighted densities at the nodes do not depend on the symmetry: evaluated once. Each
    ! transform is then one product over all nodes and components (BLAS), the sum of
    ! w_p here_p^T moved_p.
    allocate (here(3, size(weights), basis%size), moved(3, size(weights), basis%size))
    rows = 3 * size(weights)
    do p = 1, size(weights)
      call evaluate_densities(basis, points(:, p), here(:, p, :))
      here(:, p, :) = weights(p) * here(:, p, :)
    end do
    do s = 1, n_symmetries
      q = real(symmetry_matrix(s), dp)
      do p = 1, size(weights)
        call evaluate_densities(basis, matmul(transpose(q), points(:, p)), moved(:, p, :))
        moved(:, p, :) = matmul(q, moved(:, p, :))
      end do
      ! Q phi(Q^T y) of a degree-n density is again one of degree n (R_{n,k}(Q^T y) is a harmonic of
      ! degree n; grad, y x and |y| commute with Q up to det Q): only the diagonal blocks of the
      ! functions of one degree (contiguous in the basis) are nonzero.
      transforms(:, :, s) = 0.0_dp
      do n = 1, basis%order
        first = findloc(basis%degree, n, dim=1)
        last = findloc(basis%degree, n, dim=1, back=.true.)
        block = last - first + 1
        call dgemm('T', 'N', block, block, rows, 1.0_dp, here(:, :, first:last), rows, moved(:, :, first:last), &
                   rows, 0.0_dp, diagonal_block, size(diagonal_block, 1))
        transforms(first:last, first:last, s) = diagonal_block(1:block, 1:block)
      end do
    end do
  end subroutine basis_transforms
end module beadmob_lattice_symmetry
