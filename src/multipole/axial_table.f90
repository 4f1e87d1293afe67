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
  use beadmob_kinds, only: dp
  use beadmob_multipole_basis, only: multipole_basis_t
  use beadmob_pair_blocks, only: pair_block
  use beadmob_harmonic_rotation, only: rotation_rule_t, make_rotation_rule, degree_rotations, rotation_to_direction
  implicit none
  private
  public :: axial_table_t, make_axial_table, axial_block, rotated_block, axial_nodes

  real(dp), parameter :: pi = acos(-1.0_dp)

  type :: axial_table_t
    integer :: block_size = 0, order = 0
    real(dp), allocatable :: nodes(:)                ! x_k = 1 / r_k in (0, 1)
    real(dp), allocatable :: barycentric_weights(:)
    real(dp), allocatable :: blocks(:, :, :)         ! (nb, nb, n_nodes): A_z(1 / x_k)
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
  subroutine make_axial_table(basis, table)
    type(multipole_basis_t), intent(in) :: basis
    type(axial_table_t), intent(out) :: table
    integer :: k, n_nodes, a, groups
    n_nodes = axial_nodes(basis%order)
    table%block_size = basis%size
    table%order = basis%order
    allocate (table%nodes(n_nodes), table%barycentric_weights(n_nodes), table%blocks(basis%size, basis%size, n_nodes))
    do k = 1, n_nodes
      ! Chebyshev points of the first kind on (0, 1) and their barycentric weights (Berrut & Trefethen 2004)
      table%nodes(k) = 0.5_dp + 0.5_dp * cos(pi * (k - 0.5_dp) / n_nodes)
      table%barycentric_weights(k) = (-1)**(k - 1) * sin(pi * (k - 0.5_dp) / n_nodes)
      call pair_block(basis, [0.0_dp, 0.0_dp, 1.0_dp / table%nodes(k)], table%blocks(:, :, k))
    end do
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
    if (weights(k) == 0.0_dp) then
      block = table%blocks(:, :, k)
      return
    end if
    weights = table%barycentric_weights / weights
    weights = weights / sum(weights)
    block = 0.0_dp
    do k = 1, size(weights)
      block = block + weights(k) * table%blocks(:, :, k)
    end do
  end subroutine axial_block

  !> block = A(displacement), displacement = R_i - R_j (|displacement| >= 1 d): the axial block
  !> turned by D_Q, Q e_z = displacement / |displacement|, one (n, sigma) group at a time.
  pure subroutine rotated_block(table, displacement, block)
    type(axial_table_t), intent(in) :: table
    real(dp), intent(in) :: displacement(3)
    real(dp), intent(out) :: block(:, :)
    real(dp) :: axial(table%block_size, table%block_size), half(table%block_size, table%block_size)
    real(dp) :: rotations(2 * table%order + 1, 2 * table%order + 1, table%order)
    integer :: g, n, f, l
    call axial_block(table, norm2(displacement), axial)
    call degree_rotations(table%rotation, rotation_to_direction(displacement), rotations)
    ! half = A_z D^T, then block = D half (D block-diagonal with blocks O^n).
    do g = 1, size(table%group_first)
      n = table%group_degree(g)
      f = table%group_first(g)
      l = table%group_last(g)
      half(:, f:l) = matmul(axial(:, f:l), transpose(rotations(1:2 * n + 1, 1:2 * n + 1, n)))
    end do
    do g = 1, size(table%group_first)
      n = table%group_degree(g)
      f = table%group_first(g)
      l = table%group_last(g)
      block(f:l, :) = matmul(rotations(1:2 * n + 1, 1:2 * n + 1, n), half(f:l, :))
    end do
  end subroutine rotated_block
end module beadmob_axial_table
