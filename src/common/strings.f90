!> Number-to-text conversion for messages and file attributes.
module beadmob_strings
  use beadmob_kinds, only: dp, i4, i8
  implicit none
  private
  public :: str, str_approx, str_significant, either, lower_case

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
      if (buffer(1:1) == '.') buffer = '0' // buffer(:len(buffer) - 1)   ! the blank at its end makes room
      if (buffer(1:2) == '-.') buffer = '-0' // buffer(2:)
    end if
    text = trim(adjustl(buffer))
  end function str_approx

  !> `value` rounded to `digits` significant digits (1 to 17), written as C's and Python's
  !> "%.<digits>g": plain decimals for decimal exponents -4 to digits - 1, else 1.234e+05, trailing
  !> zeros dropped (0.08725, 1000, 1.5e-07; 0 for -0). For coordinates in messages, where str's
  !> round-trip form (0.87245000000000003E-1) is unreadable; the caller chooses the digits. (str
  !> itself stays: table cache keys and attributes are written with it.)
  pure function str_significant(value, digits) result(text)
    real(dp), intent(in) :: value
    integer, intent(in) :: digits
    character(len=:), allocatable :: text
    character(len=48) :: buffer, exponent_text
    character(len=24) :: form
    integer :: d, exponent, e_at
    if (value /= value) then
      text = 'NaN'
      return
    else if (abs(value) > huge(value)) then
      text = either(value > 0.0_dp, 'Inf', '-Inf')
      return
    else if (value == 0.0_dp) then
      text = '0'
      return
    end if
    d = min(max(digits, 1), 17)
    ! The decimal exponent after rounding to d digits (9.9996 at 4 digits: 1.000E+01); both writes
    ! round to nearest (rn), as C does, so they round alike.
    write (form, '(a, i0, a)') '(rn, es30.', d - 1, 'e4)'
    write (buffer, form) value
    e_at = index(buffer, 'E')
    read (buffer(e_at + 1:), *) exponent
    if (exponent < -4 .or. exponent >= d) then
      write (exponent_text, '(i0)') abs(exponent)
      if (abs(exponent) < 10) exponent_text = '0' // exponent_text(:len(exponent_text) - 1)   ! two digits at least, as C
      text = without_trailing_zeros(trim(adjustl(buffer(1:e_at - 1)))) // 'e' // either(exponent < 0, '-', '+') // &
             trim(adjustl(exponent_text))
    else
      write (form, '(a, i0, a)') '(rn, f40.', d - 1 - exponent, ')'
      write (buffer, form) value
      text = without_trailing_zeros(trim(adjustl(buffer)))
      if (text(1:1) == '.') text = '0' // text
      if (text(1:min(2, len(text))) == '-.') text = '-0' // text(2:)
    end if
  end function str_significant

  !> A decimal number without the zeros at the end of its fraction, nor a bare point (1.50 -> 1.5, 2. -> 2).
  pure function without_trailing_zeros(number) result(text)
    character(len=*), intent(in) :: number
    character(len=:), allocatable :: text
    integer :: last
    text = number
    if (index(text, '.') == 0) return
    last = len(text)
    do while (last > 1 .and. text(last:last) == '0')
      last = last - 1
    end do
    if (text(last:last) == '.') last = last - 1
    text = text(1:last)
  end function without_trailing_zeros

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

  !> `text` with A-Z turned to a-z (file extensions, keywords, in any case).
  pure function lower_case(text) result(lowered)
    character(len=*), intent(in) :: text
    character(len=len(text)) :: lowered
    integer :: k
    lowered = text
    do k = 1, len(text)
      if (text(k:k) >= 'A' .and. text(k:k) <= 'Z') lowered(k:k) = achar(iachar(text(k:k)) + 32)
    end do
  end function lower_case
end module beadmob_strings
