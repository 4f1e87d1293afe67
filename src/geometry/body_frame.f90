!> The body frame of the paper (settlers paper, section "Theoretical background"): origin at
!> the centre of mass (bead centroid, all beads identical), x and y normal to the two mirror
!> planes with x along the larger size, z the axis without mirror symmetry.
!> Mirror planes are detected from the beads, never assumed.
module beadmob_body_frame
  use beadmob_kinds, only: dp, i8
  use beadmob_lapack, only: dsyev
  use beadmob_errors, only: error_t
  use beadmob_vector_algebra, only: cross
  use beadmob_spatial_index, only: spatial_index_t, build_spatial_index, beads_within
  implicit none
  private
  public :: body_frame_t, compute_body_frame, is_mirror_symmetric, mirror_tolerance, spread_along

  !> A reflected bead centre must land within this distance (in d) of a bead.
  real(dp), parameter :: mirror_tolerance = 1.0e-6_dp

  type :: body_frame_t
    real(dp) :: centre_of_mass(3) = 0.0_dp
    !> axes(:, k) is body axis k (x, y, z) in model coordinates; a right-handed frame.
    real(dp) :: axes(3, 3) = 0.0_dp
    !> Size along each body axis: span of the bead centres plus one bead diameter.
    real(dp) :: extent(3) = 0.0_dp
    !> Mirror plane through the centre of mass normal to body axis k.
    logical :: mirror_plane(3) = .false.
    !> True when exactly the x and y planes are mirror planes: the paper's class of shapes.
    logical :: paper_class = .false.
  end type body_frame_t

contains

  subroutine compute_body_frame(centres, frame, err)
    real(dp), intent(in) :: centres(:, :)
    type(body_frame_t), intent(out) :: frame
    type(error_t), intent(inout) :: err
    type(spatial_index_t) :: index
    real(dp) :: candidates(3, 3), sizes(3)
    logical :: symmetric(3)
    integer :: k, z_axis, x_axis, others(2)

    frame%centre_of_mass = sum(centres, dim=2) / size(centres, 2)
    call build_spatial_index(centres, index, err)
    if (err%failed) return
    candidates = candidate_axes(centres, frame%centre_of_mass)
    do k = 1, 3
      symmetric(k) = is_mirror_symmetric(index, centres, frame%centre_of_mass, candidates(:, k))
      sizes(k) = extent_along(centres, candidates(:, k))
    end do

    ! z: the one axis without a mirror plane; when that is not unique keep the third candidate.
    z_axis = 3
    if (count(.not. symmetric) == 1) z_axis = findloc(symmetric, .false., dim=1)
    others = pack([1, 2, 3], [1, 2, 3] /= z_axis)
    x_axis = others(1)
    if (sizes(others(2)) > sizes(others(1)) * (1.0_dp + 1.0e-12_dp)) x_axis = others(2)

    frame%axes(:, 1) = candidates(:, x_axis)
    frame%axes(:, 3) = candidates(:, z_axis)
    frame%axes(:, 2) = cross(frame%axes(:, 3), frame%axes(:, 1))
    do k = 1, 3
      frame%extent(k) = extent_along(centres, frame%axes(:, k))
      frame%mirror_plane(k) = is_mirror_symmetric(index, centres, frame%centre_of_mass, frame%axes(:, k))
    end do
    frame%paper_class = frame%mirror_plane(1) .and. frame%mirror_plane(2) .and. .not. frame%mirror_plane(3)
  end subroutine compute_body_frame

  !> The coordinate axes when they are principal axes of the gyration tensor (always so for
  !> the lattice-aligned shapes built here), otherwise the principal axes themselves.
  function candidate_axes(centres, centre) result(axes)
    real(dp), intent(in) :: centres(:, :), centre(3)
    real(dp) :: axes(3, 3)
    real(dp) :: gyration(3, 3), eigenvalues(3), work(64), offset(3)
    integer(i8) :: i
    integer :: info, k

    gyration = 0.0_dp
    do i = 1, size(centres, 2, kind=i8)
      offset = centres(:, i) - centre
      gyration = gyration + spread(offset, 2, 3) * spread(offset, 1, 3)
    end do
    axes = 0.0_dp
    do k = 1, 3
      axes(k, k) = 1.0_dp
    end do
    if (max(abs(gyration(1, 2)), abs(gyration(1, 3)), abs(gyration(2, 3))) &
        <= 1.0e-10_dp * (gyration(1, 1) + gyration(2, 2) + gyration(3, 3))) return
    call dsyev('V', 'U', 3, gyration, 3, eigenvalues, work, size(work), info)
    if (info /= 0) return
    axes = gyration
    if (dot_product(cross(axes(:, 1), axes(:, 2)), axes(:, 3)) < 0.0_dp) axes(:, 3) = -axes(:, 3)
  end function candidate_axes

  !> True when reflecting every bead in the plane through `centre` normal to `normal`
  !> lands on a bead (within mirror_tolerance).
  logical function is_mirror_symmetric(index, centres, centre, normal)
    type(spatial_index_t), intent(in) :: index
    real(dp), intent(in) :: centres(:, :), centre(3), normal(3)
    integer(i8), allocatable :: found(:)
    integer(i8) :: i, n_found
    real(dp) :: image(3)

    is_mirror_symmetric = .false.
    do i = 1, size(centres, 2, kind=i8)
      image = centres(:, i) - 2.0_dp * dot_product(centres(:, i) - centre, normal) * normal
      call beads_within(index, centres, image, mirror_tolerance, found, n_found)
      if (n_found == 0) return
    end do
    is_mirror_symmetric = .true.
  end function is_mirror_symmetric

  !> A bead model's outer size along the unit vector axis (d): its centres' spread plus one bead.
  pure real(dp) function extent_along(centres, axis)
    real(dp), intent(in) :: centres(:, :), axis(3)
    extent_along = spread_along(centres, axis) + 1.0_dp
  end function extent_along

  !> The spread of the points' projections on the unit vector axis (max - min): of bead centres,
  !> or of a closed mesh's vertices, which is the mesh's extent (a polyhedron's extreme points
  !> are vertices).
  pure real(dp) function spread_along(points, axis)
    real(dp), intent(in) :: points(:, :), axis(3)
    real(dp) :: projection, low, high
    integer(i8) :: i
    low = huge(1.0_dp)
    high = -huge(1.0_dp)
    do i = 1, size(points, 2, kind=i8)
      projection = dot_product(axis, points(:, i))
      low = min(low, projection)
      high = max(high, projection)
    end do
    spread_along = high - low
  end function spread_along
end module beadmob_body_frame
