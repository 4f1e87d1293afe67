!> Simple bead models for validation and convergence studies (single bead, pair, chain,
!> lattice sphere, spheroid, box, torus). Sizes are in units of the bead diameter d = 1.
!> Lattice shapes use the integer cubic lattice with a node at the origin; positions are
!> returned as built (not recentred). A lattice node exactly on the surface is kept: the
!> inside tests accept a relative excess of boundary_tolerance (1e-9), so that points that
!> are on the surface in exact arithmetic (e.g. (2,0,0) for a sphere of radius 2) are kept
!> whatever the rounding.
!> On invalid parameters the builders call raise() and return centres of shape (3, 0).
module beadmob_simple_shapes
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_size_checks, only: positive_size
  use beadmob_lattice_fill, only: lattice_nodes_inside, boundary_tolerance, reserve_sites, lattice_shift
  implicit none
  private
  public :: build_single_bead, build_bead_pair, build_chain, build_filled_sphere
  public :: build_spheroid, build_box, build_torus, build_solid_box, build_cylinder


contains

  !> One bead at the origin.
  subroutine build_single_bead(centres, err)
    real(dp), allocatable, intent(out) :: centres(:, :)
    type(error_t), intent(inout) :: err
    allocate (centres(3, 1))
    centres = 0.0_dp
    if (err%failed) return  ! nothing can go wrong here; err is kept for a uniform interface
  end subroutine build_single_bead

  !> Two beads on the x axis at (0,0,0) and (separation,0,0); touching when separation = 1.
  subroutine build_bead_pair(separation, centres, err)
    real(dp), intent(in) :: separation
    real(dp), allocatable, intent(out) :: centres(:, :)
    type(error_t), intent(inout) :: err
    allocate (centres(3, 0))
    if (.not. ieee_is_finite(separation)) then
      call raise(err, 'bead_pair: separation must be finite, got ' // str(separation))
      return
    end if
    if (separation < 1.0_dp) then
      call raise(err, 'bead_pair: separation must be >= 1 (beads may not overlap), got ' &
                 // str(separation))
      return
    end if
    deallocate (centres)
    allocate (centres(3, 2))
    centres = 0.0_dp
    centres(1, 2) = separation
  end subroutine build_bead_pair

  !> n_beads touching beads along x at x = 0, 1, ..., n_beads - 1.
  subroutine build_chain(n_beads, centres, err)
    integer, intent(in) :: n_beads
    real(dp), allocatable, intent(out) :: centres(:, :)
    type(error_t), intent(inout) :: err
    integer :: i
    if (n_beads < 1) then
      allocate (centres(3, 0))
      call raise(err, 'chain: n_beads must be positive, got ' // str(n_beads))
      return
    end if
    call reserve_sites([n_beads, 1, 1], 'chain', centres, err)
    if (err%failed) return
    centres = 0.0_dp
    do i = 1, n_beads
      centres(1, i) = real(i - 1, dp)
    end do
  end subroutine build_chain

  !> All lattice points with |r| <= radius (node at the origin; `offset`: lattice_nodes_inside).
  subroutine build_filled_sphere(radius, centres, err, offset)
    real(dp), intent(in) :: radius
    real(dp), allocatable, intent(out) :: centres(:, :)
    real(dp), intent(in), optional :: offset(3)
    type(error_t), intent(inout) :: err
    if (.not. positive_size(radius, 'filled_sphere: radius', err)) then
      allocate (centres(3, 0))
      return
    end if
    call build_spheroid([radius, radius, radius], centres, err, offset)
  end subroutine build_filled_sphere

  !> All lattice points with sum_i (x_i / a_i)**2 <= 1 (node at the origin; `offset`:
  !> lattice_nodes_inside).
  subroutine build_spheroid(semi_axes, centres, err, offset)
    real(dp), intent(in) :: semi_axes(3)
    real(dp), allocatable, intent(out) :: centres(:, :)
    real(dp), intent(in), optional :: offset(3)
    type(error_t), intent(inout) :: err
    integer :: n(3), i
    do i = 1, 3
      if (.not. positive_size(semi_axes(i), 'spheroid: semi_axes(' // str(i) // ')', err)) then
        allocate (centres(3, 0))
        return
      end if
    end do
    n = floor(semi_axes * (1.0_dp + boundary_tolerance))
    call lattice_nodes_inside(-n, n, inside_spheroid, 'spheroid', lattice_shift(offset), centres, err)
  contains
    logical function inside_spheroid(node)
      real(dp), intent(in) :: node(3)
      inside_spheroid = sum((node / semi_axes)**2) <= 1.0_dp + boundary_tolerance
    end function inside_spheroid
  end subroutine build_spheroid

  !> A rectangular block of n_x * n_y * n_z beads at (i, j, k), 0 <= i < n_x, etc.
  subroutine build_box(n_x, n_y, n_z, centres, err)
    integer, intent(in) :: n_x, n_y, n_z
    real(dp), allocatable, intent(out) :: centres(:, :)
    type(error_t), intent(inout) :: err
    integer :: i, j, k, count
    if (min(n_x, n_y, n_z) < 1) then
      allocate (centres(3, 0))
      call raise(err, 'box: n_x, n_y, n_z must be positive, got ' // str(n_x) // ', ' &
                 // str(n_y) // ', ' // str(n_z))
      return
    end if
    call reserve_sites([n_x, n_y, n_z], 'box', centres, err)
    if (err%failed) return
    count = 0
    do k = 0, n_z - 1
      do j = 0, n_y - 1
        do i = 0, n_x - 1
          count = count + 1
          centres(:, count) = [real(i, dp), real(j, dp), real(k, dp)]
        end do
      end do
    end do
  end subroutine build_box

  !> Lattice points (`offset`: lattice_nodes_inside) within minor_radius of the circle of radius major_radius in the xy plane
  !> centred at the origin (axis z): (sqrt(x**2 + y**2) - major_radius)**2 + z**2 <= minor**2.
  !> minor_radius > major_radius (a spindle torus) is allowed: the same distance test applies.
  subroutine build_torus(major_radius, minor_radius, centres, err, offset)
    real(dp), intent(in) :: major_radius, minor_radius
    real(dp), allocatable, intent(out) :: centres(:, :)
    real(dp), intent(in), optional :: offset(3)
    type(error_t), intent(inout) :: err
    integer :: n_xy, n_z
    if (.not. positive_size(major_radius, 'torus: major_radius', err)) then
      allocate (centres(3, 0))
      return
    end if
    if (.not. positive_size(minor_radius, 'torus: minor_radius', err)) then
      allocate (centres(3, 0))
      return
    end if
    n_xy = floor((major_radius + minor_radius) * (1.0_dp + boundary_tolerance))
    n_z = floor(minor_radius * (1.0_dp + boundary_tolerance))
    call lattice_nodes_inside([-n_xy, -n_xy, -n_z], [n_xy, n_xy, n_z], inside_torus, 'torus', lattice_shift(offset), &
                              centres, err)
  contains
    logical function inside_torus(node)
      real(dp), intent(in) :: node(3)
      inside_torus = (sqrt(node(1)**2 + node(2)**2) - major_radius)**2 + node(3)**2 &
                     <= minor_radius**2 * (1.0_dp + boundary_tolerance)
    end function inside_torus
  end subroutine build_torus

  !> Lattice points of the box |x| <= sizes(1) / 2, |y| <= sizes(2) / 2, |z| <= sizes(3) / 2
  !> (centred on a node; `offset`: lattice_nodes_inside): a box in physical units.
  subroutine build_solid_box(sizes, centres, err, offset)
    real(dp), intent(in) :: sizes(3)
    real(dp), allocatable, intent(out) :: centres(:, :)
    type(error_t), intent(inout) :: err
    real(dp), intent(in), optional :: offset(3)
    integer :: n(3), i
    do i = 1, 3
      if (.not. positive_size(sizes(i), 'box: box_size(' // str(i) // ')', err)) then
        allocate (centres(3, 0))
        return
      end if
    end do
    n = floor(0.5_dp * sizes * (1.0_dp + boundary_tolerance))
    call lattice_nodes_inside(-n, n, inside_box, 'box', lattice_shift(offset), centres, err)
  contains
    logical function inside_box(node)
      real(dp), intent(in) :: node(3)
      inside_box = all(abs(node) <= 0.5_dp * sizes * (1.0_dp + boundary_tolerance))
    end function inside_box
  end subroutine build_solid_box

  !> Lattice points of the circular cylinder x^2 + y^2 <= radius^2, |z| <= length / 2 (axis z,
  !> centred on a node; `offset`: lattice_nodes_inside).
  subroutine build_cylinder(radius, length, centres, err, offset)
    real(dp), intent(in) :: radius, length
    real(dp), allocatable, intent(out) :: centres(:, :)
    type(error_t), intent(inout) :: err
    real(dp), intent(in), optional :: offset(3)
    integer :: n_r, n_z
    allocate (centres(3, 0))
    if (.not. positive_size(radius, 'cylinder: radius', err)) return
    if (.not. positive_size(length, 'cylinder: length', err)) return
    n_r = floor(radius * (1.0_dp + boundary_tolerance))
    n_z = floor(0.5_dp * length * (1.0_dp + boundary_tolerance))
    call lattice_nodes_inside([-n_r, -n_r, -n_z], [n_r, n_r, n_z], inside_cylinder, 'cylinder', lattice_shift(offset), &
                              centres, err)
  contains
    logical function inside_cylinder(node)
      real(dp), intent(in) :: node(3)
      inside_cylinder = node(1)**2 + node(2)**2 <= radius**2 * (1.0_dp + boundary_tolerance) .and. &
                        abs(node(3)) <= 0.5_dp * length * (1.0_dp + boundary_tolerance)
    end function inside_cylinder
  end subroutine build_cylinder
end module beadmob_simple_shapes
