!> Real regular solid harmonics R_{n,k}(x) and their gradients, n <= nmax (docs/theory.md T1).
!> Complex R_n^m = r^n P_n^m(cos theta) e^{i m phi} / (n+m)! (Condon-Shortley phase) are built
!> by exact polynomial recurrences; with this normalisation Cartesian derivatives are ladder
!> shifts: d_z R_n^m = R_{n-1}^m, (d_x +- i d_y) R_n^m = +-R_{n-1}^{m+-1}.
!> Real basis: k = 0 -> R_n^0, k > 0 -> Re R_n^k, k < 0 -> Im R_n^|k|; flat index n*n + n + k.
module beadmob_solid_harmonics
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: solid_harmonics, harmonic_index, harmonic_count

contains

  pure integer function harmonic_index(n, k)
    integer, intent(in) :: n, k
    harmonic_index = n * n + n + k
  end function harmonic_index

  !> Number of real harmonics of degree 0..nmax.
  pure integer function harmonic_count(nmax)
    integer, intent(in) :: nmax
    harmonic_count = (nmax + 1)**2
  end function harmonic_count

  !> values(harmonic_index(n,k)) = R_{n,k}(x); gradients(:, idx) = grad R_{n,k}(x).
  pure subroutine solid_harmonics(x, nmax, values, gradients)
    real(dp), intent(in) :: x(3)
    integer, intent(in) :: nmax
    real(dp), intent(out) :: values(0:), gradients(:, 0:)
    complex(dp) :: table(-1:nmax, -nmax - 1:nmax + 1), xy, dx, dy, dz
    real(dp) :: r2
    integer :: n, m, k, idx
    complex(dp), parameter :: two_i = (0.0_dp, 2.0_dp)

    r2 = sum(x**2)
    xy = cmplx(x(1), x(2), dp)
    table = (0.0_dp, 0.0_dp)
    table(0, 0) = (1.0_dp, 0.0_dp)
    do m = 0, nmax
      if (m > 0) table(m, m) = -xy / (2 * m) * table(m - 1, m - 1)
      do n = m, nmax - 1
        table(n + 1, m) = ((2 * n + 1) * x(3) * table(n, m) - r2 * table(n - 1, m)) / real((n - m + 1) * (n + m + 1), dp)
      end do
    end do
    do n = 1, nmax
      do m = 1, n
        table(n, -m) = (-1)**m * conjg(table(n, m))
      end do
    end do

    do n = 0, nmax
      do k = -n, n
        idx = harmonic_index(n, k)
        m = abs(k)
        if (n == 0) then
          dx = 0; dy = 0; dz = 0
        else
          dz = table(n - 1, m)
          dx = 0.5_dp * (table(n - 1, m + 1) - table(n - 1, m - 1))
          dy = (table(n - 1, m + 1) + table(n - 1, m - 1)) / two_i
        end if
        if (k >= 0) then
          values(idx) = real(table(n, m), dp)
          gradients(:, idx) = [real(dx, dp), real(dy, dp), real(dz, dp)]
        else
          values(idx) = aimag(table(n, m))
          gradients(:, idx) = [aimag(dx), aimag(dy), aimag(dz)]
        end if
      end do
    end do
  end subroutine solid_harmonics
end module beadmob_solid_harmonics
