!> Progress lines of a long run: rank 0 prints one line when a phase of the
!> friction job starts and one per Krylov solve, each flushed at once so that a batch job's log
!> shows where the run is while it runs. Whether to print is passed in by the caller (&run
!> progress and -quiet, friction_job.F90): no state is kept here.
module beadmob_progress
  use, intrinsic :: iso_fortran_env, only: output_unit
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: progress_line, progress_prefix, progress_seconds

  !> Every progress line starts with this (stable: tests and users grep for it).
  character(len=*), parameter :: progress_prefix = 'beadmob: progress: '

contains

  !> Print `text` as a progress line when `enabled` (callers pass .false. on ranks other than 0).
  subroutine progress_line(enabled, text)
    logical, intent(in) :: enabled
    character(len=*), intent(in) :: text
    if (.not. enabled) return
    write (output_unit, '(a)') progress_prefix // text
    flush (output_unit)
  end subroutine progress_line

  !> Seconds for progress lines: two decimals below 100 s, whole seconds above.
  function progress_seconds(seconds) result(text)
    real(dp), intent(in) :: seconds
    character(len=:), allocatable :: text
    character(len=24) :: buffer
    if (seconds < 100.0_dp) then
      write (buffer, '(f0.2)') max(seconds, 0.0_dp)
    else
      write (buffer, '(i0)') nint(seconds)
    end if
    text = trim(buffer)
    if (text(1:1) == '.') text = '0' // text
  end function progress_seconds
end module beadmob_progress
