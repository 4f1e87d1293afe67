!> The stresslet of each bead at order L = 1 (theory.md T19). The order-1 basis holds a bead's force
!> and torque only, so a bead there has no strain density of its own. Each bead is then given the
!> stresslet a rigid sphere has in the flow it meets (Faxen's second law; Batchelor 1970, eq. 5.8):
!>   S_i = (20/3) pi eta a^3 [E_i - (1 + a^2 lap / 10) e_i(R_i)],
!> E_i the strain of its own surface (E_k in strain problem k, 0 for a rigid motion) and e_i the
!> strain of the Rotne-Prager-Yamakawa fields of the other beads' forces and torques (the
!> generalised RPY stresslet coupling of Wajnryb, Mizerski, Zuk & Szymczak, J. Fluid Mech. 731, R3
!> (2013), and of Zuk, Cichocki & Szymczak, J. Fluid Mech. 822, R2 (2017), taken to first order:
!> the beads' stresslets do not act back on the forces). Its work against strain E_k, summed over
!> the beads, is by the reciprocal theorem
!>   sum_i E_k : S_i = N s0 [problem is E_k] - sum_j (U_kj . F_j + Omega_kj . T_j),
!> with U_kj, Omega_kj the Faxen velocity and rotation at bead j of the fields of all other beads
!> whose surfaces have the strain E_k (stresslet_pattern_response): one pair sum for all problems.
!> Units: eta = 1, bead radius a = 1/2.
module beadmob_bead_stresslet
  use beadmob_kinds, only: dp, i8
  use beadmob_multipole_basis, only: bead_radius
  use beadmob_linear_flow, only: n_strain_modes, strain_mode
  implicit none
  private
  public :: bead_self_stresslet, strained_bead_motion, stresslet_pattern_response

  !> s0 = (20/3) pi eta a^3: a sphere's stresslet per unit strain (Einstein; Batchelor 1970).
  real(dp), parameter :: bead_self_stresslet = 20.0_dp / 3.0_dp * acos(-1.0_dp) * bead_radius**3

contains

  !> The Faxen velocity (1 + a^2 lap / 6) u and rotation (1/2) curl u at r from the centre of a bead
  !> whose surface has the strain `strain` (its field u = (1 + a^2 lap / 10) u_s, the stresslet
  !> field u_s = (5 a^3 / 2) (r . E . r) r / r^5, exactly a rigid sphere's in a strain, with the
  !> sign of a surface that moves as E . y). lap u_s = 5 a^3 grad(r . E . r / r^5) is a potential
  !> flow (no rotation, lap^2 u_s = 0), so (Kim & Karrila 1991, sections 2.4 and 3.3):
  !>   U = (5 a^3 / 2) [Q r / r^5 + (4 a^2 / 15) (4 E . r / r^5 - 10 Q r / r^7)],  Q = r . E . r,
  !>   Omega = (5 a^3 / 2) (E . r) x r / r^5.   Valid for |r| >= 2a (beads apart or touching).
  pure subroutine strained_bead_motion(strain, r, velocity, rotation)
    real(dp), intent(in) :: strain(3, 3), r(3)
    real(dp), intent(out) :: velocity(3), rotation(3)
    real(dp) :: er(3), q, r2, r5, scale
    r2 = sum(r**2)
    r5 = r2 * r2 * sqrt(r2)
    er = matmul(strain, r)
    q = dot_product(r, er)
    scale = 2.5_dp * bead_radius**3 / r5
    velocity = scale * (q * r + 4.0_dp * bead_radius**2 / 15.0_dp * (4.0_dp * er - 10.0_dp * q / r2 * r))
    rotation = scale * [er(2) * r(3) - er(3) * r(2), er(3) * r(1) - er(1) * r(3), er(1) * r(2) - er(2) * r(1)]
  end subroutine strained_bead_motion

  !> response(nb (i - 1) + 1 : nb i, k) = projection . (U_kj, Omega_kj) for this rank's beads
  !> j = first .. first + count - 1 (i = j - first + 1): the Galerkin projection on bead j's
  !> order-1 densities of the fields of all other beads with surface strain E_k (`projection`, nb x 6,
  !> as rigid_projection's). A direct pair sum, O(count N), for the order-1 job, whose operator holds
  !> no strain densities. strained_bead_motion is linear in E, so the pairs are summed once for
  !> all five modes, as moments of r = R_j - R_i:
  !>   U = (5 a^3 / 2) [E_ab sum w r_a r_b r + (16 a^2 / 15) E . sum r / r^5],  w = r^-5 - (8 a^2 / 3) r^-7,
  !>   Omega = (5 a^3 / 2) eps_pqs E_qa sum r_a r_s / r^5.
  pure subroutine stresslet_pattern_response(centres, first, count, projection, response)
    real(dp), intent(in) :: centres(:, :), projection(:, :)
    integer(i8), intent(in) :: first, count
    real(dp), intent(out) :: response(:, :)
    real(dp), parameter :: a2 = bead_radius**2, scale = 2.5_dp * bead_radius**3
    real(dp) :: third(3, 3, 3), second(3, 3), first_moment(3), r(3), r2, inverse5, w, strain(3, 3), es(3, 3)
    real(dp) :: motion(6, n_strain_modes)
    integer(i8) :: i, j
    integer :: k, a, b, c
    do j = first, first + count - 1
      third = 0.0_dp
      second = 0.0_dp
      first_moment = 0.0_dp
      do i = 1, size(centres, 2, kind=i8)
        if (i == j) cycle
        r = centres(:, j) - centres(:, i)
        r2 = sum(r**2)
        inverse5 = 1.0_dp / (r2 * r2 * sqrt(r2))
        w = inverse5 * (1.0_dp - 8.0_dp * a2 / (3.0_dp * r2))
        first_moment = first_moment + inverse5 * r
        do b = 1, 3   ! the upper triangles only: both moments are symmetric
          do a = 1, b
            second(a, b) = second(a, b) + inverse5 * r(a) * r(b)
            third(a, b, :) = third(a, b, :) + w * r(a) * r(b) * r
          end do
        end do
      end do
      do b = 1, 3
        do a = b + 1, 3
          second(a, b) = second(b, a)
          third(a, b, :) = third(b, a, :)
        end do
      end do
      do k = 1, n_strain_modes
        strain = strain_mode(k)
        do c = 1, 3
          motion(c, k) = scale * (sum(strain * third(:, :, c)) + 16.0_dp * a2 / 15.0_dp * dot_product(strain(c, :), first_moment))
        end do
        es = matmul(strain, second)   ! es(q, s) = E_qa sum r_a r_s / r^5
        motion(4:6, k) = scale * [es(2, 3) - es(3, 2), es(3, 1) - es(1, 3), es(1, 2) - es(2, 1)]
      end do
      response(size(projection, 1) * (j - first) + 1:size(projection, 1) * (j - first + 1), :) = matmul(projection, motion)
    end do
  end subroutine stresslet_pattern_response
end module beadmob_bead_stresslet
