!> The multipole basis of one bead (docs/theory.md T2, T3): induced surface force densities
!> phi_{n,sigma,k} on the sphere of radius a, L2-orthonormal, and the exterior Stokes velocity
!> field (single layer) each density produces. Families (Cichocki et al. 1994, sigma = 0, 1, 2):
!>   sigma = 0 : grad R_{n,k}(y)                 (n = 1: uniform density, the force)
!>   sigma = 1 : y x grad R_{n,k}(y)              (n = 1: rigid-rotation density, the torque)
!>   sigma = 2 : grad (R_{n,k}(y) / |y|^(2n+1))   (n = 1: potential dipole)
!> Truncation at order L: sigma = 0, 1 for n = 1..L, sigma = 2 for n = 1..L2 (default L2 = L - 2,
!> the same decay order r^-(L+1)... see T3; gives 2L(L+2) unknowns per bead for L <= 2).
!> Units: eta = 1, bead radius a = 1/2.
module beadmob_multipole_basis
  use beadmob_kinds, only: dp
  use beadmob_solid_harmonics, only: solid_harmonics, harmonic_index
  use beadmob_quadrature, only: sphere_rule
  implicit none
  private
  public :: multipole_basis_t, make_multipole_basis, basis_size, evaluate_densities, evaluate_fields, bead_radius, &
            inversion_parity

  real(dp), parameter :: bead_radius = 0.5_dp

  type :: multipole_basis_t
    integer :: order = 0            ! L
    integer :: potential_order = 0  ! L2 (highest degree of the sigma = 2 family)
    integer :: size = 0             ! unknowns per bead
    integer, allocatable :: degree(:), family(:), harmonic(:)   ! n, sigma, k of each function
    real(dp), allocatable :: inverse_norm(:)
    !> Exterior Lamb coefficients (c_P, c_Phi, c_chi) of each function's single-layer field,
    !> already divided by the norm of the density.
    real(dp), allocatable :: field_coefficients(:, :)
  end type multipole_basis_t

contains

  pure integer function basis_size(order, potential_order)
    integer, intent(in) :: order, potential_order
    basis_size = 2 * order * (order + 2) + potential_order * (potential_order + 2)
  end function basis_size

  !> Inversion parity of a density of degree n, family sigma, up to one sign common to all: the
  !> densities obey phi(-y) = q phi(y) with q = (-1)^(n-1) for sigma = 0, 2 and (-1)^n for
  !> sigma = 1 (grad R_n, y x grad R_n, grad I_n), and this returns p = -q (the force is "odd"
  !> in the FFT operator's slot order). Its single-layer field has the parity of the density, so a
  !> pair block obeys A(-d)_ab = q_a q_b A(d)_ab = p_a p_b A(d)_ab: only such products are used.
  pure integer function inversion_parity(n, sigma)
    integer, intent(in) :: n, sigma
    inversion_parity = merge(-1, 1, mod(n + merge(0, 1, sigma == 1), 2) == 1)
  end function inversion_parity

  !> The basis of order L with the sigma = 2 family up to degree L2. `azimuthal_orders`, when
  !> given, keeps only functions with |k| in that list (exact for pairs on the z axis, whose
  !> blocks do not couple different |k|: used for the two-sphere reference values).
  pure function make_multipole_basis(order, potential_order, azimuthal_orders) result(basis)
    integer, intent(in) :: order, potential_order
    integer, intent(in), optional :: azimuthal_orders(:)
    type(multipole_basis_t) :: basis
    integer :: n, sigma, k, count, p
    real(dp), allocatable :: points(:, :), weights(:), densities(:, :, :)

    basis%order = order
    basis%potential_order = potential_order
    ! (n, sigma, k) in the order n, sigma, k; at most 3 (2n + 1) per degree.
    allocate (basis%degree(3 * order * (order + 2)), basis%family(3 * order * (order + 2)), &
              basis%harmonic(3 * order * (order + 2)))
    count = 0
    do n = 1, order
      do sigma = 0, 2
        if (sigma == 2 .and. n > potential_order) cycle
        do k = -n, n
          if (present(azimuthal_orders)) then
            if (all(azimuthal_orders /= abs(k))) cycle
          end if
          count = count + 1
          basis%degree(count) = n
          basis%family(count) = sigma
          basis%harmonic(count) = k
        end do
      end do
    end do
    basis%size = count
    basis%degree = basis%degree(1:count)
    basis%family = basis%family(1:count)
    basis%harmonic = basis%harmonic(1:count)
    allocate (basis%inverse_norm(count), basis%field_coefficients(3, count))

    ! Norms by a rule exact for the degree-2(L+1) integrands |phi|^2.
    basis%inverse_norm = 1.0_dp
    call sphere_rule([0.0_dp, 0.0_dp, 1.0_dp], bead_radius, order + 4, 2 * order + 6, points, weights)
    allocate (densities(3, basis%size, size(weights)))
    do p = 1, size(weights)
      call evaluate_densities(basis, points(:, p), densities(:, :, p))
    end do
    do count = 1, basis%size
      basis%inverse_norm(count) = 1.0_dp / sqrt(sum(weights * sum(densities(:, count, :)**2, dim=1)))
      basis%field_coefficients(:, count) = single_layer_coefficients(basis%degree(count), basis%family(count)) &
                                           * basis%inverse_norm(count)
    end do
  end function make_multipole_basis

  !> Exterior Lamb coefficients (c_P, c_Phi, c_chi) of the single-layer field of the
  !> un-normalised density of degree n, family sigma, on a sphere of radius a (theory.md T2;
  !> derived from the jump conditions, checked against a numerical jump-problem solution).
  pure function single_layer_coefficients(n, sigma) result(c)
    integer, intent(in) :: n, sigma
    real(dp) :: c(3), a
    a = bead_radius
    c = 0.0_dp
    select case (sigma)
    case (0)
      c(1) = n * a**(2 * n)
      c(2) = n * a**(2 * n + 2) / (2.0_dp * (2 * n + 1))
    case (1)
      c(3) = -a**(2 * n + 2) / (2 * n + 1)
    case (2)
      c(2) = a * n / real((2 * n + 1) * (2 * n + 3), dp)
    end select
  end function single_layer_coefficients

  !> densities(:, alpha) = phi_alpha(y) (normalised), y relative to the bead centre.
  pure subroutine evaluate_densities(basis, y, densities)
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: y(3)
    real(dp), intent(out) :: densities(:, :)
    real(dp) :: values(0:(basis%order + 1)**2 - 1), gradients(3, 0:(basis%order + 1)**2 - 1), g(3), r2
    integer :: alpha, idx, n
    call solid_harmonics(y, basis%order, values, gradients)
    r2 = sum(y**2)
    do alpha = 1, basis%size
      n = basis%degree(alpha)
      idx = harmonic_index(n, basis%harmonic(alpha))
      g = gradients(:, idx)
      select case (basis%family(alpha))
      case (0)
        densities(:, alpha) = g
      case (1)
        densities(:, alpha) = [y(2) * g(3) - y(3) * g(2), y(3) * g(1) - y(1) * g(3), y(1) * g(2) - y(2) * g(1)]
      case default
        ! grad (R r^-(2n+1)) = r^-(2n+1) grad R - (2n+1) R r^-(2n+3) y
        densities(:, alpha) = (g - (2 * n + 1) * values(idx) / r2 * y) / r2**(n + 0.5_dp)
      end select
      densities(:, alpha) = densities(:, alpha) * basis%inverse_norm(alpha)
    end do
  end subroutine evaluate_densities

  !> fields(:, beta) = velocity at x (relative to the source bead centre, |x| >= a) of the
  !> single-layer field of the normalised density beta: a combination of Lamb's exterior fields
  !> on h = R_{n,k} / r^(2n+1) (Lamb 1932, Art. 335; theory.md T1):
  !>   P: A r^2 grad h + B x h,  Phi: grad h,  chi: grad h x x,
  !>   A = (2-n)/(2n(2n-1)), B = (n+1)/(n(2n-1)).
  pure subroutine evaluate_fields(basis, x, fields)
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: x(3)
    real(dp), intent(out) :: fields(:, :)
    real(dp) :: values(0:(basis%order + 1)**2 - 1), gradients(3, 0:(basis%order + 1)**2 - 1)
    real(dp) :: r2, scale, h, gh(3), lamb_a, lamb_b, c(3)
    integer :: beta, idx, n
    call solid_harmonics(x, basis%order, values, gradients)
    r2 = sum(x**2)
    do beta = 1, basis%size
      n = basis%degree(beta)
      idx = harmonic_index(n, basis%harmonic(beta))
      scale = r2**(-(n + 0.5_dp))
      h = values(idx) * scale
      gh = (gradients(:, idx) - (2 * n + 1) * values(idx) / r2 * x) * scale
      lamb_a = (2.0_dp - n) / (2.0_dp * n * (2 * n - 1))
      lamb_b = (n + 1.0_dp) / (n * (2 * n - 1))
      c = basis%field_coefficients(:, beta)
      fields(:, beta) = c(1) * (lamb_a * r2 * gh + lamb_b * h * x) + c(2) * gh &
                        + c(3) * [gh(2) * x(3) - gh(3) * x(2), gh(3) * x(1) - gh(1) * x(3), gh(1) * x(2) - gh(2) * x(1)]
    end do
  end subroutine evaluate_fields
end module beadmob_multipole_basis
