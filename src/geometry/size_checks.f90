!> Validation of the size parameters shape builders take.
module beadmob_size_checks
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str, str_approx
  implicit none
  private
  public :: positive_size

  !> Largest size (d) a shape parameter may have: lattice coordinates of the builders are default
  !> integers, and a body 1e7 beads across is far beyond any memory anyway (a size beyond the
  !> integer range would otherwise wrap round into a silently wrong bead model).
  real(dp), parameter :: max_size = 1.0e7_dp

contains

  !> True if value is finite, > 0 and <= max_size; otherwise raises "<what> must be positive and
  !> finite, got <value>" (or "... at most 1e7 d ...").
  logical function positive_size(value, what, err) result(ok)
    real(dp), intent(in) :: value
    character(len=*), intent(in) :: what
    type(error_t), intent(inout) :: err
    ok = ieee_is_finite(value)
    if (ok) ok = value > 0.0_dp
    if (.not. ok) then
      call raise(err, what // ' must be positive and finite, got ' // str(value))
    else if (value > max_size) then
      ok = .false.
      call raise(err, what // ' must be at most ' // str_approx(max_size) // ' d (the lattice index range), got ' // str_approx(value))
    end if
  end function positive_size
end module beadmob_size_checks
