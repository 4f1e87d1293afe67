!> Cell list of bead centres (cells of one bead diameter) for neighbour queries in
!> O(log N) each: beads are sorted by cell key, a cell is found by binary search.
!> Used for overlap detection and mirror-symmetry tests on any bead set, on or off the lattice.
module beadmob_spatial_index
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  implicit none
  private
  public :: spatial_index_t, build_spatial_index, beads_within, sort_keys, lower_bound

  !> Widest model span (in d) the int64 cell key can hold without overflow.
  real(dp), parameter :: max_span = 2.0e6_dp

  type :: spatial_index_t
    real(dp) :: origin(3) = 0.0_dp
    integer(i8) :: n_cells(3) = 0
    integer(i8), allocatable :: keys(:)    ! sorted cell keys
    integer(i8), allocatable :: order(:)   ! bead index of each sorted key
  end type spatial_index_t

contains

  subroutine build_spatial_index(centres, index, err)
    real(dp), intent(in) :: centres(:, :)
    type(spatial_index_t), intent(out) :: index
    type(error_t), intent(inout) :: err
    integer(i8) :: n, i
    real(dp) :: span(3)

    n = size(centres, 2, kind=i8)
    allocate (index%keys(n), index%order(n))
    if (n == 0) return
    index%origin = minval(centres, dim=2)
    span = maxval(centres, dim=2) - index%origin
    if (any(span > max_span)) then
      call raise(err, 'bead model spans more than 2e6 bead diameters; this is not a compact body')
      return
    end if
    index%n_cells = int(span, i8) + 1
    do i = 1, n
      index%keys(i) = cell_key(index, cell_of(index, centres(:, i)))
      index%order(i) = i
    end do
    call sort_keys(index%keys, index%order)
  end subroutine build_spatial_index

  pure function cell_of(index, point) result(cell)
    type(spatial_index_t), intent(in) :: index
    real(dp), intent(in) :: point(3)
    integer(i8) :: cell(3)
    cell = int(floor(point - index%origin), i8)
  end function cell_of

  pure integer(i8) function cell_key(index, cell)
    type(spatial_index_t), intent(in) :: index
    integer(i8), intent(in) :: cell(3)
    cell_key = cell(1) + index%n_cells(1) * (cell(2) + index%n_cells(2) * cell(3))
  end function cell_key

  !> Indices of the beads whose centre lies strictly closer than `radius` to `point`: the cells
  !> (of one d) that [point - radius, point + radius] meets, one binary search per row of them
  !> (a row's keys are consecutive).
  subroutine beads_within(index, centres, point, radius, found, n_found)
    type(spatial_index_t), intent(in) :: index
    real(dp), intent(in) :: centres(:, :), point(3), radius
    integer(i8), allocatable, intent(inout) :: found(:)
    integer(i8), intent(out) :: n_found
    integer(i8) :: low(3), high(3), k, bead, last_key, y, z
    integer(i8), allocatable :: grown(:)

    n_found = 0
    if (.not. allocated(found)) allocate (found(32))
    if (size(index%keys) == 0) return
    ! floor is monotone: a centre within radius lies in a cell between these (clamped to the grid).
    low = max(cell_of(index, point - radius), 0_i8)
    high = min(cell_of(index, point + radius), index%n_cells - 1)
    if (any(low > high)) return
    do z = low(3), high(3)
      do y = low(2), high(2)
        last_key = cell_key(index, [high(1), y, z])
        do k = lower_bound(index%keys, cell_key(index, [low(1), y, z])), size(index%keys, kind=i8)
          if (index%keys(k) > last_key) exit
          bead = index%order(k)
          if (norm2(centres(:, bead) - point) >= radius) cycle
          n_found = n_found + 1
          if (n_found > size(found)) then
            allocate (grown(2 * size(found)))
            grown(1:size(found)) = found
            call move_alloc(grown, found)
          end if
          found(n_found) = bead
        end do
      end do
    end do
  end subroutine beads_within

  !> First position whose key is >= target (size+1 if none).
  pure integer(i8) function lower_bound(keys, target)
    integer(i8), intent(in) :: keys(:), target
    integer(i8) :: low, high, middle
    low = 1
    high = size(keys, kind=i8) + 1
    do while (low < high)
      middle = (low + high) / 2
      if (keys(middle) < target) then
        low = middle + 1
      else
        high = middle
      end if
    end do
    lower_bound = low
  end function lower_bound

  !> Stable bottom-up merge sort of keys, carrying `order` along.
  subroutine sort_keys(keys, order)
    integer(i8), intent(inout) :: keys(:), order(:)
    integer(i8), allocatable :: key_buffer(:), order_buffer(:)
    integer(i8) :: n, width, left, middle, right, i, j, k

    n = size(keys, kind=i8)
    allocate (key_buffer(n), order_buffer(n))
    width = 1
    do while (width < n)
      left = 1
      do while (left <= n)
        middle = min(left + width, n + 1)
        right = min(left + 2 * width, n + 1)
        i = left
        j = middle
        do k = left, right - 1
          if (i < middle .and. (j >= right .or. keys(min(i, n)) <= keys(min(j, n)))) then
            key_buffer(k) = keys(i)
            order_buffer(k) = order(i)
            i = i + 1
          else
            key_buffer(k) = keys(j)
            order_buffer(k) = order(j)
            j = j + 1
          end if
        end do
        left = right
      end do
      keys = key_buffer
      order = order_buffer
      width = 2 * width
    end do
  end subroutine sort_keys
end module beadmob_spatial_index
