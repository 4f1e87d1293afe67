!> Validation of the size parameters shape builders take.
module beadmob_size_checks
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  implicit none
  private
  public :: positive_size

contains

  !> True if value is finite and > 0; otherwise raises "<what> must be positive and finite, got <value>".
  logical function positive_size(value, what, err) result(ok)
    real(dp), intent(in) :: value
    character(len=*), intent(in) :: what
    type(error_t), intent(inout) :: err
    ok = ieee_is_finite(value)
    if (ok) ok = value > 0.0_dp
    if (.not. ok) call raise(err, what // ' must be positive and finite, got ' // str(value))
  end function positive_size
end module beadmob_size_checks
