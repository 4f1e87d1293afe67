!> Galerkin blocks of the multipole system (docs/theory.md T4, T5):
!>   A_ij(alpha, beta) = int_{S_i} phi_alpha(x - R_i) . u_beta(x - R_j) dS_x,
!> the projection on bead i's densities of the exterior field of bead j's density beta. For
!> i = j it is the single-bead block (Z0^-1 of Cichocki et al. 1994); otherwise the two-bead
!> propagator, a function of R_i - R_j only, with A_ji(-r) = A_ij(r)^T. Evaluated by a product
!> rule on S_i whose polar axis points at R_j: Gauss-Legendre in cos(theta) converges like
!> rho^(-2 n_theta), rho the Bernstein-ellipse parameter of the nearest singularity of the
!> integrand (the pole of |x - R_j|^-1); the azimuthal trapezoid rule is exact.
module beadmob_pair_blocks
  use beadmob_kinds, only: dp
  use beadmob_lapack, only: dgemm
  use beadmob_multipole_basis, only: multipole_basis_t, evaluate_densities, evaluate_fields, bead_radius
  use beadmob_quadrature, only: sphere_rule
  implicit none
  private
  public :: pair_block, self_block, rigid_projection

contains

  !> Block for the row bead i and column bead j, displacement = R_i - R_j (|displacement| >= 2a).
  subroutine pair_block(basis, displacement, block)
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: displacement(3)
    real(dp), intent(out) :: block(:, :)
    real(dp) :: distance, t0, rho
    integer :: n_theta, n_phi, order
    order = basis%order
    distance = norm2(displacement)
    t0 = (bead_radius**2 + distance**2) / (2.0_dp * bead_radius * distance)
    rho = t0 + sqrt(t0 * t0 - 1.0_dp)
    ! About 40 + 1.5 (L + 3) e-folds of the integrand's Gauss-Legendre error (theory.md T4).
    n_theta = ceiling((40.0_dp + 1.5_dp * (order + 3)) / log(rho)) / 2 + order + 8
    n_theta = min(max(n_theta, order + 8), 400)
    n_phi = 2 * azimuthal_extent(basis) + 8
    call projected_fields(basis, -displacement, displacement, n_theta, n_phi, block)
  end subroutine pair_block

  !> The single-bead block: the field of bead i's own densities projected on them.
  subroutine self_block(basis, block)
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(out) :: block(:, :)
    call projected_fields(basis, [0.0_dp, 0.0_dp, 1.0_dp], [0.0_dp, 0.0_dp, 0.0_dp], basis%order + 4, &
                          2 * azimuthal_extent(basis) + 6, block)
    block = 0.5_dp * (block + transpose(block))   ! symmetric in exact arithmetic
  end subroutine self_block

  !> Largest |k| in the basis. About the pair axis the integrand is a trigonometric polynomial of
  !> degree <= 2 max|k| + 2 (the vector components add one each), so the azimuthal trapezoid rule
  !> with 2 max|k| + 8 points is exact. A basis restricted to small |k| (two-sphere tables on the
  !> z axis) thus needs few azimuthal points.
  pure integer function azimuthal_extent(basis)
    type(multipole_basis_t), intent(in) :: basis
    azimuthal_extent = maxval(abs(basis%harmonic))
  end function azimuthal_extent

  !> block(alpha, beta) = sum_p w_p phi_alpha(y_p) . u_beta(y_p + displacement), y_p on S_i.
  subroutine projected_fields(basis, axis, displacement, n_theta, n_phi, block)
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: axis(3), displacement(3)
    integer, intent(in) :: n_theta, n_phi
    real(dp), intent(out) :: block(:, :)
    real(dp), allocatable :: points(:, :), weights(:), densities(:, :), fields(:, :)
    integer :: p, nb, n_points
    nb = basis%size
    call sphere_rule(axis, bead_radius, n_theta, n_phi, points, weights)
    n_points = size(weights)
    allocate (densities(3 * n_points, nb), fields(3 * n_points, nb))
    do p = 1, n_points
      call evaluate_densities(basis, points(:, p), densities(3 * p - 2:3 * p, :))
      densities(3 * p - 2:3 * p, :) = weights(p) * densities(3 * p - 2:3 * p, :)
      call evaluate_fields(basis, points(:, p) + displacement, fields(3 * p - 2:3 * p, :))
    end do
    call dgemm('T', 'N', nb, nb, 3 * n_points, 1.0_dp, densities, 3 * n_points, fields, 3 * n_points, 0.0_dp, block, nb)
  end subroutine projected_fields

  !> projection(alpha, m) = int_S phi_alpha . v_m dS for the unit rigid motions of one bead:
  !> m = 1..3 translations, m = 4..6 rotations about the bead centre (theory.md T5). Its
  !> transpose maps a bead's multipoles to the force (1..3) and torque (4..6) on the fluid.
  subroutine rigid_projection(basis, projection)
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(out) :: projection(:, :)
    real(dp), allocatable :: points(:, :), weights(:), densities(:, :)
    real(dp) :: y(3), unit(3)
    integer :: p, c
    call sphere_rule([0.0_dp, 0.0_dp, 1.0_dp], bead_radius, basis%order + 4, 2 * basis%order + 6, points, weights)
    allocate (densities(3, basis%size))
    projection(:, 1:6) = 0.0_dp
    do p = 1, size(weights)
      y = points(:, p)
      call evaluate_densities(basis, y, densities)
      do c = 1, 3
        unit = 0.0_dp
        unit(c) = 1.0_dp
        projection(:, c) = projection(:, c) + weights(p) * densities(c, :)
        projection(:, 3 + c) = projection(:, 3 + c) + weights(p) * matmul([unit(2) * y(3) - unit(3) * y(2), &
                               unit(3) * y(1) - unit(1) * y(3), unit(1) * y(2) - unit(2) * y(1)], densities)
      end do
    end do
  end subroutine rigid_projection
end module beadmob_pair_blocks
