!> Test reference: the Rotne-Prager-Yamakawa grand mobility in closed form, which the multipole
!> method at order L = 1 without lubrication must reproduce (docs/theory.md T7): force and torque
!> per bead. Units: viscosity eta = 1, bead radius a = 1/2.
!> Per bead the unknowns are (F, T) and the velocities (U, Omega); a block maps the force and
!> torque of bead j to the velocity and angular velocity of bead i.
!> Formulas: Rotne & Prager, J. Chem. Phys. 50, 4831 (1969); Yamakawa, J. Chem. Phys. 53, 436
!> (1970); rotational blocks as in Wajnryb et al., J. Fluid Mech. 731, R3 (2013), eq. (2.4)-(2.7)
!> for non-overlapping spheres.
module beadmob_rpy_reference
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: rpy_self_block, rpy_pair_block, bead_radius, rpy_block_size

  real(dp), parameter :: pi = acos(-1.0_dp)
  real(dp), parameter :: bead_radius = 0.5_dp
  integer, parameter :: rpy_block_size = 6

contains

  !> Single sphere: U = F / (6 pi eta a), Omega = T / (8 pi eta a^3) (Stokes, Kirchhoff).
  pure subroutine rpy_self_block(block)
    real(dp), intent(out) :: block(:, :)
    integer :: k
    block = 0.0_dp
    do k = 1, 3
      block(k, k) = 1.0_dp / (6.0_dp * pi * bead_radius)
      block(k + 3, k + 3) = 1.0_dp / (8.0_dp * pi * bead_radius**3)
    end do
  end subroutine rpy_self_block

  !> Pair block for r = r_i - r_j, |r| >= 2a (touching or apart).
  pure subroutine rpy_pair_block(r, block)
    real(dp), intent(in) :: r(3)
    real(dp), intent(out) :: block(:, :)
    real(dp) :: distance, unit(3), outer(3, 3), identity(3, 3), cross_matrix(3, 3), a2
    integer :: k
    distance = norm2(r)
    unit = r / distance
    a2 = bead_radius**2
    identity = 0.0_dp
    do k = 1, 3
      identity(k, k) = 1.0_dp
    end do
    outer = spread(unit, 2, 3) * spread(unit, 1, 3)
    ! [unit]_x v = unit x v
    cross_matrix = reshape([0.0_dp, unit(3), -unit(2), -unit(3), 0.0_dp, unit(1), unit(2), -unit(1), 0.0_dp], [3, 3])
    ! Translation from force: Stokeslet plus the a^2 Laplacian (Faxen) correction.
    block(1:3, 1:3) = ((1.0_dp + 2.0_dp * a2 / (3.0_dp * distance**2)) * identity &
                       + (1.0_dp - 2.0_dp * a2 / distance**2) * outer) / (8.0_dp * pi * distance)
    ! Rotation from force and translation from torque: the rotlet, Omega_i = F_j x r / (8 pi r^3).
    block(4:6, 1:3) = -cross_matrix / (8.0_dp * pi * distance**2)
    block(1:3, 4:6) = -cross_matrix / (8.0_dp * pi * distance**2)
    ! Rotation from torque: the rotlet dipole.
    block(4:6, 4:6) = -(identity - 3.0_dp * outer) / (16.0_dp * pi * distance**3)
  end subroutine rpy_pair_block
end module beadmob_rpy_reference
