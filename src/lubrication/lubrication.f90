!> Lubrication correction of a rigid bead model (docs/theory.md T9; Durlofsky, Brady & Bossis,
!> J. Fluid Mech. 180, 21 (1987) for the superposition idea; Cichocki et al., J. Chem. Phys. 100,
!> 3780 (1994) and 112, 2548 (2000) with the multipole method):
!>   zeta = zeta_L + sum_{pairs, r < cutoff} T^T [Z_exact(r) - Z_L(r)] T,
!> Z(r) the 6x6 friction of the rigid doublet about its midpoint, T the map from the body's
!> motion to the doublet's. A rigid doublet has no relative motion at contact, so Z is finite
!> there. By the doublet's symmetry Z = diag(Y, Y, X, Yr, Yr, Xr) with the pair along z: four
!> numbers per distance; a lattice has few distances, so the table is small.
module beadmob_lubrication
  use mpi
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_parallel, only: even_shares
  use beadmob_multipole_basis, only: multipole_basis_t, make_multipole_basis, bead_radius
  use beadmob_dense_friction, only: dense_friction, rigid_motions
  use beadmob_two_sphere_exact, only: stimson_jeffery, stimson_jeffery_contact
  use beadmob_table_cache, only: cache_key_t, read_cached_lubrication, write_cached_lubrication, warn_cache
  implicit none
  private
  public :: doublet_friction, exact_doublet_friction, lubrication_table_t, &
            make_shared_lubrication_table, lubrication_cache_key, add_lubrication, reference_order, contact_tolerance

  !> Order of the "exact" doublet values: rigid-doublet friction converges in L even at contact;
  !> L = 24 -> 30 changes them by < 1e-8 relative (theory.md T8 table, tests).
  integer, parameter :: reference_order = 30
  real(dp), parameter :: contact_tolerance = 1.0e-9_dp
  !> Part of the cache key of the corrections: bump it whenever doublet_friction,
  !> exact_doublet_friction or the two-sphere series change.
  integer, parameter :: lubrication_formula_version = 1

  type :: lubrication_table_t
    real(dp) :: cutoff = 0.0_dp
    real(dp), allocatable :: distances(:)
    !> correction(1:4, k): Z_exact - Z_L for (Y, X, Yr, Xr) at distances(k)
    real(dp), allocatable :: correction(:, :)
    integer :: cached_distances = 0     ! corrections read from the table cache
    integer :: computed_distances = 0   ! corrections computed
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

  !> The cache key of the corrections at order (L, L2): everything they depend on.
  function lubrication_cache_key(order, potential_order) result(key)
    integer, intent(in) :: order, potential_order
    type(cache_key_t) :: key
    key%name = 'L' // str(order) // '_L2_' // str(potential_order)
    key%text = 'rigid-doublet corrections Z_exact - Z_L (Y, X, Yr, Xr) per centre distance (units of d); ' // &
               'multipole_order = ' // str(order) // ', potential_order = ' // str(potential_order) // &
               ', bead_radius = ' // str(bead_radius) // '; exact: multipole order ' // str(reference_order) // &
               ' (potential order ' // str(reference_order - 2) // '), axial translation Stimson-Jeffery, ' // &
               'contact within ' // str(contact_tolerance) // '; lubrication_formula_version = ' // &
               str(lubrication_formula_version)
  end function lubrication_cache_key

  !> The corrections for every distinct bead distance below `cutoff` (units of d), collectively
  !> over comm, the same table on every rank: corrections found in the table cache `cache_file`
  !> ('' = none; read by rank 0, for the identical distance) are taken from it, the others are
  !> computed shared over the ranks and added to the cache.
  subroutine make_shared_lubrication_table(comm, order, potential_order, centres, cutoff, cache_file, table, err)
    integer, intent(in) :: comm, order, potential_order
    real(dp), intent(in) :: centres(:, :), cutoff
    character(len=*), intent(in) :: cache_file
    type(lubrication_table_t), intent(out) :: table
    type(error_t), intent(inout) :: err
    real(dp) :: exact(4), approximate(4)
    real(dp), allocatable :: found(:), cached_distances(:), cached(:, :), computed(:, :), gathered(:, :)
    integer, allocatable :: missing(:), counts(:), offsets(:), flags(:)
    integer :: rank, n_ranks, ierr, j, k, h, n, n_missing, mine, failed_here, failed_anywhere
    type(error_t) :: cache_err, write_err
    logical :: caching

    call MPI_Comm_rank(comm, rank, ierr)
    call MPI_Comm_size(comm, n_ranks, ierr)
    ! Every rank finds the same distances from the same centres.
    call distinct_close_distances(centres, cutoff, found)
    n = size(found)
    table%cutoff = cutoff
    table%distances = found
    allocate (table%correction(4, n), flags(n))
    flags = 0
    ! Only rank 0 touches the file: its view decides, for every rank.
    caching = len(cache_file) > 0
    call MPI_Bcast(caching, 1, MPI_LOGICAL, 0, comm, ierr)
    if (caching .and. rank == 0) then
      call read_cached_lubrication(cache_file, lubrication_cache_key(order, potential_order), cached_distances, &
                                   cached, cache_err)
      if (cache_err%failed) call warn_cache(cache_file, cache_err%message // &
                                            '; computing every lubrication correction and rewriting the cache')
      do k = 1, n
        do j = 1, size(cached_distances)
          ! Identical distances only: the correction then is exactly the one computed before.
          if (cached_distances(j) == found(k)) then
            flags(k) = 1
            table%correction(:, k) = cached(:, j)
            exit
          end if
        end do
      end do
    end if
    if (caching) then
      call MPI_Bcast(flags, n, MPI_INTEGER, 0, comm, ierr)
      if (any(flags == 1)) call MPI_Bcast(table%correction, 4 * n, MPI_DOUBLE_PRECISION, 0, comm, ierr)
    end if

    ! The missing corrections, shared over the ranks.
    missing = pack([(k, k = 1, n)], flags == 0)
    n_missing = size(missing)
    call even_shares(n_missing, n_ranks, counts, offsets)
    mine = counts(rank)
    allocate (computed(4, max(mine, 1)), gathered(4, max(n_missing, 1)))
    do h = 1, mine
      k = missing(offsets(rank) + h)
      call exact_doublet_friction(found(k), exact, err)
      call doublet_friction(order, potential_order, found(k), approximate, err)
      computed(:, h) = exact - approximate
    end do
    call MPI_Allgatherv(computed, 4 * mine, MPI_DOUBLE_PRECISION, gathered, 4 * counts, 4 * offsets, &
                        MPI_DOUBLE_PRECISION, comm, ierr)
    if (ierr /= MPI_SUCCESS) call raise(err, 'MPI_Allgatherv of the lubrication table failed')
    table%correction(:, missing) = gathered(:, 1:n_missing)
    table%cached_distances = n - n_missing
    table%computed_distances = n_missing

    ! Store only corrections every rank computed without error.
    failed_here = merge(1, 0, err%failed)
    call MPI_Allreduce(failed_here, failed_anywhere, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
    if (caching .and. rank == 0 .and. n_missing > 0 .and. failed_anywhere == 0) then
      call write_cached_lubrication(cache_file, lubrication_cache_key(order, potential_order), &
                                    [cached_distances, found(missing)], &
                                    reshape([cached, gathered(:, 1:n_missing)], [4, size(cached_distances) + n_missing]), &
                                    write_err)
      if (write_err%failed) call warn_cache(cache_file, 'not updated: ' // write_err%message)
    end if
  end subroutine make_shared_lubrication_table

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
