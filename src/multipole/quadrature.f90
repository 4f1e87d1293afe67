!> Quadrature rules on a sphere: Gauss-Legendre in cos(theta) about a chosen polar axis times
!> the trapezoid rule in the azimuth (exact for trigonometric polynomials of degree < n_phi).
module beadmob_quadrature
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: gauss_legendre, sphere_rule

  real(dp), parameter :: pi = acos(-1.0_dp)

contains

  !> Nodes and weights of the n-point Gauss-Legendre rule on [-1, 1] (Newton on P_n).
  pure subroutine gauss_legendre(n, nodes, weights)
    integer, intent(in) :: n
    real(dp), intent(out) :: nodes(n), weights(n)
    real(dp) :: t, value, derivative, step
    integer :: i, iteration
    do i = 1, (n + 1) / 2
      t = cos(pi * (i - 0.25_dp) / (n + 0.5_dp))
      do iteration = 1, 100
        call legendre(n, t, value, derivative)
        step = value / derivative
        t = t - step
        if (abs(step) < 1.0e-16_dp) exit
      end do
      call legendre(n, t, value, derivative)
      nodes(i) = -t
      nodes(n + 1 - i) = t
      weights(i) = 2.0_dp / ((1.0_dp - t * t) * derivative**2)
      weights(n + 1 - i) = weights(i)
    end do
  end subroutine gauss_legendre

  !> P_n(t) and P_n'(t) by the three-term recurrence.
  pure subroutine legendre(n, t, value, derivative)
    integer, intent(in) :: n
    real(dp), intent(in) :: t
    real(dp), intent(out) :: value, derivative
    real(dp) :: previous, next
    integer :: j
    previous = 1.0_dp
    value = t
    do j = 2, n
      next = ((2 * j - 1) * t * value - (j - 1) * previous) / j
      previous = value
      value = next
    end do
    derivative = n * (t * value - previous) / (t * t - 1.0_dp)
  end subroutine legendre

  !> Points (relative to the centre, 3 x n_theta*n_phi) and weights of a rule on the sphere of
  !> radius `radius` whose polar axis is `axis` (need not be normalised).
  pure subroutine sphere_rule(axis, radius, n_theta, n_phi, points, weights)
    real(dp), intent(in) :: axis(3), radius
    integer, intent(in) :: n_theta, n_phi
    real(dp), allocatable, intent(out) :: points(:, :), weights(:)
    real(dp) :: e1(3), e2(3), e3(3), helper(3), t(n_theta), wt(n_theta), phi, sin_theta
    integer :: i, j, p
    e3 = axis / norm2(axis)
    helper = [1.0_dp, 0.0_dp, 0.0_dp]
    if (abs(e3(1)) >= 0.9_dp) helper = [0.0_dp, 1.0_dp, 0.0_dp]
    e1 = [e3(2) * helper(3) - e3(3) * helper(2), e3(3) * helper(1) - e3(1) * helper(3), &
          e3(1) * helper(2) - e3(2) * helper(1)]
    e1 = e1 / norm2(e1)
    e2 = [e3(2) * e1(3) - e3(3) * e1(2), e3(3) * e1(1) - e3(1) * e1(3), e3(1) * e1(2) - e3(2) * e1(1)]
    call gauss_legendre(n_theta, t, wt)
    allocate (points(3, n_theta * n_phi), weights(n_theta * n_phi))
    p = 0
    do i = 1, n_theta
      sin_theta = sqrt(max(0.0_dp, 1.0_dp - t(i)**2))
      do j = 0, n_phi - 1
        phi = 2.0_dp * pi * j / n_phi
        p = p + 1
        points(:, p) = radius * (sin_theta * (cos(phi) * e1 + sin(phi) * e2) + t(i) * e3)
        weights(p) = wt(i) * (2.0_dp * pi / n_phi) * radius**2
      end do
    end do
  end subroutine sphere_rule
end module beadmob_quadrature
