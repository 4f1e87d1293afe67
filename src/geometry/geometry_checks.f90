!> Checks every bead model passes before any physics: not empty, finite coordinates,
!> no overlapping beads. Each failure names the bead(s) and, for bead files, the line.
module beadmob_geometry_checks
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_bead_model, only: bead_model_t, bead_label
  use beadmob_spatial_index, only: spatial_index_t, build_spatial_index, beads_within
  implicit none
  private
  public :: check_bead_model, default_overlap_tolerance

  !> Two beads overlap when their centre distance is below d * (1 - tolerance).
  real(dp), parameter :: default_overlap_tolerance = 1.0e-6_dp

contains

  subroutine check_bead_model(model, overlap_tolerance, err)
    type(bead_model_t), intent(in) :: model
    real(dp), intent(in) :: overlap_tolerance
    type(error_t), intent(inout) :: err

    if (model%n_beads() == 0) then
      call raise(err, 'the bead model is empty (' // model%source // ' gave no beads)')
      return
    end if
    call check_finite(model, err)
    if (err%failed) return
    call check_overlaps(model, overlap_tolerance, err)
  end subroutine check_bead_model

  subroutine check_finite(model, err)
    type(bead_model_t), intent(in) :: model
    type(error_t), intent(inout) :: err
    integer(i8) :: i
    integer :: k
    character(len=1), parameter :: axis_names(3) = ['x', 'y', 'z']
    do i = 1, model%n_beads()
      do k = 1, 3
        if (.not. ieee_is_finite(model%centres(k, i))) then
          call raise(err, bead_label(model, i) // ' has a non-finite coordinate ' // axis_names(k) // ' = ' // &
                     str(model%centres(k, i)))
          return
        end if
      end do
    end do
  end subroutine check_finite

  !> Reports the first overlapping pair (lowest indices) and how many pairs overlap.
  subroutine check_overlaps(model, tolerance, err)
    type(bead_model_t), intent(in) :: model
    real(dp), intent(in) :: tolerance
    type(error_t), intent(inout) :: err
    type(spatial_index_t) :: index
    integer(i8), allocatable :: found(:)
    integer(i8) :: i, k, n_found, n_pairs, first_i, first_j
    real(dp) :: limit

    call build_spatial_index(model%centres, index, err)
    if (err%failed) return
    limit = 1.0_dp - tolerance
    n_pairs = 0
    first_i = 0
    first_j = 0
    do i = 1, model%n_beads()
      call beads_within(index, model%centres, model%centres(:, i), limit, found, n_found)
      do k = 1, n_found
        if (found(k) <= i) cycle
        n_pairs = n_pairs + 1
        if (first_i == 0 .or. (i == first_i .and. found(k) < first_j)) then
          first_i = i
          first_j = found(k)
        end if
      end do
    end do
    if (n_pairs == 0) return
    call raise(err, 'overlapping beads: ' // bead_label(model, first_i) // ' and ' // bead_label(model, first_j) // &
               ' have centre distance ' // str(norm2(model%centres(:, first_i) - model%centres(:, first_j))) // &
               ' < 1 bead diameter (' // str(n_pairs) // ' overlapping pair(s) in all)')
  end subroutine check_overlaps
end module beadmob_geometry_checks
