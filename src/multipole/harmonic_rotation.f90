!> Rotations of the multipole basis (theory.md T15). For a proper rotation Q the map
!> (T_Q f)(y) = Q f(Q^T y) sends a density of degree n and family sigma to one of the same n and
!> sigma (grad, y x and |y| commute with a proper rotation), so D_Q(alpha', alpha) =
!> <phi_alpha', T_Q phi_alpha> is block-diagonal in (n, sigma), and every block of degree n is
!> the same orthogonal matrix O^n(Q) of the L2-normalised real harmonics:
!>   Y_k(Q^T y) = sum_k' O^n(k', k) Y_k'(y),   O^n(k', k) = int_{|y|=1} Y_k'(y) Y_k(Q^T y) dS.
!> The integrand is a polynomial of degree 2n on the sphere: a product rule with L + 1
!> Gauss-Legendre points in cos(theta) and 2 L + 2 in the azimuth gives O^n exactly (to rounding).
!> (The families' norms are the harmonic's norm times a factor of n and sigma only, so the same
!> O^n serves every family; checked against the direct quadrature of D_Q in test_axial_blocks.)
module beadmob_harmonic_rotation
  use beadmob_kinds, only: dp
  use beadmob_solid_harmonics, only: solid_harmonics, harmonic_index
  use beadmob_quadrature, only: sphere_rule
  implicit none
  private
  public :: rotation_rule_t, make_rotation_rule, degree_rotations, rotation_to_direction, direction_rotations

  !> What every rotation of order <= L needs, computed once.
  type :: rotation_rule_t
    integer :: order = 0
    real(dp), allocatable :: points(:, :)     ! (3, P) nodes on the unit sphere
    !> weighted(p, idx) = w_p Y_idx(y_p) (normalised harmonic, flat index of solid_harmonics)
    real(dp), allocatable :: weighted(:, :)
    real(dp), allocatable :: inverse_norm(:)  ! 1 / ||R_idx|| on the unit sphere
    !> For direction_rotations: O^n(P), P = R_x(-pi/2) (P e_z = e_y), per degree, and the sign of
    !> sin(m alpha) in O^n(R_z(alpha)) at (k, -k) per degree and k = 1..n
    real(dp), allocatable :: to_y(:, :, :), z_sign(:, :)
    logical :: factorised = .false.           ! O^n(R_z) has the cos/sin pair form (checked)
  end type rotation_rule_t

contains

  pure function make_rotation_rule(order) result(rule)
    integer, intent(in) :: order
    type(rotation_rule_t) :: rule
    real(dp), allocatable :: weights(:), values(:, :)
    real(dp) :: gradients(3, 0:(order + 1)**2 - 1)
    integer :: p
    rule%order = order
    call sphere_rule([0.0_dp, 0.0_dp, 1.0_dp], 1.0_dp, order + 1, 2 * order + 2, rule%points, weights)
    allocate (values(size(weights), 0:(order + 1)**2 - 1))
    do p = 1, size(weights)
      call solid_harmonics(rule%points(:, p), order, values(p, :), gradients)
    end do
    ! 0-based like the harmonics' flat index (an assignment to an unallocated array would start at 1)
    allocate (rule%inverse_norm(0:(order + 1)**2 - 1), rule%weighted(size(weights), 0:(order + 1)**2 - 1))
    rule%inverse_norm = 1.0_dp / sqrt(matmul(weights, values**2))
    rule%weighted = values * spread(weights, 2, size(values, 2)) * spread(rule%inverse_norm, 1, size(weights))
    call prepare_factorisation(rule)
  end function make_rotation_rule

  !> What direction_rotations needs: O^n(P) for the fixed P = R_x(-pi/2), which turns the z axis
  !> into the y axis, and the signs of O^n(R_z(alpha)), read from one rotation about z
  !> (alpha = 1) and checked against the cos/sin pair form at a second angle; without that form
  !> (not expected of real harmonics) direction_rotations takes degree_rotations' way.
  pure subroutine prepare_factorisation(rule)
    type(rotation_rule_t), intent(inout) :: rule
    real(dp) :: about_z(2 * rule%order + 1, 2 * rule%order + 1, rule%order), &
                model(2 * rule%order + 1, 2 * rule%order + 1, rule%order), p(3, 3)
    integer :: n, k
    allocate (rule%to_y(2 * rule%order + 1, 2 * rule%order + 1, rule%order), rule%z_sign(rule%order, rule%order))
    p = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, -1.0_dp, 0.0_dp, 1.0_dp, 0.0_dp], [3, 3])   ! columns P e_x, P e_y, P e_z
    call degree_rotations(rule, p, rule%to_y)
    call degree_rotations(rule, z_rotation(1.0_dp), about_z)
    rule%z_sign = 0.0_dp
    do n = 1, rule%order
      do k = 1, n
        rule%z_sign(k, n) = sign(1.0_dp, about_z(n + 1 + k, n + 1 - k, n) * sin(real(k, dp)))
      end do
    end do
    call degree_rotations(rule, z_rotation(2.5_dp), about_z)
    call z_blocks(rule, cos(2.5_dp), sin(2.5_dp), model)
    rule%factorised = maxval(abs(about_z - model)) <= 1.0e-13_dp
  end subroutine prepare_factorisation

  !> R_z(alpha) as a 3 x 3 matrix.
  pure function z_rotation(alpha) result(q)
    real(dp), intent(in) :: alpha
    real(dp) :: q(3, 3)
    q = reshape([cos(alpha), sin(alpha), 0.0_dp, -sin(alpha), cos(alpha), 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], [3, 3])
  end function z_rotation

  !> blocks(:, :, n) = O^n(R_z(alpha)) from cos alpha and sin alpha: 1 at k = 0 and, for k = 1..n,
  !> cos(k alpha) at (k, k) and (-k, -k), z_sign sin(k alpha) at (k, -k) and its negative at (-k, k)
  !> (cos and sin of k alpha by the angle-addition recurrence).
  pure subroutine z_blocks(rule, c, s, blocks)
    type(rotation_rule_t), intent(in) :: rule
    real(dp), intent(in) :: c, s
    real(dp), intent(out) :: blocks(:, :, :)
    real(dp) :: ck(0:rule%order), sk(0:rule%order)
    integer :: n, k
    ck(0) = 1.0_dp
    sk(0) = 0.0_dp
    do k = 1, rule%order
      ck(k) = ck(k - 1) * c - sk(k - 1) * s
      sk(k) = sk(k - 1) * c + ck(k - 1) * s
    end do
    blocks = 0.0_dp
    do n = 1, rule%order
      blocks(n + 1, n + 1, n) = 1.0_dp
      do k = 1, n
        blocks(n + 1 + k, n + 1 + k, n) = ck(k)
        blocks(n + 1 - k, n + 1 - k, n) = ck(k)
        blocks(n + 1 + k, n + 1 - k, n) = rule%z_sign(k, n) * sk(k)
        blocks(n + 1 - k, n + 1 + k, n) = -rule%z_sign(k, n) * sk(k)
      end do
    end do
  end subroutine z_blocks

  !> degree_rotations of rotation_to_direction(direction), factorised: Q = R_z(phi) R_y(theta)
  !> and R_y(theta) = P R_z(theta) P^T give O^n(Q) = O^n(R_z(phi)) O^n(P) O^n(R_z(theta)) O^n(P)^T
  !> (O^n is a representation: O^n(Q1 Q2) = O^n(Q1) O^n(Q2)), the R_z factors in closed form:
  !> no harmonics evaluated per pair (theory.md T15).
  pure subroutine direction_rotations(rule, direction, rotations)
    type(rotation_rule_t), intent(in) :: rule
    real(dp), intent(in) :: direction(3)
    real(dp), intent(out) :: rotations(:, :, :)
    real(dp) :: u(3), rho, by_theta(2 * rule%order + 1, 2 * rule%order + 1, rule%order), &
                by_phi(2 * rule%order + 1, 2 * rule%order + 1, rule%order), turned(2 * rule%order + 1, 2 * rule%order + 1)
    integer :: n, m
    if (.not. rule%factorised) then
      call degree_rotations(rule, rotation_to_direction(direction), rotations)
      return
    end if
    u = direction / norm2(direction)
    rho = hypot(u(1), u(2))
    call z_blocks(rule, u(3), rho, by_theta)
    if (rho > 0.0_dp) then
      call z_blocks(rule, u(1) / rho, u(2) / rho, by_phi)
    else
      call z_blocks(rule, 1.0_dp, 0.0_dp, by_phi)
    end if
    rotations = 0.0_dp
    do n = 1, rule%order
      m = 2 * n + 1
      turned(1:m, 1:m) = matmul(matmul(rule%to_y(1:m, 1:m, n), by_theta(1:m, 1:m, n)), transpose(rule%to_y(1:m, 1:m, n)))
      rotations(1:m, 1:m, n) = matmul(by_phi(1:m, 1:m, n), turned(1:m, 1:m))
    end do
  end subroutine direction_rotations

  !> rotations(1:2n+1, 1:2n+1, n) = O^n(Q) for n = 1..L (k = -n..n in the basis order).
  pure subroutine degree_rotations(rule, q, rotations)
    type(rotation_rule_t), intent(in) :: rule
    real(dp), intent(in) :: q(3, 3)
    real(dp), intent(out) :: rotations(:, :, :)
    real(dp) :: turned(size(rule%points, 2), 0:(rule%order + 1)**2 - 1), gradients(3, 0:(rule%order + 1)**2 - 1)
    integer :: p, n, first, last
    do p = 1, size(rule%points, 2)
      call solid_harmonics(matmul(rule%points(:, p), q), rule%order, turned(p, :), gradients)   ! Q^T y_p
    end do
    turned = turned * spread(rule%inverse_norm, 1, size(rule%points, 2))
    rotations = 0.0_dp
    do n = 1, rule%order
      first = harmonic_index(n, -n)
      last = harmonic_index(n, n)
      rotations(1:2 * n + 1, 1:2 * n + 1, n) = matmul(transpose(rule%weighted(:, first:last)), turned(:, first:last))
    end do
  end subroutine degree_rotations

  !> A proper rotation with Q e_z = direction / |direction|: Q = R_z(phi) R_y(theta) of the
  !> direction's polar angles.
  pure function rotation_to_direction(direction) result(q)
    real(dp), intent(in) :: direction(3)
    real(dp) :: q(3, 3), u(3), rho, cos_phi, sin_phi, cos_theta, sin_theta
    u = direction / norm2(direction)
    rho = hypot(u(1), u(2))
    cos_theta = u(3)
    sin_theta = rho
    if (rho > 0.0_dp) then
      cos_phi = u(1) / rho
      sin_phi = u(2) / rho
    else
      cos_phi = 1.0_dp
      sin_phi = 0.0_dp
    end if
    ! columns: R_z(phi) R_y(theta) e_x, e_y, e_z
    q(:, 1) = [cos_phi * cos_theta, sin_phi * cos_theta, -sin_theta]
    q(:, 2) = [-sin_phi, cos_phi, 0.0_dp]
    q(:, 3) = [cos_phi * sin_theta, sin_phi * sin_theta, cos_theta]
  end function rotation_to_direction
end module beadmob_harmonic_rotation
