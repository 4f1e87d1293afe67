!> The free body in an ambient linear flow (theory.md T19) from its grand resistance G about the
!> reference point R0 (rows and columns: U_x..W_z, E_1..E_5; G_mn = c_m . A^-1 c_n, the Galerkin
!> form of Kim & Karrila, Microhydrodynamics (1991), sections 5.1-5.2):
!>   force and torque on the fluid   F = G_UU v - G_UE e,   v = (U - u0(R0), Omega - Omega0)
!>   stresslet (Batchelor 1970)      s = G_EE e - G_EU v    (the first moment of the traction the
!>                                                          fluid exerts on the body, amplitudes)
!> A force- and torque-free body: v = zeta^-1 G_UE e (velocity_per_strain), and s = (G_EE - G_EU
!> zeta^-1 G_UE) e (stresslet_per_strain, the Schur complement: symmetric, positive definite).
!> A sphere of radius a: v = 0, s = (20/3) pi eta a^3 e (Einstein; Batchelor 1970, eq. 5.8).
!> The error bar of each entry is its change from the companion of order L - 1 (theory.md T14).
module beadmob_flow_response
  use beadmob_kinds, only: dp
  use beadmob_lapack, only: dpotrf, dpotrs
  use beadmob_linear_flow, only: n_strain_modes
  implicit none
  private
  public :: flow_response_t, free_body_response, flow_response_of

  type :: flow_response_t
    logical :: available = .false.
    real(dp) :: velocity_per_strain(6, n_strain_modes) = 0.0_dp
    real(dp) :: stresslet_per_strain(n_strain_modes, n_strain_modes) = 0.0_dp
    !> The body held still (v = 0): s = G_EE e
    real(dp) :: held_stresslet_per_strain(n_strain_modes, n_strain_modes) = 0.0_dp
    !> |s - s^T| / |s| of the Schur complement before it is made symmetric: rounding at order L >= 2;
    !> at order 1 what the beads' own stresslets add by rows only (bead_stresslet.f90, theory.md T19)
    real(dp) :: stresslet_asymmetry = 0.0_dp
    !> The companion's values and |order L - companion| (the bar); companion_order 0: none
    integer :: companion_order = 0
    real(dp) :: companion_velocity_per_strain(6, n_strain_modes) = 0.0_dp
    real(dp) :: companion_stresslet_per_strain(n_strain_modes, n_strain_modes) = 0.0_dp
    real(dp) :: velocity_per_strain_error(6, n_strain_modes) = 0.0_dp
    real(dp) :: stresslet_per_strain_error(n_strain_modes, n_strain_modes) = 0.0_dp
  end type flow_response_t

contains

  !> The free body's velocity and stresslet per unit strain amplitude from the grand resistance.
  !> ok = .false. when the friction block is not positive definite (then both are zero).
  !> `asymmetry`: |s - s^T| / |s| before s is made symmetric.
  pure subroutine free_body_response(grand, velocity_per_strain, stresslet_per_strain, ok, asymmetry)
    real(dp), intent(in) :: grand(6 + n_strain_modes, 6 + n_strain_modes)
    real(dp), intent(out) :: velocity_per_strain(6, n_strain_modes), stresslet_per_strain(n_strain_modes, n_strain_modes)
    logical, intent(out) :: ok
    real(dp), intent(out), optional :: asymmetry
    real(dp) :: factor(6, 6)
    integer :: info
    if (present(asymmetry)) asymmetry = 0.0_dp
    factor = grand(1:6, 1:6)
    velocity_per_strain = grand(1:6, 7:)
    stresslet_per_strain = 0.0_dp
    call dpotrf('L', 6, factor, 6, info)
    ok = info == 0
    if (.not. ok) then
      velocity_per_strain = 0.0_dp
      return
    end if
    call dpotrs('L', 6, n_strain_modes, factor, 6, velocity_per_strain, 6, info)
    stresslet_per_strain = grand(7:, 7:) - matmul(grand(7:, 1:6), velocity_per_strain)
    if (present(asymmetry)) asymmetry = norm2(stresslet_per_strain - transpose(stresslet_per_strain)) / &
                                        max(norm2(stresslet_per_strain), tiny(1.0_dp))
    stresslet_per_strain = 0.5_dp * (stresslet_per_strain + transpose(stresslet_per_strain))
  end subroutine free_body_response

  !> The response of order L (grand) and, with companion_order > 0, its bar from the companion's.
  pure function flow_response_of(grand, companion_grand, companion_order) result(response)
    real(dp), intent(in) :: grand(6 + n_strain_modes, 6 + n_strain_modes)
    real(dp), intent(in) :: companion_grand(6 + n_strain_modes, 6 + n_strain_modes)
    integer, intent(in) :: companion_order
    type(flow_response_t) :: response
    logical :: ok
    call free_body_response(grand, response%velocity_per_strain, response%stresslet_per_strain, ok, &
                            response%stresslet_asymmetry)
    response%available = ok
    response%held_stresslet_per_strain = grand(7:, 7:)
    if (.not. ok .or. companion_order <= 0) return
    call free_body_response(companion_grand, response%companion_velocity_per_strain, &
                            response%companion_stresslet_per_strain, ok)
    if (.not. ok) return
    response%companion_order = companion_order
    response%velocity_per_strain_error = abs(response%velocity_per_strain - response%companion_velocity_per_strain)
    response%stresslet_per_strain_error = abs(response%stresslet_per_strain - response%companion_stresslet_per_strain)
  end function flow_response_of
end module beadmob_flow_response
