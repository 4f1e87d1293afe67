!> Plain-text bead files: one bead per line, "x y z" (spaces, tabs or commas between the
!> numbers), units of the bead diameter; '#' starts a comment; blank lines are skipped.
module beadmob_text_bead_file
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  implicit none
  private
  public :: read_text_bead_file

contains

  !> Reads all beads; `lines(i)` is the file line bead i came from (for messages).
  subroutine read_text_bead_file(path, centres, lines, err)
    character(len=*), intent(in) :: path
    real(dp), allocatable, intent(out) :: centres(:, :)
    integer, allocatable, intent(out) :: lines(:)
    type(error_t), intent(inout) :: err
    integer :: unit, status, line_number, n_beads, n_values, comment_at
    character(len=4096) :: line
    character(len=512) :: message
    real(dp) :: values(3)

    allocate (centres(3, 1024), lines(1024))
    n_beads = 0
    open (newunit=unit, file=path, status='old', action='read', iostat=status, iomsg=message)
    if (status /= 0) then
      call raise(err, "cannot open bead file '" // path // "': " // trim(message))
      call shrink(0)
      return
    end if
    line_number = 0
    do
      read (unit, '(a)', iostat=status, iomsg=message) line
      if (is_iostat_end(status)) exit
      line_number = line_number + 1
      if (status /= 0) then
        call raise(err, path // ' line ' // str(line_number) // ': ' // trim(message))
        exit
      end if
      comment_at = index(line, '#')
      if (comment_at > 0) line(comment_at:) = ''
      if (len_trim(line) == 0) cycle
      call parse_numbers(line, values, n_values, message)
      if (n_values /= 3) then
        call raise(err, path // ' line ' // str(line_number) // ': ' // trim(message) // ": '" // trim(line) // "'")
        exit
      end if
      n_beads = n_beads + 1
      if (n_beads > size(lines)) call grow()
      centres(:, n_beads) = values
      lines(n_beads) = line_number
    end do
    close (unit)
    call shrink(n_beads)
  contains
    subroutine grow()
      real(dp), allocatable :: bigger_centres(:, :)
      integer, allocatable :: bigger_lines(:)
      allocate (bigger_centres(3, 2 * size(lines)), bigger_lines(2 * size(lines)))
      bigger_centres(:, 1:size(lines)) = centres
      bigger_lines(1:size(lines)) = lines
      call move_alloc(bigger_centres, centres)
      call move_alloc(bigger_lines, lines)
    end subroutine grow
    subroutine shrink(n)
      integer, intent(in) :: n
      centres = centres(:, 1:n)
      lines = lines(1:n)
    end subroutine shrink
  end subroutine read_text_bead_file

  !> Splits on blanks/tabs/commas and reads each token as a real. n_values = 3 on success;
  !> otherwise `message` says what is wrong (NaN and Inf are read here and rejected later
  !> by the geometry checks, which name the bead).
  subroutine parse_numbers(line, values, n_values, message)
    character(len=*), intent(in) :: line
    real(dp), intent(out) :: values(3)
    integer, intent(out) :: n_values
    character(len=*), intent(out) :: message
    integer :: position, token_start, status, n_tokens
    character(len=*), parameter :: separators = ' ,' // achar(9)

    values = 0.0_dp
    n_values = 0
    n_tokens = 0
    message = ''
    position = 1
    do
      do while (position <= len_trim(line))
        if (index(separators, line(position:position)) == 0) exit
        position = position + 1
      end do
      if (position > len_trim(line)) exit
      token_start = position
      do while (position <= len_trim(line))
        if (index(separators, line(position:position)) > 0) exit
        position = position + 1
      end do
      n_tokens = n_tokens + 1
      if (n_tokens > 3) cycle
      read (line(token_start:position - 1), *, iostat=status) values(n_tokens)
      if (status /= 0) then
        message = "'" // line(token_start:position - 1) // "' is not a number"
        n_values = -1
        return
      end if
    end do
    if (n_tokens /= 3) then
      message = 'expected 3 numbers "x y z", found ' // str(n_tokens)
      n_values = n_tokens
      return
    end if
    n_values = 3
  end subroutine parse_numbers
end module beadmob_text_bead_file
