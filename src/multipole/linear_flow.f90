!> The ambient linear flow in the multipole system (theory.md T19): u0(r) = U0 + Omega0 x r + E0 . r
!> with E0 symmetric and traceless, E0 = sum_k e_k E_k over five orthonormal strain modes. A body
!> held still in the strain E_k sees on bead i the surface velocity -E_k . (R_i - R0) - E_k . y
!> (y from the bead centre): a translation of the bead plus the bead's own strain. Its Galerkin
!> right-hand side is the translation's projection plus that of E_k . y, which is the gradient of
!> the harmonic (1/2) y . E_k . y and so lies in the n = 2, sigma = 0 densities alone
!> (multipole_basis.f90; Cichocki et al., J. Chem. Phys. 100, 3780 (1994), section II).
module beadmob_linear_flow
  use beadmob_kinds, only: dp
  use beadmob_multipole_basis, only: multipole_basis_t, evaluate_densities, bead_radius
  use beadmob_quadrature, only: sphere_rule
  implicit none
  private
  public :: n_strain_modes, strain_mode, strain_velocity, strain_rotation, strain_projection

  integer, parameter :: n_strain_modes = 5

contains

  !> Strain mode k (3 x 3, symmetric, traceless, E_k : E_l = delta_kl):
  !> E1 = (xy + yx)/sqrt2, E2 = (xz + zx)/sqrt2, E3 = (yz + zy)/sqrt2, E4 = (xx - yy)/sqrt2,
  !> E5 = (2zz - xx - yy)/sqrt6. Shear u = gamma y e_x has E0 = gamma/sqrt2 E1, Omega0 = -gamma/2 e_z.
  pure function strain_mode(k) result(mode)
    integer, intent(in) :: k
    real(dp) :: mode(3, 3)
    real(dp), parameter :: s2 = 1.0_dp / sqrt(2.0_dp), s6 = 1.0_dp / sqrt(6.0_dp)
    mode = 0.0_dp
    select case (k)
    case (1)
      mode(1, 2) = s2
      mode(2, 1) = s2
    case (2)
      mode(1, 3) = s2
      mode(3, 1) = s2
    case (3)
      mode(2, 3) = s2
      mode(3, 2) = s2
    case (4)
      mode(1, 1) = s2
      mode(2, 2) = -s2
    case (5)
      mode(1, 1) = -s6
      mode(2, 2) = -s6
      mode(3, 3) = 2.0_dp * s6
    end select
  end function strain_mode

  !> E_k . arm: the velocity of strain mode k at `arm` from the reference point.
  pure function strain_velocity(k, arm) result(velocity)
    integer, intent(in) :: k
    real(dp), intent(in) :: arm(3)
    real(dp) :: velocity(3)
    velocity = matmul(strain_mode(k), arm)
  end function strain_velocity

  !> D(Q)_kl = E_k : (Q E_l Q^T): strain amplitudes of a frame turned by Q (columns: its axes in
  !> the other frame) in the other frame's modes, e = D e'. Orthogonal, as Q is.
  pure function strain_rotation(q) result(d)
    real(dp), intent(in) :: q(3, 3)
    real(dp) :: d(n_strain_modes, n_strain_modes)
    integer :: k, l
    do l = 1, n_strain_modes
      do k = 1, n_strain_modes
        d(k, l) = sum(strain_mode(k) * matmul(q, matmul(strain_mode(l), transpose(q))))
      end do
    end do
  end function strain_rotation

  !> projection(alpha, k) = int_S phi_alpha . (E_k . y) dS on one bead (y from its centre): the
  !> bead's own part of the strain's right-hand side. The integrand is a polynomial of the
  !> degree of rigid_projection's (pair_blocks.f90), so the same rule is exact. Zero in a basis
  !> without the n = 2, sigma = 0 densities (order 1): a bead then carries no stresslet.
  subroutine strain_projection(basis, projection)
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(out) :: projection(:, :)
    real(dp), allocatable :: points(:, :), weights(:), densities(:, :)
    integer :: p, k
    call sphere_rule([0.0_dp, 0.0_dp, 1.0_dp], bead_radius, basis%order + 4, 2 * basis%order + 6, points, weights)
    allocate (densities(3, basis%size))
    projection(:, 1:n_strain_modes) = 0.0_dp
    do p = 1, size(weights)
      call evaluate_densities(basis, points(:, p), densities)
      do k = 1, n_strain_modes
        projection(:, k) = projection(:, k) + weights(p) * matmul(strain_velocity(k, points(:, p)), densities)
      end do
    end do
  end subroutine strain_projection
end module beadmob_linear_flow
