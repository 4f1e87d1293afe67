!> What Brownian motion does, read from the mobility and the flow's response (docs/theory.md T19,
!> docs/postprocessing.md, where beadmob-post derives the same with error bars and physical units).
!> Dimensionless: eta = kT = 1, lengths in d.
!>   centre of diffusion: the centre of mobility (Harvey & Garcia de la Torre, Macromolecules 13,
!>     960 (1980): the point about which the translation-rotation coupling is symmetric)
!>   D_t = tr(D_tt) / 3 there, the Stokes radius 1 / (6 pi D_t)
!>   D_1 <= D_2 <= D_3: the eigenvalues of D_rr, and the five l = 2 relaxation times 1 / (6D -+ 2 Delta),
!>     1 / (3 (D + D_i)), D the mean, Delta^2 = D1^2 + D2^2 + D3^2 - D1 D2 - D1 D3 - D2 D3 (Favro,
!>     Phys. Rev. 119, 53 (1960)); tau_h = 1 / (6 D)
!>   [eta] of eta_eff = eta (1 + [eta] phi): without rotary Brownian motion tr(T) / (10 V) (the
!>     isotropic average of the stresslet per strain T), and at zero shear that plus b . (-K)^-1 b /
!>     (10 V), b = sum_i G_i^T C_i, K = sum_ij D_ij G_j G_i, C the rotation per strain, G_i the
!>     generators of rotations on the strain amplitudes (beadmob_post/brownian.py derives it;
!>     Einstein's 5/2 and Simha's spheroid values are its tests)
module beadmob_brownian_numbers
  use beadmob_kinds, only: dp
  use beadmob_lapack, only: dsyev, dpotrf, dpotrs
  use beadmob_linear_flow, only: n_strain_modes, strain_mode
  implicit none
  private
  public :: brownian_numbers_t, brownian_numbers_of, intrinsic_viscosities

  real(dp), parameter :: pi = acos(-1.0_dp)

  type :: brownian_numbers_t
    logical :: available = .false.
    real(dp) :: centre_of_diffusion(3) = 0.0_dp
    real(dp) :: translational_diffusion = 0.0_dp, stokes_radius = 0.0_dp
    real(dp) :: rotational_diffusion(3) = 0.0_dp, rotational_axes(3, 3) = 0.0_dp   ! axes: columns
    real(dp) :: relaxation_times(5) = 0.0_dp, harmonic_mean_relaxation_time = 0.0_dp
    !> With the flow: [eta] without and with rotary Brownian motion, for the volume `volume`
    logical :: with_flow = .false.
    real(dp) :: volume = 0.0_dp, intrinsic_viscosity_high_frequency = 0.0_dp, intrinsic_viscosity_zero_shear = 0.0_dp
  end type brownian_numbers_t

contains

  !> From the mobility about the centre of mobility (6 x 6, rows U, Omega) and that centre.
  function brownian_numbers_of(mobility_at_centre, centre) result(numbers)
    real(dp), intent(in) :: mobility_at_centre(6, 6), centre(3)
    type(brownian_numbers_t) :: numbers
    real(dp) :: vectors(3, 3), values(3), work(64), mean, delta, rates(5)
    integer :: info
    numbers%centre_of_diffusion = centre
    numbers%translational_diffusion = (mobility_at_centre(1, 1) + mobility_at_centre(2, 2) + mobility_at_centre(3, 3)) / 3
    numbers%stokes_radius = 1.0_dp / (6.0_dp * pi * numbers%translational_diffusion)
    vectors = 0.5_dp * (mobility_at_centre(4:6, 4:6) + transpose(mobility_at_centre(4:6, 4:6)))
    call dsyev('V', 'U', 3, vectors, 3, values, work, size(work), info)
    numbers%available = info == 0 .and. all(values > 0.0_dp)
    if (.not. numbers%available) return
    numbers%rotational_diffusion = values
    numbers%rotational_axes = vectors
    mean = sum(values) / 3
    ! Delta without cancellation: half the sum of the squared differences
    delta = sqrt(0.5_dp * ((values(1) - values(2))**2 + (values(1) - values(3))**2 + (values(2) - values(3))**2))
    rates = [6 * mean + 2 * delta, 3 * (mean + values(3)), 3 * (mean + values(2)), 3 * (mean + values(1)), &
             6 * mean - 2 * delta]
    numbers%relaxation_times = 1.0_dp / rates   ! shortest first
    numbers%harmonic_mean_relaxation_time = 1.0_dp / (6.0_dp * mean)
  end function brownian_numbers_of

  !> [eta] without (high_frequency) and with (zero_shear) rotary Brownian motion, from the
  !> rotation per strain C (3 x 5), the stresslet per strain T and the rotational mobility D_rr
  !> (any frame, the same for all three), for the volume `volume` (module header).
  subroutine intrinsic_viscosities(rotation_per_strain, stresslet_per_strain, rotational_mobility, volume, &
                                   high_frequency, zero_shear)
    real(dp), intent(in) :: rotation_per_strain(3, n_strain_modes), stresslet_per_strain(n_strain_modes, n_strain_modes)
    real(dp), intent(in) :: rotational_mobility(3, 3), volume
    real(dp), intent(out) :: high_frequency, zero_shear
    real(dp) :: generators(n_strain_modes, n_strain_modes, 3), operator(n_strain_modes, n_strain_modes)
    real(dp) :: b(n_strain_modes), solved(n_strain_modes), d(3, 3), spin(3, 3)
    integer :: i, j, l, m, info
    high_frequency = 0.0_dp
    do m = 1, n_strain_modes
      high_frequency = high_frequency + stresslet_per_strain(m, m)
    end do
    high_frequency = high_frequency / (10.0_dp * volume)
    ! (G_i)_ml = E_m : (E_l [e_i]x - [e_i]x E_l): how the body-frame strain amplitudes turn.
    do i = 1, 3
      spin = 0.0_dp
      spin(modulo(i + 1, 3) + 1, modulo(i, 3) + 1) = 1.0_dp
      spin(modulo(i, 3) + 1, modulo(i + 1, 3) + 1) = -1.0_dp
      do l = 1, n_strain_modes
        do m = 1, n_strain_modes
          generators(m, l, i) = sum(strain_mode(m) * (matmul(strain_mode(l), spin) - matmul(spin, strain_mode(l))))
        end do
      end do
    end do
    b = 0.0_dp
    do i = 1, 3
      b = b + matmul(transpose(generators(:, :, i)), rotation_per_strain(i, :))
    end do
    d = 0.5_dp * (rotational_mobility + transpose(rotational_mobility))
    operator = 0.0_dp
    do i = 1, 3
      do j = 1, 3
        operator = operator - d(i, j) * matmul(generators(:, :, j), generators(:, :, i))
      end do
    end do
    ! -K is symmetric positive definite (its eigenvalues are the five relaxation rates).
    solved = b
    call dpotrf('L', n_strain_modes, operator, n_strain_modes, info)
    call dpotrs('L', n_strain_modes, 1, operator, n_strain_modes, solved, n_strain_modes, info)
    zero_shear = high_frequency + dot_product(b, solved) / (10.0_dp * volume)
  end subroutine intrinsic_viscosities
end module beadmob_brownian_numbers
