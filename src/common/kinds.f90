!> Numeric kinds used everywhere in beadmob: one place, so that every real is real(dp).
module beadmob_kinds
  use, intrinsic :: iso_fortran_env, only: real64, int32, int64
  implicit none
  private
  public :: dp, i4, i8

  integer, parameter :: dp = real64
  integer, parameter :: i4 = int32
  integer, parameter :: i8 = int64
end module beadmob_kinds
