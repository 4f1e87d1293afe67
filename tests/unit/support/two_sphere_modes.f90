!> Two-sphere resistance functions from the multipole method (test and benchmark helper): two
!> equal spheres on the z axis at centre distance r, in symmetric (both move alike) and
!> antisymmetric (opposite) modes, normalised by 6 pi eta a (translation), 8 pi eta a^3
!> (rotation) and their geometric mean (coupling Y^B), as in docs/theory.md T8.
module beadmob_two_sphere_modes
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t
  use beadmob_multipole_basis, only: multipole_basis_t, make_multipole_basis, bead_radius
  use beadmob_dense_friction, only: dense_friction
  implicit none
  private
  public :: two_sphere_functions, function_names, n_functions

  integer, parameter :: n_functions = 10
  character(len=*), parameter :: function_names(n_functions) = [character(len=7) :: 'XA_sym', 'XA_anti', 'XC_sym', &
    'XC_anti', 'YA_sym', 'YA_anti', 'YB_sym', 'YB_anti', 'YC_sym', 'YC_anti']

contains

  subroutine two_sphere_functions(r, order, potential_order, values, err)
    real(dp), intent(in) :: r
    integer, intent(in) :: order, potential_order
    real(dp), intent(out) :: values(n_functions)
    type(error_t), intent(inout) :: err
    real(dp), parameter :: pi = acos(-1.0_dp)
    real(dp) :: centres(3, 2), identity(12, 12), z0(12, 12), z1(12, 12), st, sr
    type(multipole_basis_t) :: basis
    integer :: k
    centres = reshape([0.0_dp, 0.0_dp, -r / 2, 0.0_dp, 0.0_dp, r / 2], [3, 2])
    identity = 0.0_dp
    do k = 1, 12
      identity(k, k) = 1.0_dp
    end do
    ! |k| = 0 holds the axial motions, |k| = 1 the transverse ones (exact for a pair on z).
    basis = make_multipole_basis(order, potential_order, [0])
    call dense_friction(basis, centres, identity, z0, err)
    basis = make_multipole_basis(order, potential_order, [1])
    call dense_friction(basis, centres, identity, z1, err)
    st = 6.0_dp * pi * bead_radius
    sr = 8.0_dp * pi * bead_radius**3
    ! Rows/columns: sphere 1 (U, W) = 1..6, sphere 2 = 7..12.
    values(1) = (z0(3, 3) + z0(3, 9)) / st
    values(2) = (z0(3, 3) - z0(3, 9)) / st
    values(3) = (z0(6, 6) + z0(6, 12)) / sr
    values(4) = (z0(6, 6) - z0(6, 12)) / sr
    values(5) = (z1(1, 1) + z1(1, 7)) / st
    values(6) = (z1(1, 1) - z1(1, 7)) / st
    values(7) = (z1(5, 1) + z1(5, 7)) / sqrt(st * sr)
    values(8) = (z1(5, 1) - z1(5, 7)) / sqrt(st * sr)
    values(9) = (z1(5, 5) + z1(5, 11)) / sr
    values(10) = (z1(5, 5) - z1(5, 11)) / sr
  end subroutine two_sphere_functions
end module beadmob_two_sphere_modes
