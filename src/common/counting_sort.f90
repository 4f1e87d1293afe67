!> A stable counting sort of positions by small integer keys, for grouping work that shares data
!> (kernel_spectrum.f90: octant points by canonical block; pfft_operator.F90: near pairs by
!> stencil offset).
module beadmob_counting_sort
  use beadmob_kinds, only: i8
  implicit none
  private
  public :: counting_sort

contains

  !> order: the positions 1 .. size(keys) sorted by their keys (0 .. n_keys), in their own order
  !> within a key; starts(k) is the first place of key k in order and starts(n_keys + 1) =
  !> size(keys) + 1, so key k's positions are order(starts(k) : starts(k + 1) - 1).
  pure subroutine counting_sort(keys, n_keys, order, starts)
    integer, intent(in) :: keys(:), n_keys
    integer(i8), intent(out) :: order(:)      ! size(keys)
    integer(i8), intent(out) :: starts(0:)    ! 0 .. n_keys + 1
    integer(i8), allocatable :: next(:)
    integer(i8) :: p
    integer :: k
    starts = 0
    do p = 1, size(keys, kind=i8)
      starts(keys(p) + 1) = starts(keys(p) + 1) + 1
    end do
    starts(0) = 1
    do k = 1, n_keys + 1
      starts(k) = starts(k) + starts(k - 1)
    end do
    allocate (next(0:n_keys))
    next(:) = starts(0:n_keys)
    do p = 1, size(keys, kind=i8)
      order(next(keys(p))) = p
      next(keys(p)) = next(keys(p)) + 1
    end do
  end subroutine counting_sort
end module beadmob_counting_sort
