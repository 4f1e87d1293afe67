!> The two POSIX file operations that make a written file appear whole or not at all: write to a
!> temporary name, then rename(2) it over the final one (atomic within a file system); remove the
!> temporary on failure. Used by the result file, the checkpoint and the table cache.
module beadmob_file_system
  use, intrinsic :: iso_c_binding, only: c_char, c_int, c_null_char
  implicit none
  private
  public :: rename_file, remove_file, probe_writable

  interface
    integer(c_int) function c_rename(old_path, new_path) bind(c, name='rename')
      import :: c_char, c_int
      character(kind=c_char), intent(in) :: old_path(*), new_path(*)
    end function c_rename
    integer(c_int) function c_unlink(path) bind(c, name='unlink')
      import :: c_char, c_int
      character(kind=c_char), intent(in) :: path(*)
    end function c_unlink
  end interface

contains

  !> Rename old_path to new_path (replacing it); true on success.
  logical function rename_file(old_path, new_path)
    character(len=*), intent(in) :: old_path, new_path
    rename_file = c_rename(old_path // c_null_char, new_path // c_null_char) == 0
  end function rename_file

  !> Remove `path` if it exists (a missing file is not an error).
  subroutine remove_file(path)
    character(len=*), intent(in) :: path
    integer(c_int) :: status
    status = c_unlink(path // c_null_char)
  end subroutine remove_file

  !> Whether a file can be written at `path`, found by doing it: an absent path is created and
  !> removed again; an existing one is opened for reading and writing and left as it was (a
  !> directory fails here too). `reason` is '' on success, else the system's message.
  subroutine probe_writable(path, reason)
    character(len=*), intent(in) :: path
    character(len=:), allocatable, intent(out) :: reason
    character(len=512) :: message
    integer :: unit, status
    logical :: exists
    inquire (file=path, exist=exists)
    if (exists) then
      open (newunit=unit, file=path, status='old', action='readwrite', access='stream', iostat=status, &
            iomsg=message)
      if (status == 0) close (unit)
    else
      open (newunit=unit, file=path, status='new', action='write', access='stream', iostat=status, &
            iomsg=message)
      if (status == 0) close (unit, status='delete')
    end if
    reason = ''
    if (status /= 0) reason = trim(message)
  end subroutine probe_writable
end module beadmob_file_system
