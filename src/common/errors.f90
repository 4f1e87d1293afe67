!> Error values passed up from library routines to the driver, which makes the
!> MPI ranks agree on failure and aborts with one clear message. Library code never stops.
module beadmob_errors
  implicit none
  private
  public :: error_t, raise

  type :: error_t
    logical :: failed = .false.
    character(len=:), allocatable :: message
  end type error_t

contains

  !> Record a failure; the first message is kept (it names the root cause).
  subroutine raise(err, message)
    type(error_t), intent(inout) :: err
    character(len=*), intent(in) :: message
    if (err%failed) return
    err%failed = .true.
    err%message = message
  end subroutine raise
end module beadmob_errors
