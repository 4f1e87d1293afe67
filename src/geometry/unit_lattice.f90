!> Whether bead centres sit on the unit lattice (the paper's bead models: touching beads of
!> diameter d = 1 on a cubic lattice). Such models get the lattice's exact shortcuts: canonical
!> pair blocks, the FFT convolution, the shell model, lattice symmetries.
module beadmob_unit_lattice
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: lattice_tolerance, on_unit_lattice, lattice_mirrors

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

  !> The lattice axes along which the bead set (integer coordinates 0 .. span) is its own mirror
  !> image.
  function lattice_mirrors(lattice, span) result(mirrored)
    integer, intent(in) :: lattice(:, :), span(3)
    logical :: mirrored(3)
    logical, allocatable :: occupied(:, :, :)
    integer :: a, i, l(3)
    allocate (occupied(0:span(1), 0:span(2), 0:span(3)))
    occupied = .false.
    do i = 1, size(lattice, 2)
      occupied(lattice(1, i), lattice(2, i), lattice(3, i)) = .true.
    end do
    do a = 1, 3
      mirrored(a) = .true.
      do i = 1, size(lattice, 2)
        l = lattice(:, i)
        l(a) = span(a) - l(a)
        if (.not. occupied(l(1), l(2), l(3))) then
          mirrored(a) = .false.
          exit
        end if
      end do
    end do
  end function lattice_mirrors
end module beadmob_unit_lattice
