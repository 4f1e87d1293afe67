!> Number-to-text conversion for messages and file attributes.
module beadmob_strings
  use beadmob_kinds, only: dp, i4, i8
  implicit none
  private
  public :: str, str_approx, either

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

  !> Three significant digits, for sizes and times in messages (1.23e+09, 384, 0.0123).
  pure function str_approx(value) result(text)
    real(dp), intent(in) :: value
    character(len=:), allocatable :: text
    character(len=32) :: buffer
    if (abs(value) >= 1.0e5_dp .or. (abs(value) < 1.0e-2_dp .and. value /= 0.0_dp)) then
      write (buffer, '(es10.2)') value
    else if (abs(value) >= 100.0_dp) then
      write (buffer, '(f0.0)') value
      buffer = buffer(1:len_trim(buffer) - 1)   ! no trailing point
    else
      write (buffer, '(f0.2)') value
      if (buffer(1:1) == '.') buffer = '0' // buffer
      if (buffer(1:2) == '-.') buffer = '-0' // buffer(2:)
    end if
    text = trim(adjustl(buffer))
  end function str_approx

  pure function str_logical(value) result(text)
    logical, intent(in) :: value
    character(len=:), allocatable :: text
    if (value) then
      text = 'true'
    else
      text = 'false'
    end if
  end function str_logical
  !> if_true when condition holds, else if_false (texts of different lengths, unlike merge).
  pure function either(condition, if_true, if_false) result(text)
    logical, intent(in) :: condition
    character(len=*), intent(in) :: if_true, if_false
    character(len=:), allocatable :: text
    if (condition) then
      text = if_true
    else
      text = if_false
    end if
  end function either
end module beadmob_strings
