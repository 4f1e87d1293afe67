!> The extent along a direction of the body a shape stands for, not of one bead model of it. A
!> bead model's outer size (its centres' spread plus one d, body_frame.f90) lies up to d beyond
!> the body's and moves with the lattice: on a round-ended mesh at d = 1/30 of its length, 2.6 %
!> beyond it. A continuum job's coefficients take the body's as their length L, the limit of zero
!> bead size of theirs (docs/theory.md T18, "The coefficients' length").
module beadmob_body_extent
  use beadmob_kinds, only: dp
  use beadmob_input_config, only: shape_config_t, is_set
  implicit none
  private
  public :: continuous_extent

contains

  !> The extent of shape c's body along the unit vector `axis` (in the unit of c's lengths), as
  !> the sum of its support function h(e) + h(-e) in closed form, and whether the shape has one:
  !> the sphere, spheroid, box by box_size, cylinder and torus (simple_shapes.f90: each centred at
  !> the origin, its bead centres the lattice points inside it). A mesh's is its vertices' spread
  !> (body_frame.f90's spread_along); the paper's shapes and bead files have none here
  !> (known = .false.).
  subroutine continuous_extent(c, axis, extent, known)
    type(shape_config_t), intent(in) :: c
    real(dp), intent(in) :: axis(3)
    real(dp), intent(out) :: extent
    logical, intent(out) :: known
    real(dp) :: across   ! |e| in the xy plane (the cylinder's and torus's cross-section)

    extent = 0.0_dp
    known = .true.
    across = sqrt(max(0.0_dp, 1.0_dp - axis(3)**2))
    select case (trim(c%name))
    case ('sphere')
      extent = 2.0_dp * c%radius
    case ('spheroid')
      ! The ellipsoid's support function: sqrt(sum (a_i e_i)^2)
      extent = 2.0_dp * norm2(c%semi_axes * axis)
    case ('box')
      known = all(is_set(c%box_size))   ! by bead counts (box_beads) it is a bead model, no body
      if (known) extent = sum(c%box_size * abs(axis))
    case ('cylinder')
      ! Axis along z: the two rims' circles of radius R at z = +-length / 2
      extent = c%length * abs(axis(3)) + 2.0_dp * c%radius * across
    case ('torus')
      ! The centre circle (radius R in the xy plane) grown by the tube's radius r
      extent = 2.0_dp * (c%major_radius * across + c%minor_radius)
    case default
      known = .false.
    end select
  end subroutine continuous_extent
end module beadmob_body_extent
