!> Two-bead blocks at any displacement without a quadrature per pair (theory.md T15).
!> On the z axis, every entry of the block A_z(r) is a polynomial of degree <= 2 L + 2 in
!> x = 1 / r (r in d): the exterior field of a degree-n density is a sum of terms
!> r^-(n+1+m) and r^-(n-1+m) in its Taylor degree m about the other bead, and a density of degree
!> n' <= L sees only the Taylor degrees m <= n' + 3. Interpolation in x at n_nodes > 2 L + 3
!> Chebyshev points of (0, 1) (blocks there by quadrature, pair_blocks.f90) is therefore exact up
!> to rounding for every r >= 1 (measured: 4e-15 of the block's largest entry, L = 1..6; the test
!> test_axial_blocks checks 1e-12 at random distances and directions up to L = 8). A pair in
!> direction u then follows by the rotation of the basis, A(r u) = D_Q A_z(r) D_Q^T with
!> Q e_z = u (harmonic_rotation.f90; the same covariance as the lattice symmetries, T4).
module beadmob_axial_table
  use mpi
  use beadmob_kinds, only: dp
  use beadmob_multipole_basis, only: multipole_basis_t
  use beadmob_pair_blocks, only: pair_block
  use beadmob_harmonic_rotation, only: rotation_rule_t, make_rotation_rule, direction_rotations
  use beadmob_lapack, only: dgemm, dgemv
  implicit none
  private
  public :: axial_table_t, make_axial_table, axial_block, rotated_block, axial_nodes

  real(dp), parameter :: pi = acos(-1.0_dp)

  type :: axial_table_t
    integer :: block_size = 0, order = 0
    real(dp), allocatable :: nodes(:)                ! x_k = 1 / r_k in (0, 1)
    real(dp), allocatable :: barycentric_weights(:)
    real(dp), allocatable :: blocks(:, :, :)         ! (nb, nb, n_nodes): A_z(1 / x_k)
    !> The nodes are the distinct distances of a bead set (fewer than the Chebyshev nodes): blocks
    !> are looked up, not interpolated, and only those distances are served.
    logical :: at_distances = .false.
    !> First and last basis index of each (n, sigma) group (contiguous in the basis order), its degree
    integer, allocatable :: group_first(:), group_last(:), group_degree(:)
    type(rotation_rule_t) :: rotation
  end type axial_table_t

contains

  !> Nodes per order: 2 L + 6 (the polynomial degree 2 L + 2 plus a margin of 3).
  pure integer function axial_nodes(order)
    integer, intent(in) :: order
    axial_nodes = 2 * order + 6
  end function axial_nodes

  !> The table of `basis` (all |k| <= n of every degree: the rotation needs whole degrees).
  !> comm (optional): the node quadratures are shared over its ranks (collective). distances
  !> (optional): when there are fewer distinct ones than Chebyshev nodes, the table holds those
  !> distances only (at_distances; a few beads at high L, where a quadrature is expensive).
  subroutine make_axial_table(basis, table, comm, distances)
    type(multipole_basis_t), intent(in) :: basis
    type(axial_table_t), intent(out) :: table
    integer, intent(in), optional :: comm
    real(dp), intent(in), optional :: distances(:)
    integer :: k, n_nodes, a, groups, rank, n_ranks, ierr, owner
    real(dp), allocatable :: distinct(:)
    n_nodes = axial_nodes(basis%order)
    table%block_size = basis%size
    table%order = basis%order
    if (present(distances)) then
      distinct = distinct_values(distances)
      table%at_distances = size(distinct) < n_nodes
      if (table%at_distances) n_nodes = size(distinct)
    end if
    allocate (table%nodes(n_nodes), table%barycentric_weights(n_nodes), table%blocks(basis%size, basis%size, n_nodes))
    rank = 0
    n_ranks = 1
    if (present(comm)) then
      call MPI_Comm_rank(comm, rank, ierr)
      call MPI_Comm_size(comm, n_ranks, ierr)
    end if
    do k = 1, n_nodes
      if (table%at_distances) then
        table%nodes(k) = 1.0_dp / distinct(k)
        table%barycentric_weights(k) = 0.0_dp
      else
        ! Chebyshev points of the first kind on (0, 1) and their barycentric weights (Berrut & Trefethen 2004)
        table%nodes(k) = 0.5_dp + 0.5_dp * cos(pi * (k - 0.5_dp) / n_nodes)
        table%barycentric_weights(k) = (-1)**(k - 1) * sin(pi * (k - 0.5_dp) / n_nodes)
      end if
      if (mod(k - 1, n_ranks) == rank) call pair_block(basis, [0.0_dp, 0.0_dp, 1.0_dp / table%nodes(k)], table%blocks(:, :, k))
    end do
    if (present(comm) .and. n_ranks > 1) then
      do k = 1, n_nodes   ! node k from its rank (round robin)
        owner = mod(k - 1, n_ranks)
        call MPI_Bcast(table%blocks(:, :, k), basis%size**2, MPI_DOUBLE_PRECISION, owner, comm, ierr)
      end do
    end if
    groups = 0
    allocate (table%group_first(basis%size), table%group_last(basis%size), table%group_degree(basis%size))
    do a = 1, basis%size
      if (a > 1) then
        if (basis%degree(a) == basis%degree(a - 1) .and. basis%family(a) == basis%family(a - 1)) cycle
      end if
      groups = groups + 1
      table%group_first(groups) = a
      table%group_last(groups) = a + 2 * basis%degree(a)
      table%group_degree(groups) = basis%degree(a)
    end do
    table%group_first = table%group_first(1:groups)
    table%group_last = table%group_last(1:groups)
    table%group_degree = table%group_degree(1:groups)
    table%rotation = make_rotation_rule(basis%order)
  end subroutine make_axial_table

  !> block = A_z(distance), the pair on the z axis (distance >= 1, in d).
  pure subroutine axial_block(table, distance, block)
    type(axial_table_t), intent(in) :: table
    real(dp), intent(in) :: distance
    real(dp), intent(out) :: block(:, :)
    real(dp) :: x, weights(size(table%nodes))
    integer :: k
    x = 1.0_dp / distance
    weights = x - table%nodes
    k = minloc(abs(weights), dim=1)
    ! A node, or with a table at distances, one of them (the same distance computed from
    ! another displacement: equal to rounding)
    if (weights(k) == 0.0_dp .or. table%at_distances) then
      block = table%blocks(:, :, k)
      return
    end if
    weights = table%barycentric_weights / weights
    weights = weights / sum(weights)
    ! block = sum_k weights(k) blocks(:, :, k), one BLAS product (vectorised at run time)
    call dgemv('N', table%block_size**2, size(weights), 1.0_dp, table%blocks, table%block_size**2, weights, 1, 0.0_dp, &
               block, 1)
  end subroutine axial_block

  !> The sorted distinct values of `values` (equal to 1e-12 relative: one distance computed from
  !> two displacements).
  pure function distinct_values(values) result(distinct)
    real(dp), intent(in) :: values(:)
    real(dp), allocatable :: distinct(:)
    real(dp) :: sorted(size(values)), swap
    integer :: i, j, n
    sorted = values
    do i = 2, size(sorted)   ! insertion sort: few values
      swap = sorted(i)
      j = i - 1
      do while (j >= 1)
        if (sorted(j) <= swap) exit
        sorted(j + 1) = sorted(j)
        j = j - 1
      end do
      sorted(j + 1) = swap
    end do
    allocate (distinct(size(sorted)))
    n = 0
    do i = 1, size(sorted)
      if (n > 0) then
        if (sorted(i) - distinct(n) <= 1.0e-12_dp * sorted(i)) cycle
      end if
      n = n + 1
      distinct(n) = sorted(i)
    end do
    distinct = distinct(1:n)
  end function distinct_values

  !> block = A(displacement), displacement = R_i - R_j (|displacement| >= 1 d): the axial block
  !> turned, D_Q A_z D_Q^T with Q e_z = displacement / |displacement| (D_Q: O^n(Q) on each
  !> (n, sigma) group, harmonic_rotation.f90).
  pure subroutine rotated_block(table, displacement, block)
    type(axial_table_t), intent(in) :: table
    real(dp), intent(in) :: displacement(3)
    real(dp), intent(out) :: block(:, :)
    real(dp) :: axial(table%block_size, table%block_size), half(table%block_size, table%block_size), &
                turn(table%block_size, table%block_size)
    real(dp) :: rotations(2 * table%order + 1, 2 * table%order + 1, table%order)
    integer :: g, n, f, l, nb
    nb = table%block_size
    call axial_block(table, norm2(displacement), axial)
    call direction_rotations(table%rotation, displacement, rotations)
    ! D whole, zero between groups: two dense BLAS products (vectorised at run time) were faster
    ! than the group-by-group loops, which use a fifth of the flops.
    turn = 0.0_dp
    do g = 1, size(table%group_first)
      n = table%group_degree(g)
      f = table%group_first(g)
      l = table%group_last(g)
      turn(f:l, f:l) = rotations(1:2 * n + 1, 1:2 * n + 1, n)
    end do
    call dgemm('N', 'T', nb, nb, nb, 1.0_dp, axial, nb, turn, nb, 0.0_dp, half, nb)   ! A_z D^T
    call dgemm('N', 'N', nb, nb, nb, 1.0_dp, turn, nb, half, nb, 0.0_dp, block, nb)
  end subroutine rotated_block
end module beadmob_axial_table
