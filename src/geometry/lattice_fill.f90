!> Filling a shape with lattice nodes: the loop shared by the builders whose inside test is
!> a plain function of the node (cone, spheroid, torus), and the boundary tolerance all
!> shape builders use for nodes that lie on a surface in exact arithmetic.
module beadmob_lattice_fill
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: lattice_nodes_inside, inside_test, boundary_tolerance

  !> Relative tolerance of the inside tests of the shape builders.
  real(dp), parameter :: boundary_tolerance = 1.0e-9_dp

  abstract interface
    logical function inside_test(node)
      import :: dp
      real(dp), intent(in) :: node(3)
    end function inside_test
  end interface

contains

  !> Integer lattice nodes in the box lower..upper (per axis) for which `inside` is true,
  !> in the order x fastest, then y, then z.
  function lattice_nodes_inside(lower, upper, inside) result(centres)
    integer, intent(in) :: lower(3), upper(3)
    procedure(inside_test) :: inside
    real(dp), allocatable :: centres(:, :)
    real(dp), allocatable :: buffer(:, :)
    real(dp) :: node(3)
    integer :: i, j, k, count
    allocate (buffer(3, product(max(upper - lower + 1, 0))))
    count = 0
    do k = lower(3), upper(3)
      do j = lower(2), upper(2)
        do i = lower(1), upper(1)
          node = [real(i, dp), real(j, dp), real(k, dp)]
          if (inside(node)) then
            count = count + 1
            buffer(:, count) = node
          end if
        end do
      end do
    end do
    centres = buffer(:, 1:count)
  end function lattice_nodes_inside
end module beadmob_lattice_fill
