!> The two POSIX file operations that make a written file appear whole or not at all: write to a
!> temporary name, then rename(2) it over the final one (atomic within a file system); remove the
!> temporary on failure. Used by the result file, the checkpoint and the table cache.
module beadmob_file_system
  use, intrinsic :: iso_c_binding, only: c_char, c_int, c_null_char
  implicit none
  private
  public :: rename_file, remove_file

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
end module beadmob_file_system
