!> Number-to-text conversion for messages and file attributes.
module beadmob_strings
  use beadmob_kinds, only: dp, i4, i8
  implicit none
  private
  public :: str

  interface str
    module procedure str_int4, str_int8, str_real, str_logical
  end interface str

contains

  pure function str_int4(value) result(text)
    integer(i4), intent(in) :: value
    character(len=:), allocatable :: text
    character(len=16) :: buffer
    write (buffer, '(i0)') value
    text = trim(buffer)
  end function str_int4

  pure function str_int8(value) result(text)
    integer(i8), intent(in) :: value
    character(len=:), allocatable :: text
    character(len=24) :: buffer
    write (buffer, '(i0)') value
    text = trim(buffer)
  end function str_int8

  !> Shortest general format that round-trips typical input values (g0 trims zeros).
  pure function str_real(value) result(text)
    real(dp), intent(in) :: value
    character(len=:), allocatable :: text
    character(len=40) :: buffer
    write (buffer, '(g0)') value
    text = trim(adjustl(buffer))
  end function str_real

  pure function str_logical(value) result(text)
    logical, intent(in) :: value
    character(len=:), allocatable :: text
    if (value) then
      text = 'true'
    else
      text = 'false'
    end if
  end function str_logical
end module beadmob_strings
