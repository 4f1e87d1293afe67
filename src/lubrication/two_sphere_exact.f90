!> Exact two-sphere resistance values for equal spheres (radius a, eta = 1) moving along or
!> rotating about their line of centres, as series in bispherical coordinates, cosh(alpha) =
!> r/(2a) (docs/theory.md T8). Independent of the multipole method: used as its reference.
module beadmob_two_sphere_exact
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: stimson_jeffery, stimson_jeffery_contact, maude_approach, jeffery_counter_rotation

contains

  !> Drag per sphere / (6 pi eta a U), both spheres translating with U along the line of centres:
  !> Stimson & Jeffery, Proc. R. Soc. A 111, 110 (1926); Happel & Brenner (1965) sec. 6.3:
  !> lambda = (4/3) sinh(al) sum n(n+1)/((2n-1)(2n+3)) [1 - (4 sinh^2((n+1/2)al) - (2n+1)^2 sinh^2 al)
  !>                                                   / (2 sinh((2n+1)al) + (2n+1) sinh(2 al))].
  !> r = centre distance (> 2a); at contact use stimson_jeffery_contact.
  pure real(dp) function stimson_jeffery(r, a) result(lambda)
    real(dp), intent(in) :: r, a
    real(dp) :: al, x, term, total, fraction
    integer :: n
    al = acosh(r / (2.0_dp * a))
    total = 0.0_dp
    do n = 1, 50000000
      x = (2 * n + 1) * al
      if (x > 600.0_dp) then
        fraction = 1.0_dp   ! 4 sinh^2(x/2) / (2 sinh x) -> 1; the rest is exponentially small
      else
        fraction = (4.0_dp * sinh(x / 2)**2 - (2 * n + 1)**2 * sinh(al)**2) / (2.0_dp * sinh(x) + (2 * n + 1) * sinh(2 * al))
      end if
      term = real(n, dp) * (n + 1) / (real(2 * n - 1, dp) * (2 * n + 3)) * (1.0_dp - fraction)
      total = total + term
      if (abs(term) < 1.0e-17_dp * abs(total) .and. n > 10) exit
    end do
    lambda = 4.0_dp / 3.0_dp * sinh(al) * total
  end function stimson_jeffery

  !> The contact limit of the Stimson-Jeffery series (0/0 at alpha = 0): the series at
  !> alpha = 0.02, 0.015, 0.01, 0.0075, 0.005 extrapolated to alpha = 0 by the cubic through
  !> least squares (the limit is regular in alpha). Literature: 0.645 (Stimson & Jeffery 1926).
  real(dp) function stimson_jeffery_contact(a) result(lambda)
    real(dp), intent(in) :: a
    real(dp), parameter :: alphas(5) = [0.02_dp, 0.015_dp, 0.01_dp, 0.0075_dp, 0.005_dp]
    real(dp) :: design(5, 4), values(5), work(64)
    integer :: i, info
    interface
      subroutine dgels(trans, m, n, nrhs, a, lda, b, ldb, work, lwork, info)
        import :: dp
        character, intent(in) :: trans
        integer, intent(in) :: m, n, nrhs, lda, ldb, lwork
        real(dp), intent(inout) :: a(lda, *), b(ldb, *), work(*)
        integer, intent(out) :: info
      end subroutine dgels
    end interface
    do i = 1, 5
      values(i) = stimson_jeffery(2.0_dp * a * cosh(alphas(i)), a)
      design(i, :) = alphas(i)**[0, 1, 2, 3]
    end do
    call dgels('N', 5, 4, 1, design, 5, values, 5, work, size(work), info)
    lambda = values(1)
  end function stimson_jeffery_contact

  !> Drag per sphere / (6 pi eta a U), spheres approaching each other along the line of centres
  !> with speeds U: Maude, Brit. J. Appl. Phys. 12, 293 (1961); Brenner, Chem. Eng. Sci. 16, 242
  !> (1961), two-sphere form (the mid-plane is a slip symmetry plane, not a wall):
  !> (4/3) sinh(al) sum n(n+1)/((2n-1)(2n+3)) [(4 cosh^2((n+1/2)al) + (2n+1)^2 sinh^2 al)
  !>                                          / (2 sinh((2n+1)al) - (2n+1) sinh(2 al)) - 1].
  pure real(dp) function maude_approach(r, a) result(lambda)
    real(dp), intent(in) :: r, a
    real(dp) :: al, x, term, total
    integer :: n
    al = acosh(r / (2.0_dp * a))
    total = 0.0_dp
    do n = 1, 10000000
      x = (2 * n + 1) * al
      if (x > 700.0_dp) exit
      term = real(n, dp) * (n + 1) / (real(2 * n - 1, dp) * (2 * n + 3)) &
             * ((4.0_dp * cosh(x / 2)**2 + (2 * n + 1)**2 * sinh(al)**2) / (2.0_dp * sinh(x) - (2 * n + 1) * sinh(2 * al)) &
                - 1.0_dp)
      total = total + term
      if (abs(term) < 1.0e-17_dp * abs(total)) exit
    end do
    lambda = 4.0_dp / 3.0_dp * sinh(al) * total
  end function maude_approach

  !> Torque per sphere / (8 pi eta a^3 Omega), spheres counter-rotating about the line of centres
  !> (the mid-plane is then a no-slip wall): Jeffery, Proc. Lond. Math. Soc. 14, 327 (1915),
  !> sphere rotating about the normal of a plane wall: sinh^3(al) sum_{n>=1} csch^3(n al).
  pure real(dp) function jeffery_counter_rotation(r, a) result(lambda)
    real(dp), intent(in) :: r, a
    real(dp) :: al, term, total
    integer :: n
    al = acosh(r / (2.0_dp * a))
    total = 0.0_dp
    do n = 1, 100000000
      term = 1.0_dp / sinh(n * al)**3
      total = total + term
      if (term < 1.0e-17_dp * total) exit
    end do
    lambda = sinh(al)**3 * total
  end function jeffery_counter_rotation
end module beadmob_two_sphere_exact
