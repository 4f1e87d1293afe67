!> The bead operators by name: the one place that knows every implementation of
!> multipole_operator_t (job_plan.f90's choose_operator picks the name).
module beadmob_operator_catalog
  use beadmob_multipole_operator, only: multipole_operator_t
  use beadmob_bead_operator, only: bead_operator_t
  use beadmob_fft_operator, only: fft_operator_t
  use beadmob_pfft_operator, only: pfft_operator_t
  use beadmob_dense_operator, only: dense_operator_t
  use beadmob_replicated_operator, only: replicated_operator_t
  implicit none
  private
  public :: new_operator

contains

  !> An operator of the kind `name` ('direct', 'fft', 'pfft' or 'dense'; a checked name), not yet
  !> created; with `replicated`, that operator whole on every rank (replicated_operator.F90).
  recursive subroutine new_operator(name, op, replicated)
    character(len=*), intent(in) :: name
    class(multipole_operator_t), allocatable, intent(out) :: op
    logical, intent(in), optional :: replicated
    if (present(replicated)) then
      if (replicated) then
        allocate (replicated_operator_t :: op)
        select type (op)
        type is (replicated_operator_t)
          call new_operator(name, op%inner)
        end select
        return
      end if
    end if
    select case (name)
    case ('fft')
      allocate (fft_operator_t :: op)
    case ('pfft')
      allocate (pfft_operator_t :: op)
    case ('dense')
      allocate (dense_operator_t :: op)
    case default
      allocate (bead_operator_t :: op)
    end select
  end subroutine new_operator
end module beadmob_operator_catalog
