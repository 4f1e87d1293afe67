!> Lubrication correction of a rigid bead model (docs/theory.md T9; Durlofsky, Brady & Bossis,
!> J. Fluid Mech. 180, 21 (1987) for the superposition idea; Cichocki et al., J. Chem. Phys. 100,
!> 3780 (1994) and 112, 2548 (2000) with the multipole method):
!>   zeta = zeta_L + sum_{pairs, r < cutoff} T^T [Z_exact(r) - Z_L(r)] T,
!> Z(r) the 6x6 friction of the rigid doublet about its midpoint, T the map from the body's
!> motion to the doublet's. A rigid doublet has no relative motion at contact, so Z is finite
!> there. By the doublet's symmetry Z = diag(Y, Y, X, Yr, Yr, Xr) with the pair along z: four
!> numbers per distance; a lattice has few distances, so the table is small.
module beadmob_lubrication
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t
  use beadmob_multipole_basis, only: multipole_basis_t, make_multipole_basis, bead_radius
  use beadmob_dense_friction, only: dense_friction, rigid_motions
  use beadmob_two_sphere_exact, only: stimson_jeffery, stimson_jeffery_contact
  implicit none
  private
  public :: doublet_friction, exact_doublet_friction, lubrication_table_t, make_lubrication_table, &
            add_lubrication, reference_order, contact_tolerance

  !> Order of the "exact" doublet values: rigid-doublet friction converges in L even at contact;
  !> L = 24 -> 30 changes them by < 1e-8 relative (theory.md T8 table, tests).
  integer, parameter :: reference_order = 30
  real(dp), parameter :: contact_tolerance = 1.0e-9_dp

  type :: lubrication_table_t
    real(dp) :: cutoff = 0.0_dp
    real(dp), allocatable :: distances(:)
    !> correction(1:4, k): Z_exact - Z_L for (Y, X, Yr, Xr) at distances(k)
    real(dp), allocatable :: correction(:, :)
  end type lubrication_table_t

contains

  !> (Y, X, Yr, Xr) of the rigid doublet at centre distance r, from the multipole method with the
  !> azimuthal symmetry reduction (|k| = 0 and |k| = 1 decouple for a pair on the z axis).
  subroutine doublet_friction(order, potential_order, r, values, err)
    integer, intent(in) :: order, potential_order
    real(dp), intent(in) :: r
    real(dp), intent(out) :: values(4)
    type(error_t), intent(inout) :: err
    real(dp) :: centres(3, 2), friction(6, 6), motions(12, 6)
    type(multipole_basis_t) :: basis
    integer :: k
    centres = reshape([0.0_dp, 0.0_dp, -r / 2, 0.0_dp, 0.0_dp, r / 2], [3, 2])
    motions = rigid_motions(centres, [0.0_dp, 0.0_dp, 0.0_dp])
    values = 0.0_dp
    do k = 0, 1
      basis = make_multipole_basis(order, potential_order, [k])
      ! Motions (U_z, W_z) live in |k| = 0; (U_x, W_y) in |k| = 1 (cosine part).
      if (k == 0) then
        call dense_friction(basis, centres, motions(:, [3, 6]), friction(1:2, 1:2), err)
        values(2) = friction(1, 1)
        values(4) = friction(2, 2)
      else
        call dense_friction(basis, centres, motions(:, [1, 5]), friction(1:2, 1:2), err)
        values(1) = friction(1, 1)
        values(3) = friction(2, 2)
      end if
    end do
  end subroutine doublet_friction

  !> Exact rigid-doublet values: axial translation from the Stimson-Jeffery series (contact
  !> limit extrapolated), the others from the multipole method at reference_order.
  subroutine exact_doublet_friction(r, values, err)
    real(dp), intent(in) :: r
    real(dp), intent(out) :: values(4)
    type(error_t), intent(inout) :: err
    real(dp), parameter :: pi = acos(-1.0_dp)
    call doublet_friction(reference_order, reference_order - 2, r, values, err)
    if (r <= 2.0_dp * bead_radius * (1.0_dp + contact_tolerance)) then
      values(2) = 2.0_dp * 6.0_dp * pi * bead_radius * stimson_jeffery_contact(bead_radius)
    else
      values(2) = 2.0_dp * 6.0_dp * pi * bead_radius * stimson_jeffery(r, bead_radius)
    end if
  end subroutine exact_doublet_friction

  !> The corrections for every distinct bead distance below `cutoff` (units of d).
  subroutine make_lubrication_table(order, potential_order, centres, cutoff, table, err)
    integer, intent(in) :: order, potential_order
    real(dp), intent(in) :: centres(:, :), cutoff
    type(lubrication_table_t), intent(out) :: table
    type(error_t), intent(inout) :: err
    real(dp) :: exact(4), approximate(4)
    real(dp), allocatable :: found(:)
    integer :: k
    call distinct_close_distances(centres, cutoff, found)
    table%cutoff = cutoff
    table%distances = found
    allocate (table%correction(4, size(found)))
    do k = 1, size(found)
      call exact_doublet_friction(found(k), exact, err)
      call doublet_friction(order, potential_order, found(k), approximate, err)
      table%correction(:, k) = exact - approximate
    end do
  end subroutine make_lubrication_table

  !> Sorted distinct centre distances (to 1e-9 relative) of pairs closer than cutoff. O(N^2)
  !> only over pairs in neighbouring cells of a cell list would be needed for huge models; here a
  !> direct scan of pairs within the cutoff box is done per bead.
  subroutine distinct_close_distances(centres, cutoff, found)
    real(dp), intent(in) :: centres(:, :), cutoff
    real(dp), allocatable, intent(out) :: found(:)
    real(dp), allocatable :: list(:)
    real(dp) :: r
    integer :: i, j, n_found
    allocate (list(64))
    n_found = 0
    do i = 1, size(centres, 2)
      do j = i + 1, size(centres, 2)
        if (any(abs(centres(:, j) - centres(:, i)) >= cutoff)) cycle
        r = norm2(centres(:, j) - centres(:, i))
        if (r >= cutoff) cycle
        if (any(abs(list(1:n_found) - r) <= 1.0e-9_dp * r)) cycle
        n_found = n_found + 1
        if (n_found > size(list)) list = [list, list]
        list(n_found) = r
      end do
    end do
    found = list(1:n_found)
    call sort(found)
  end subroutine distinct_close_distances

  pure subroutine sort(values)
    real(dp), intent(inout) :: values(:)
    real(dp) :: swap
    integer :: i, j
    do i = 2, size(values)
      swap = values(i)
      j = i - 1
      do while (j >= 1)
        if (values(j) <= swap) exit
        values(j + 1) = values(j)
        j = j - 1
      end do
      values(j + 1) = swap
    end do
  end subroutine sort

  !> friction += sum over pairs (i < j) closer than the cutoff of T^T [R Delta R^T] T, with
  !> R Delta R^T = Y (I - e e) + X e e per 3x3 block (e the pair axis) and T the body -> doublet
  !> midpoint map (U_mid = U + Omega x (m - reference), Omega_mid = Omega). Pairs i in
  !> first..last only (the caller sums over ranks).
  subroutine add_lubrication(table, centres, reference, first, last, friction, n_pairs)
    type(lubrication_table_t), intent(in) :: table
    real(dp), intent(in) :: centres(:, :), reference(3)
    integer, intent(in) :: first, last
    real(dp), intent(inout) :: friction(6, 6)
    integer, intent(out) :: n_pairs
    real(dp) :: d(3), r, e(3), ee(3, 3), delta(6, 6), transfer(6, 6), arm(3)
    integer :: i, j, k, c
    n_pairs = 0
    do i = first, last
      do j = i + 1, size(centres, 2)
        d = centres(:, j) - centres(:, i)
        if (any(abs(d) >= table%cutoff)) cycle
        r = norm2(d)
        if (r >= table%cutoff) cycle
        k = minloc(abs(table%distances - r), 1)
        e = d / r
        ee = spread(e, 2, 3) * spread(e, 1, 3)
        delta = 0.0_dp
        delta(1:3, 1:3) = table%correction(2, k) * ee - table%correction(1, k) * ee
        delta(4:6, 4:6) = table%correction(4, k) * ee - table%correction(3, k) * ee
        do c = 1, 3
          delta(c, c) = delta(c, c) + table%correction(1, k)
          delta(3 + c, 3 + c) = delta(3 + c, 3 + c) + table%correction(3, k)
        end do
        arm = 0.5_dp * (centres(:, i) + centres(:, j)) - reference
        transfer = 0.0_dp
        do c = 1, 6
          transfer(c, c) = 1.0_dp
        end do
        ! U_mid = U - [arm]_x Omega
        transfer(1:3, 4) = [0.0_dp, -arm(3), arm(2)]
        transfer(1:3, 5) = [arm(3), 0.0_dp, -arm(1)]
        transfer(1:3, 6) = [-arm(2), arm(1), 0.0_dp]
        friction = friction + matmul(transpose(transfer), matmul(delta, transfer))
        n_pairs = n_pairs + 1
      end do
    end do
  end subroutine add_lubrication
end module beadmob_lubrication
