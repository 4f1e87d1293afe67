!> The exact Stokes friction of a rigid ellipsoid: the continuum job's model of how the
!> friction of a bead model responds to the small changes of volume and shape that the lattice
!> makes at each offset (continuum_fit.f90, docs/theory.md T18).
!>
!> Semi-axes a_i, Delta(l) = sqrt(prod_i (a_i^2 + l)), chi = int_0^inf dl / Delta and
!> alpha_i = int_0^inf dl / ((a_i^2 + l) Delta). In the principal frame, viscosity 1:
!>   force  F_i = 16 pi U_i / (chi + a_i^2 alpha_i)                        (Oberbeck 1876)
!>   torque T_i = 16 pi (a_j^2 + a_k^2) Omega_i / (3 (a_j^2 alpha_j + a_k^2 alpha_k))  (Jeffery 1922)
!> with chi = 2 R_F(a_1^2, a_2^2, a_3^2) and alpha_i = (2/3) R_D(a_j^2, a_k^2, a_i^2), Carlson's
!> symmetric integrals (DLMF 19.16.1-2), evaluated by duplication (DLMF 19.36.1, Carlson 1995).
!> In a linear flow (docs/theory.md T19; scripts/beadmob_post/ellipsoid.py derives and tests the
!> same in Python), with beta_ij = int_0^inf dl / ((a_i^2 + l)(a_j^2 + l) Delta):
!>   rotation  Omega_k - Omega0_k = (a_i^2 - a_j^2) / (a_i^2 + a_j^2) E_ij, (k, i, j) cyclic  (Jeffery 1922)
!>   stresslet S_ij = 16 pi E_ij / (3 (a_i^2 + a_j^2) beta_ij) for i /= j, and on the traceless
!>             diagonal 2 V (P S_E P^T)^-1, S_E Eshelby's tensor at Poisson ratio 1/2 (Eshelby 1957;
!>             Mura, Micromechanics of Defects in Solids (1987), section 11): the free ellipsoid's.
module beadmob_ellipsoid_friction
  use beadmob_kinds, only: dp
  use beadmob_vector_algebra, only: cross
  use beadmob_linear_flow, only: n_strain_modes, strain_rotation
  implicit none
  private
  public :: ellipsoid_friction, ellipsoid_grand_resistance, carlson_rf, carlson_rd

  real(dp), parameter :: pi = acos(-1.0_dp)
  !> Duplication stops when every argument is within this relative distance of their mean:
  !> the series' first neglected terms are of sixth order in it (below 1e-17).
  real(dp), parameter :: duplication_tolerance = 1.0e-3_dp

contains

  !> The 6x6 friction (rows force, torque; columns velocity, angular velocity) about the
  !> centre of the ellipsoid with these semi-axes along the columns of `axes` (in the frame of
  !> those coordinates), viscosity 1.
  pure function ellipsoid_friction(semi_axes, axes) result(friction)
    real(dp), intent(in) :: semi_axes(3), axes(3, 3)
    real(dp) :: friction(6, 6)
    real(dp) :: squares(3), chi, alpha(3), principal(6)
    integer :: i, j, k
    squares = semi_axes**2
    chi = 2.0_dp * carlson_rf(squares(1), squares(2), squares(3))
    do i = 1, 3
      j = modulo(i, 3) + 1
      k = modulo(i + 1, 3) + 1
      alpha(i) = 2.0_dp / 3.0_dp * carlson_rd(squares(j), squares(k), squares(i))
    end do
    do i = 1, 3
      j = modulo(i, 3) + 1
      k = modulo(i + 1, 3) + 1
      principal(i) = 16.0_dp * pi / (chi + squares(i) * alpha(i))
      principal(3 + i) = 16.0_dp * pi * (squares(j) + squares(k)) / (3.0_dp * (squares(j) * alpha(j) + squares(k) * alpha(k)))
    end do
    ! Blocks A diag(f) A^T: the principal frame turned into the coordinates of `axes`.
    friction = 0.0_dp
    friction(1:3, 1:3) = matmul(axes, matmul(diagonal(principal(1:3)), transpose(axes)))
    friction(4:6, 4:6) = matmul(axes, matmul(diagonal(principal(4:6)), transpose(axes)))
  contains
    pure function diagonal(values) result(matrix)
      real(dp), intent(in) :: values(3)
      real(dp) :: matrix(3, 3)
      matrix = 0.0_dp
      matrix(1, 1) = values(1)
      matrix(2, 2) = values(2)
      matrix(3, 3) = values(3)
    end function diagonal
  end function ellipsoid_friction

  !> The 11 x 11 grand resistance (theory.md T19: rows and columns U, Omega, E_1..E_5) of the
  !> ellipsoid with these semi-axes along the columns of `axes`, about its centre, viscosity 1.
  !> From the free body's rotation V and stresslet T per strain: G_OmegaE = zeta_rr V and G_EE =
  !> T + V^T zeta_rr V (the inverse of flow_response.f90's Schur complement); G_UE = 0 by symmetry.
  pure function ellipsoid_grand_resistance(semi_axes, axes) result(grand)
    real(dp), intent(in) :: semi_axes(3), axes(3, 3)
    real(dp) :: grand(6 + n_strain_modes, 6 + n_strain_modes)
    integer, parameter :: pairs(2, 3) = reshape([1, 2, 1, 3, 2, 3], [2, 3])
    real(dp), parameter :: unit(3, 3) = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
                                                 1.0_dp], [3, 3])
    ! The traceless diagonal modes E_4, E_5 as rows (their diagonals)
    real(dp), parameter :: diagonals(2, 3) = reshape([1.0_dp / sqrt(2.0_dp), -1.0_dp / sqrt(6.0_dp), &
      -1.0_dp / sqrt(2.0_dp), -1.0_dp / sqrt(6.0_dp), 0.0_dp, 2.0_dp / sqrt(6.0_dp)], [2, 3])
    real(dp) :: squares(3), beta(3, 3), rotation(3, n_strain_modes), stresslet(n_strain_modes, n_strain_modes)
    real(dp) :: friction(6, 6), eshelby(3, 3), restricted(2, 2), turn(6 + n_strain_modes, 6 + n_strain_modes)
    real(dp) :: product_of_axes, volume, q(3, 3)
    integer :: mode, i, j, k
    squares = semi_axes**2
    beta = pair_integrals(squares)
    product_of_axes = product(semi_axes)
    volume = 4.0_dp * pi * product_of_axes / 3.0_dp
    friction = ellipsoid_friction(semi_axes, unit)
    rotation = 0.0_dp
    stresslet = 0.0_dp
    do mode = 1, 3
      i = pairs(1, mode)
      j = pairs(2, mode)
      k = 6 - i - j
      ! E_ij = e / sqrt2 for the mode's amplitude e; (1, 3) is anticyclic for k = 2.
      rotation(k, mode) = merge(-1.0_dp, 1.0_dp, mode == 2) * (squares(i) - squares(j)) / &
                          ((squares(i) + squares(j)) * sqrt(2.0_dp))
      stresslet(mode, mode) = 16.0_dp * pi / (3.0_dp * (squares(i) + squares(j)) * beta(i, j))
    end do
    do j = 1, 3
      eshelby(:, j) = 0.5_dp * beta(:, j) * squares(j)
      eshelby(j, j) = 1.5_dp * squares(j) * beta(j, j)
    end do
    restricted = product_of_axes * matmul(diagonals, matmul(eshelby, transpose(diagonals)))
    stresslet(4:5, 4:5) = 2.0_dp * volume * inverse2(restricted)
    stresslet(4:5, 4:5) = 0.5_dp * (stresslet(4:5, 4:5) + transpose(stresslet(4:5, 4:5)))
    grand = 0.0_dp
    grand(1:6, 1:6) = friction
    grand(4:6, 7:) = matmul(friction(4:6, 4:6), rotation)
    grand(7:, 4:6) = transpose(grand(4:6, 7:))
    grand(7:, 7:) = stresslet + matmul(transpose(rotation), grand(4:6, 7:))
    ! Into the coordinates of `axes`: diag(Q, Q, D(Q)), Q proper (an angular velocity is a
    ! pseudovector: a reflection would turn the sign of the rotation-strain coupling; the
    ! ellipsoid is the same body with any sign of its axes, so the third is flipped if need be).
    q = axes
    if (dot_product(q(:, 1), cross(q(:, 2), q(:, 3))) < 0.0_dp) q(:, 3) = -q(:, 3)
    turn = 0.0_dp
    turn(1:3, 1:3) = q
    turn(4:6, 4:6) = q
    turn(7:, 7:) = strain_rotation(q)
    grand = matmul(turn, matmul(grand, transpose(turn)))
  contains
    pure function inverse2(a) result(inverse)
      real(dp), intent(in) :: a(2, 2)
      real(dp) :: inverse(2, 2)
      inverse = reshape([a(2, 2), -a(2, 1), -a(1, 2), a(1, 1)], [2, 2]) / (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
    end function inverse2
  end function ellipsoid_grand_resistance

  !> beta_ij = int_0^inf dl / ((a_i^2 + l)(a_j^2 + l) Delta(l)) by the trapezoid rule in t = ln l:
  !> the integrand l f(l) is analytic and decays at both ends (~ l as l -> 0, ~ l^(-5/2) as l ->
  !> infinity), where the rule converges geometrically in 1/step; from 35 e-folds below the
  !> smallest a_i^2 to 15 above the largest, step 0.05: 1e-13 at axis ratios 1:100 (checked
  !> against the Carlson route of scripts/beadmob_post/ellipsoid.py, tests/unit/hydro/test_ellipsoid_grand.f90).
  pure function pair_integrals(squares) result(beta)
    real(dp), intent(in) :: squares(3)
    real(dp) :: beta(3, 3)
    real(dp), parameter :: step = 0.05_dp
    real(dp) :: first, l, delta
    integer :: p, points, i, j
    first = log(minval(squares)) - 35.0_dp
    points = ceiling((log(maxval(squares)) + 15.0_dp - first) / step)
    beta = 0.0_dp
    do p = 0, points
      l = exp(first + p * step)
      delta = sqrt(product(squares + l))
      do j = 1, 3
        do i = 1, 3
          beta(i, j) = beta(i, j) + step * l / ((squares(i) + l) * (squares(j) + l) * delta)
        end do
      end do
    end do
  end function pair_integrals

  !> R_F(x, y, z) = (1/2) int_0^inf dt / sqrt((t + x)(t + y)(t + z)), x, y, z >= 0, at most one 0.
  pure real(dp) function carlson_rf(x, y, z) result(rf)
    real(dp), intent(in) :: x, y, z
    real(dp) :: p(3), lambda, mean, dx, dy, dz, e2, e3
    p = [x, y, z]
    do
      mean = sum(p) / 3.0_dp
      if (maxval(abs(p - mean)) <= duplication_tolerance * mean) exit
      lambda = sqrt(p(1) * p(2)) + sqrt(p(2) * p(3)) + sqrt(p(3) * p(1))
      p = 0.25_dp * (p + lambda)
    end do
    dx = 1.0_dp - p(1) / mean
    dy = 1.0_dp - p(2) / mean
    dz = -(dx + dy)
    e2 = dx * dy - dz**2
    e3 = dx * dy * dz
    rf = (1.0_dp - e2 / 10.0_dp + e3 / 14.0_dp + e2**2 / 24.0_dp - 3.0_dp * e2 * e3 / 44.0_dp) / sqrt(mean)
  end function carlson_rf

  !> R_D(x, y, z) = (3/2) int_0^inf dt / ((t + z) sqrt((t + x)(t + y)(t + z))), z > 0.
  pure real(dp) function carlson_rd(x, y, z) result(rd)
    real(dp), intent(in) :: x, y, z
    real(dp) :: p(3), lambda, mean, weight, tail, dx, dy, dz, e2, e3, e4, e5
    p = [x, y, z]
    weight = 1.0_dp
    tail = 0.0_dp
    do
      mean = (p(1) + p(2) + 3.0_dp * p(3)) / 5.0_dp
      if (maxval(abs(p - mean)) <= duplication_tolerance * mean) exit
      lambda = sqrt(p(1) * p(2)) + sqrt(p(2) * p(3)) + sqrt(p(3) * p(1))
      tail = tail + weight / (sqrt(p(3)) * (p(3) + lambda))
      weight = 0.25_dp * weight
      p = 0.25_dp * (p + lambda)
    end do
    dx = 1.0_dp - p(1) / mean
    dy = 1.0_dp - p(2) / mean
    dz = -(dx + dy) / 3.0_dp
    e2 = dx * dy - 6.0_dp * dz**2
    e3 = (3.0_dp * dx * dy - 8.0_dp * dz**2) * dz
    e4 = 3.0_dp * (dx * dy - dz**2) * dz**2
    e5 = dx * dy * dz**3
    rd = weight / (mean * sqrt(mean)) * (1.0_dp - 3.0_dp * e2 / 14.0_dp + e3 / 6.0_dp + 9.0_dp * e2**2 / 88.0_dp - &
                                        3.0_dp * e4 / 22.0_dp - 9.0_dp * e2 * e3 / 52.0_dp + 3.0_dp * e5 / 26.0_dp) + &
         3.0_dp * tail
  end function carlson_rd
end module beadmob_ellipsoid_friction
