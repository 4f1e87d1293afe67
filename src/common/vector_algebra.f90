!> Small 3-vector helpers shared by geometry and rigid-body code.
module beadmob_vector_algebra
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: cross, axis_angle_rotation

contains

  pure function cross(a, b) result(c)
    real(dp), intent(in) :: a(3), b(3)
    real(dp) :: c(3)
    c = [a(2) * b(3) - a(3) * b(2), a(3) * b(1) - a(1) * b(3), a(1) * b(2) - a(2) * b(1)]
  end function cross

  !> The rotation by `angle` (radians) about the unit vector `axis` (Rodrigues' formula:
  !> 1 + sin(angle) K + (1 - cos(angle)) K^2, K the cross-product matrix of axis).
  pure function axis_angle_rotation(axis, angle) result(r)
    real(dp), intent(in) :: axis(3), angle
    real(dp) :: r(3, 3), k(3, 3)
    integer :: i
    k = reshape([0.0_dp, axis(3), -axis(2), -axis(3), 0.0_dp, axis(1), axis(2), -axis(1), 0.0_dp], [3, 3])
    r = sin(angle) * k + (1.0_dp - cos(angle)) * matmul(k, k)
    do i = 1, 3
      r(i, i) = r(i, i) + 1.0_dp
    end do
  end function axis_angle_rotation
end module beadmob_vector_algebra
