!> Whether bead centres sit on the unit lattice (the paper's bead models: touching beads of
!> diameter d = 1 on a cubic lattice). Such models get the lattice's exact shortcuts: canonical
!> pair blocks, the FFT convolution, the shell model, lattice symmetries.
module beadmob_unit_lattice
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: lattice_tolerance, on_unit_lattice

  !> A centre within this distance (d) of a lattice point is on it (bead files hold rounded decimals).
  real(dp), parameter :: lattice_tolerance = 1.0e-9_dp

contains

  !> True when every centre is within lattice_tolerance of the unit lattice through the lowest corner.
  pure logical function on_unit_lattice(centres)
    real(dp), intent(in) :: centres(:, :)
    real(dp) :: corner(3)
    integer :: i
    corner = minval(centres, dim=2)
    on_unit_lattice = .true.
    do i = 1, size(centres, 2)
      if (any(abs(centres(:, i) - corner - anint(centres(:, i) - corner)) > lattice_tolerance)) then
        on_unit_lattice = .false.
        return
      end if
    end do
  end function on_unit_lattice
end module beadmob_unit_lattice
