!> A rigid bead model: the bead centres (units of the bead diameter d = 1) and a record
!> of how they were made (shape name, parameters, source), carried into the output file.
module beadmob_bead_model
  use beadmob_kinds, only: dp, i8
  implicit none
  private
  public :: bead_model_t, shape_parameter_t, add_parameter, bead_label, parameter_name_length

  integer, parameter :: parameter_name_length = 32

  type :: shape_parameter_t
    character(len=parameter_name_length) :: name = ''
    real(dp) :: value = 0.0_dp
  end type shape_parameter_t

  type :: bead_model_t
    !> Shape name as given in the input (e.g. 'cone', 'bead_file').
    character(len=:), allocatable :: shape_name
    !> Where the beads came from: 'built-in shape' or the bead file path.
    character(len=:), allocatable :: source
    !> Parameters the shape was built with, in the order they were given.
    type(shape_parameter_t), allocatable :: parameters(:)
    !> Length L that makes the mobilities dimensionless (paper, eq. matrices), in units of d.
    real(dp) :: reference_length = 0.0_dp
    !> Bead centres, shape (3, n_beads).
    real(dp), allocatable :: centres(:, :)
    !> Line of the bead file each bead came from (empty when built in), for error messages.
    integer, allocatable :: source_lines(:)
  contains
    procedure :: n_beads
  end type bead_model_t

contains

  pure integer(i8) function n_beads(self)
    class(bead_model_t), intent(in) :: self
    n_beads = 0
    if (allocated(self%centres)) n_beads = size(self%centres, 2, kind=i8)
  end function n_beads

  subroutine add_parameter(model, name, value)
    type(bead_model_t), intent(inout) :: model
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: value
    type(shape_parameter_t), allocatable :: grown(:)
    if (.not. allocated(model%parameters)) allocate (model%parameters(0))
    allocate (grown(size(model%parameters) + 1))
    grown(1:size(model%parameters)) = model%parameters
    grown(size(grown)) = shape_parameter_t(name, value)
    call move_alloc(grown, model%parameters)
  end subroutine add_parameter

  !> 'bead 12' or 'bead 12 (beads.txt line 15)': how messages name a bead.
  function bead_label(model, index) result(label)
    type(bead_model_t), intent(in) :: model
    integer(i8), intent(in) :: index
    character(len=:), allocatable :: label
    character(len=24) :: number
    write (number, '(i0)') index
    label = 'bead ' // trim(number)
    if (allocated(model%source_lines) .and. allocated(model%source)) then
      if (size(model%source_lines) >= index) then
        write (number, '(i0)') model%source_lines(index)
        label = label // ' (' // model%source // ' line ' // trim(number) // ')'
      end if
    end if
  end function bead_label
end module beadmob_bead_model
