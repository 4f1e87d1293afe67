!> The shell model of a lattice bead body: only the beads within a given number of layers of the
!> surface. The rigid-body friction is carried by the surface traction; interior beads of a full
!> model carry forces that decay into the body, so dropping them changes the friction little
!> and removes a large share of the unknowns of a thick body (bench/accuracy/accuracy.md measures the
!> change). Layer 1 = beads with at least one empty face-neighbour site (6-neighbourhood);
!> layer k = beads k - 1 face steps from layer 1.
module beadmob_shell_model
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  implicit none
  private
  public :: surface_depth, shell_mask

  integer, parameter :: face_steps(3, 6) = reshape([1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1], [3, 6])

contains

  !> depth(i) = the layer of bead i (1 = on the surface). The beads must lie on the unit lattice
  !> (checked by the caller: beadmob_unit_lattice on_unit_lattice).
  subroutine surface_depth(centres, depth)
    real(dp), intent(in) :: centres(:, :)
    integer, allocatable, intent(out) :: depth(:)
    integer, allocatable :: lattice(:, :), site(:, :, :), queue(:)
    integer :: n, i, k, head, tail, c(3), top(3), neighbour

    n = size(centres, 2)
    allocate (depth(n), queue(n))
    depth = 0
    if (n == 0) return
    lattice = nint(centres - spread(minval(centres, dim=2), 2, n)) + 1   ! >= 1: a zero border around
    top = maxval(lattice, dim=2) + 1
    allocate (site(0:top(1), 0:top(2), 0:top(3)))
    site = 0
    do i = 1, n
      site(lattice(1, i), lattice(2, i), lattice(3, i)) = i
    end do
    ! Breadth-first from the surface beads: each bead gets the smallest number of face steps.
    tail = 0
    do i = 1, n
      do k = 1, 6
        c = lattice(:, i) + face_steps(:, k)
        if (site(c(1), c(2), c(3)) == 0) then
          depth(i) = 1
          tail = tail + 1
          queue(tail) = i
          exit
        end if
      end do
    end do
    head = 0
    do while (head < tail)
      head = head + 1
      i = queue(head)
      do k = 1, 6
        c = lattice(:, i) + face_steps(:, k)
        neighbour = site(c(1), c(2), c(3))
        if (neighbour == 0) cycle
        if (depth(neighbour) /= 0) cycle
        depth(neighbour) = depth(i) + 1
        tail = tail + 1
        queue(tail) = neighbour
      end do
    end do
  end subroutine surface_depth

  !> keep(i) = bead i lies within `layers` layers of the surface (layers >= 1).
  subroutine shell_mask(centres, layers, keep, err)
    real(dp), intent(in) :: centres(:, :)
    integer, intent(in) :: layers
    logical, allocatable, intent(out) :: keep(:)
    type(error_t), intent(inout) :: err
    integer, allocatable :: depth(:)
    if (layers < 1) then
      call raise(err, 'shell_layers must be >= 1 (or 0 for the full model), got ' // str(layers))
      return
    end if
    call surface_depth(centres, depth)
    keep = depth <= layers
  end subroutine shell_mask
end module beadmob_shell_model
