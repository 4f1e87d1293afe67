!> Filling a shape with lattice nodes: the loop shared by the builders whose inside test is
!> a plain function of the node (cone, spheroid, torus), and the boundary tolerance all
!> shape builders use for nodes that lie on a surface in exact arithmetic.
module beadmob_lattice_fill
  use beadmob_kinds, only: dp, i4
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str, str_approx
  use beadmob_resources, only: available_memory_bytes
  use beadmob_vector_algebra, only: axis_angle_rotation
  implicit none
  private
  public :: lattice_nodes_inside, inside_test, boundary_tolerance, reserve_sites, lattice_shift, offset_sequence, &
            turn_sequence

  !> Relative tolerance of the inside tests of the shape builders.
  real(dp), parameter :: boundary_tolerance = 1.0e-9_dp

  abstract interface
    logical function inside_test(node)
      import :: dp
      real(dp), intent(in) :: node(3)
    end function inside_test
  end interface

contains

  !> The points node + offset (node an integer lattice node) for which `inside` is true, in the
  !> order x fastest, then y, then z; the nodes range over the box lower..upper, which must
  !> hold every integer point of the body. `offset` (each component in [0, 1), d) shifts the
  !> lattice against the body (the continuum job's sub-lattice offsets); the inside test must
  !> then be complete, the box only bounds it. `what` names the shape in an error.
  subroutine lattice_nodes_inside(lower, upper, inside, what, offset, centres, err)
    integer, intent(in) :: lower(3), upper(3)
    procedure(inside_test) :: inside
    character(len=*), intent(in) :: what
    real(dp), intent(in) :: offset(3)
    real(dp), allocatable, intent(out) :: centres(:, :)
    type(error_t), intent(inout) :: err
    real(dp), allocatable :: buffer(:, :)
    real(dp) :: node(3)
    integer :: i, j, k, count, first(3)
    ! A shifted point n + offset, offset in (0, 1), covers the body's integer points from n = lower - 1.
    first = lower - merge(1, 0, offset /= 0.0_dp)
    call reserve_sites(upper - first + 1, what, buffer, err)
    if (err%failed) then
      allocate (centres(3, 0))
      return
    end if
    count = 0
    do k = first(3), upper(3)
      do j = first(2), upper(2)
        do i = first(1), upper(1)
          node = [real(i, dp), real(j, dp), real(k, dp)] + offset
          if (inside(node)) then
            count = count + 1
            buffer(:, count) = node
          end if
        end do
      end do
    end do
    centres = buffer(:, 1:count)
  end subroutine lattice_nodes_inside

  !> A builder's optional offset of the lattice against the body: as given, else none.
  pure function lattice_shift(offset) result(shift)
    real(dp), intent(in), optional :: offset(3)
    real(dp) :: shift(3)
    shift = 0.0_dp
    if (present(offset)) shift = offset
  end function lattice_shift

  !> Lattice offset number j >= 1 of a well spread sequence over the unit cell: the Halton
  !> sequence in bases 2, 3, 5 (van der Corput's in each base per axis).
  pure function offset_sequence(j) result(offset)
    integer, intent(in) :: j
    real(dp) :: offset(3)
    offset = [van_der_corput(j, 2), van_der_corput(j, 3), van_der_corput(j, 5)]
  end function offset_sequence

  !> Lattice turn number j >= 1 of a well spread sequence of rotations by at most max_angle
  !> (radians, up to pi): the rotation vector uniform in the ball of that radius (axis uniform on
  !> the sphere, angle max_angle u^(1/3)), u and the axis from the Halton sequence in bases 7,
  !> 11, 13 (none of the offsets' bases, so turns and offsets do not go in step); the rotation
  !> matrix by Rodrigues' formula (axis_angle_rotation).
  pure function turn_sequence(j, max_angle) result(turn)
    integer, intent(in) :: j
    real(dp), intent(in) :: max_angle
    real(dp) :: turn(3, 3)
    real(dp), parameter :: two_pi = 6.283185307179586_dp
    real(dp) :: axis(3), angle, z, phi
    angle = max_angle * van_der_corput(j, 7)**(1.0_dp / 3.0_dp)
    z = 1.0_dp - 2.0_dp * van_der_corput(j, 11)
    phi = two_pi * van_der_corput(j, 13)
    axis = [sqrt(max(0.0_dp, 1.0_dp - z**2)) * cos(phi), sqrt(max(0.0_dp, 1.0_dp - z**2)) * sin(phi), z]
    turn = axis_angle_rotation(axis, angle)
  end function turn_sequence

  !> The radical inverse of index in base (van der Corput): its digits mirrored about the point.
  pure real(dp) function van_der_corput(index, base)
    integer, intent(in) :: index, base
    real(dp) :: f
    integer :: i
    van_der_corput = 0.0_dp
    f = 1.0_dp
    i = index
    do while (i > 0)
      f = f / base
      van_der_corput = van_der_corput + f * modulo(i, base)
      i = i / base
    end do
  end function van_der_corput

  !> buffer(3, n) for the n = product(sites) candidate lattice nodes of a shape builder, refused
  !> with one message (never a crash) when n exceeds the bead index range (default integers) or
  !> the positions alone (24 B a node, twice: the buffer and the model) exceed the memory this
  !> node has available. A model that passes may still be refused by the job estimate
  !> (beadmob_job_estimate), which knows the operator.
  subroutine reserve_sites(sites, what, buffer, err)
    integer, intent(in) :: sites(3)
    character(len=*), intent(in) :: what
    real(dp), allocatable, intent(out) :: buffer(:, :)
    type(error_t), intent(inout) :: err
    real(dp) :: n, needed, available
    integer :: stat
    n = product(real(max(sites, 0), dp))
    needed = 2 * 24 * n
    available = available_memory_bytes()
    if (n > real(huge(1_i4), dp)) then
      call raise(err, what // ': ' // str(sites(1)) // ' x ' // str(sites(2)) // ' x ' // str(sites(3)) // &
                 ' = ' // str_approx(n) // ' lattice sites, more beads than beadmob indexes (' // str(huge(1_i4)) // &
                 '); the positions alone would need ' // str_approx(needed / 1.0e9_dp) // ' GB per rank')
    else if (available > 0.0_dp .and. needed > available) then
      call raise(err, what // ': ' // str(sites(1)) // ' x ' // str(sites(2)) // ' x ' // str(sites(3)) // &
                 ' = ' // str_approx(n) // ' lattice sites: their positions alone need ' // str_approx(needed / 1.0e9_dp) // &
                 ' GB per rank, this node has ' // str_approx(available / 1.0e9_dp) // ' GB available')
    else
      allocate (buffer(3, int(n)), stat=stat)
      if (stat /= 0) call raise(err, what // ': could not allocate the positions of ' // str_approx(n) // &
                                ' lattice sites (' // str_approx(needed / 2.0e9_dp) // ' GB)')
    end if
    if (err%failed .and. .not. allocated(buffer)) allocate (buffer(3, 0))
  end subroutine reserve_sites

end module beadmob_lattice_fill
