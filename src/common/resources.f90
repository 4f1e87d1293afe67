!> Resources used by this process: the peak resident set size (POSIX getrusage; Linux reports
!> ru_maxrss in kilobytes).
module beadmob_resources
  use, intrinsic :: iso_c_binding, only: c_int, c_long
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: peak_resident_bytes

  type, bind(c) :: c_timeval
    integer(c_long) :: seconds, microseconds
  end type c_timeval

  type, bind(c) :: c_rusage
    type(c_timeval) :: user_time, system_time
    integer(c_long) :: maxrss, ixrss, idrss, isrss, minflt, majflt, nswap, inblock, oublock, msgsnd, msgrcv, &
                       nsignals, nvcsw, nivcsw
  end type c_rusage

  interface
    integer(c_int) function c_getrusage(who, usage) bind(c, name='getrusage')
      import :: c_int, c_rusage
      integer(c_int), value :: who
      type(c_rusage), intent(out) :: usage
    end function c_getrusage
  end interface

contains

  !> Peak resident set size of this process so far, bytes (0 if unavailable).
  real(dp) function peak_resident_bytes()
    type(c_rusage) :: usage
    integer(c_int), parameter :: rusage_self = 0
    peak_resident_bytes = 0.0_dp
    if (c_getrusage(rusage_self, usage) == 0) peak_resident_bytes = real(usage%maxrss, dp) * 1024.0_dp
  end function peak_resident_bytes
end module beadmob_resources
