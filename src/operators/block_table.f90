!> The two-bead blocks an operator product needs, computed once. Beads on a cubic lattice of
!> spacing d (the paper's models) have blocks that depend on the integer lattice displacement
!> only: one table over the displacement box [-span, span]^3 serves every pair. Blocks are
!> computed only for the canonical displacements (d_1 >= d_2 >= d_3 >= 0), from the axial table
!> (no quadrature per block), shared over the MPI ranks; every other block follows by a lattice symmetry, A(Q c) = D_Q A(c) D_Q^T (theory.md T4).
!> Two forms: the compact one keeps the canonical blocks and the D_Q only (O(span^3 / 6) blocks,
!> what the FFT operator needs: each rank forms the blocks of its own FFT slab from it), the
!> expanded one also the whole displacement box (the direct operator's lookups). Off-lattice bead
!> sets (bead files) store the blocks of this rank's rows for every column bead instead.
!> With a table cache file (table_cache.f90) the canonical blocks of earlier runs are read from it
!> and only the missing ones computed; the file then gets the union.
module beadmob_block_table
  use mpi
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_parallel, only: even_shares
  use beadmob_multipole_basis, only: multipole_basis_t, bead_radius
  use beadmob_axial_table, only: axial_table_t, make_axial_table, rotated_block
  use beadmob_lattice_symmetry, only: n_symmetries, canonical_displacement, basis_transforms
  use beadmob_table_cache, only: cache_key_t, read_cached_blocks, write_cached_blocks, warn_cache
  use beadmob_unit_lattice, only: lattice_tolerance
  use beadmob_lapack, only: dgemm
  implicit none
  private
  public :: block_table_t, make_block_table, table_block_index, block_cache_key
  public :: block_formula_version, lattice_block, lattice_block_entries, canonical_count
  public :: entry_terms_t, make_entry_terms, entries_by_terms

  !> Largest block store allowed per rank (bytes) before refusing an off-lattice model.
  real(dp), parameter :: max_store_bytes = 8.0e9_dp
  !> Part of the cache key of the blocks: bump it whenever the axial table, pair_block's quadrature or the
  !> multipole basis (functions, ordering, normalisation) change, so cached blocks of the old
  !> formulas are no longer used.
  integer, parameter :: block_formula_version = 2
  !> How the blocks are evaluated (axial_table.f90 and pair_blocks.f90), also in the key: a
  !> changed rule shows there.
  character(len=*), parameter :: pair_block_rule = 'axial table at 2 L + 6 Chebyshev nodes in 1/r (blocks by ' // &
                                                   'Gauss-Legendre n_theta = ceiling((40 + 1.5 (L + 3)) / log rho) / 2 + ' // &
                                                   'L + 8 within [L + 8, 400], trapezoid n_phi = 2 max|k| + 8), turned ' // &
                                                   'to the displacement by D_Q'

  type :: block_table_t
    logical :: on_lattice = .false.
    integer :: block_size = 0
    integer :: span(3) = 0
    integer, allocatable :: lattice(:, :)      ! (3, N) integer coordinates (lattice models)
    !> Expanded lattice table (nb, nb, blocks of the displacement box), or the off-lattice store
    !> (nb, nb, N n_local)
    real(dp), allocatable :: blocks(:, :, :)
    !> Compact lattice table: the block of canonical displacement c is
    !> canonical_blocks(:, :, canonical_id(c(1), c(2), c(3))) (lattice_block, lattice_block_entries)
    integer, allocatable :: canonical_id(:, :, :)
    real(dp), allocatable :: canonical_blocks(:, :, :)
    !> D_Q of the 48 lattice symmetries, dense (nb, nb, 48) and by rows without the zeros: row r
    !> of D_s has transform_count(r, s) entries transform_value(:, r, s) in columns transform_column(:, r, s)
    real(dp), allocatable :: transforms(:, :, :)
    integer, allocatable :: transform_count(:, :), transform_column(:, :, :)
    real(dp), allocatable :: transform_value(:, :, :)
    integer(i8) :: computed_blocks = 0         ! blocks computed (all ranks; off lattice: axial table nodes)
    integer(i8) :: cached_blocks = 0           ! blocks read from the table cache
    !> The table cache file ('' or unallocated: none). Callers that reach make_block_table
    !> through an operator's create routine set it in the operator's table before that call.
    character(len=:), allocatable :: cache_file
  end type block_table_t

  !> Chosen entries (rows(e), columns(e)) of the turned blocks D_s A D_s^T, for every lattice
  !> symmetry s, as short sums over the entries of A: entry e under s is
  !> sum_j value(j, e, s) A(index(j, e, s)) (A flattened, j <= count(e, s)). D_s has a few
  !> nonzeros per row, so each entry needs a few products (make_entry_terms).
  type :: entry_terms_t
    integer, allocatable :: count(:, :), index(:, :, :)
    real(dp), allocatable :: value(:, :, :)
  end type entry_terms_t

contains

  pure integer function table_block_index(table, displacement)
    type(block_table_t), intent(in) :: table
    integer, intent(in) :: displacement(3)
    integer :: width(3)
    width = 2 * table%span + 1
    table_block_index = 1 + (displacement(1) + table%span(1)) + width(1) * ((displacement(2) + table%span(2)) &
                        + width(2) * (displacement(3) + table%span(3)))
  end function table_block_index

  !> The cache key of the blocks of `basis`: everything they depend on.
  function block_cache_key(basis) result(key)
    type(multipole_basis_t), intent(in) :: basis
    type(cache_key_t) :: key
    key%name = 'L' // str(basis%order) // '_L2_' // str(basis%potential_order)
    key%text = 'two-bead Galerkin blocks of canonical lattice displacements (units of d); multipole_order = ' // &
               str(basis%order) // ', potential_order = ' // str(basis%potential_order) // ', unknowns_per_bead = ' // &
               str(basis%size) // ', bead_radius = ' // str(bead_radius) // '; blocks: ' // pair_block_rule // &
               '; block_formula_version = ' // str(block_formula_version)
  end function block_cache_key

  !> Collective over comm. first, n_local: this rank's rows (off-lattice case). `cache_file`
  !> (default: table%cache_file as set by the caller, else none; '' = none): the table cache
  !> of the lattice blocks (off-lattice stores do not use it). `expand` (default true): also the
  !> blocks of the whole displacement box (else the compact form only). The table is rebuilt from scratch.
  subroutine make_block_table(comm, basis, centres, first, n_local, table, err, cache_file, expand)
    integer, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :)
    integer(i8), intent(in) :: first, n_local
    type(block_table_t), intent(inout) :: table
    type(error_t), intent(inout) :: err
    character(len=*), intent(in), optional :: cache_file
    logical, intent(in), optional :: expand
    character(len=:), allocatable :: cache
    logical :: expanded
    real(dp) :: corner(3)
    integer :: i

    cache = ''
    if (allocated(table%cache_file)) cache = trim(table%cache_file)
    if (present(cache_file)) cache = trim(cache_file)
    table = block_table_t(cache_file=cache)
    table%block_size = basis%size
    corner = minval(centres, dim=2)
    allocate (table%lattice(3, size(centres, 2)))
    do i = 1, size(centres, 2)
      table%lattice(:, i) = nint(centres(:, i) - corner)
    end do
    table%on_lattice = all(abs(centres - spread(corner, 2, size(centres, 2)) - table%lattice) <= lattice_tolerance)
    if (table%on_lattice) then
      table%span = maxval(table%lattice, dim=2)
      expanded = .true.
      if (present(expand)) expanded = expand
      call fill_lattice_table(comm, basis, expanded, table, err)
    else
      deallocate (table%lattice)
      call fill_pair_store(comm, basis, centres, first, n_local, table, err)
    end if
  end subroutine make_block_table

  !> The canonical blocks (d_1 >= d_2 >= d_3 >= 0, c_k <= the k-th largest span: exactly the
  !> sorted |d| of the box's displacements) from the axial table shared over the ranks, those not found
  !> in the table cache; the D_Q dense and by rows; with `expand`, also every block of the box by
  !> the lattice symmetries on the half box and A(-d) = A(d)^T on the other half.
  subroutine fill_lattice_table(comm, basis, expand, table, err)
    integer, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    logical, intent(in) :: expand
    type(block_table_t), intent(inout) :: table
    type(error_t), intent(inout) :: err
    integer :: width(3), n_blocks, centre_index, rank, n_ranks, ierr, nb, h, index, d(3), c(3), s, n_canonical, mine, &
               n_missing, extent(3), i, j, k
    integer, allocatable :: counts(:), offsets(:), canonical_list(:, :), missing(:), cached_list(:, :)
    real(dp), allocatable :: gathered(:, :, :), cached(:, :, :)
    logical, allocatable :: known(:)
    logical :: caching
    type(error_t) :: cache_err, write_err
    type(axial_table_t) :: axial
    real(dp) :: bytes
    integer :: stat

    nb = basis%size
    width = 2 * table%span + 1
    extent = sorted_descending(table%span)
    if (expand) then
      bytes = product(real(width, dp)) * nb * nb * 8   ! in real arithmetic: product(width) may overflow
      if (bytes > max_store_bytes) then
        call raise(err, 'the block table of this model needs ' // str(bytes / 1.0e9_dp) // ' GB per rank (box ' // &
                   str(width(1)) // ' x ' // str(width(2)) // ' x ' // str(width(3)) // ' displacements, ' // &
                   str(nb) // ' unknowns per bead); the limit is ' // str(max_store_bytes / 1.0e9_dp) // &
                   ' GB: use the FFT operator')
        return
      end if
    end if

    ! The canonical displacements, numbered in the order c(3) slowest: canonical_id(c) = 0 for
    ! c = 0 (the self block is the operator's business) and for unsorted c.
    allocate (table%canonical_id(0:extent(1), 0:extent(2), 0:extent(3)), stat=stat)
    if (stat == 0) allocate (canonical_list(3, canonical_count(extent)), stat=stat)
    if (stat /= 0) then
      call raise(err, 'could not allocate the index of the canonical lattice displacements (extent ' // &
                 str(extent(1)) // ' x ' // str(extent(2)) // ' x ' // str(extent(3)) // ')')
      return
    end if
    table%canonical_id = 0
    n_canonical = 0
    do k = 0, extent(3)
      do j = k, extent(2)
        do i = j, extent(1)
          if (i == 0) cycle
          n_canonical = n_canonical + 1
          table%canonical_id(i, j, k) = n_canonical
          canonical_list(:, n_canonical) = [i, j, k]
        end do
      end do
    end do

    call MPI_Comm_rank(comm, rank, ierr)
    call MPI_Comm_size(comm, n_ranks, ierr)
    allocate (table%canonical_blocks(nb, nb, max(n_canonical, 1)), known(n_canonical), stat=stat)
    if (stat /= 0) then
      call raise(err, 'could not allocate the ' // str(n_canonical) // ' canonical lattice blocks (' // &
                 str(8.0_dp * nb * nb * n_canonical / 1.0e9_dp) // ' GB per rank)')
      return
    end if
    known = .false.
    ! Only rank 0 touches the file: its view decides, for every rank.
    caching = len(table%cache_file) > 0
    call MPI_Bcast(caching, 1, MPI_LOGICAL, 0, comm, ierr)
    if (caching) call take_cached_blocks()

    ! The rest shared over the ranks: each rank computes its share in place in
    ! the gathered array (no second copy of the blocks), then one Allgatherv.
    missing = pack([(h, h = 1, n_canonical)], .not. known)
    n_missing = size(missing)
    call even_shares(n_missing, n_ranks, counts, offsets)
    mine = counts(rank)
    if (n_missing == n_canonical) then
      call move_alloc(table%canonical_blocks, gathered)   ! nothing cached: fill the table itself
    else
      allocate (gathered(nb, nb, max(n_missing, 1)), stat=stat)
      if (stat /= 0) then
        call raise(err, 'could not allocate the ' // str(n_missing) // ' lattice blocks to compute')
        return
      end if
    end if
    ! Each block from the axial table turned to the displacement (theory.md T15): exact to
    ! rounding for every distance >= d, a quadrature per table node instead of one per block.
    if (n_missing > 0) call make_axial_table(basis, axial, comm)
    do h = offsets(rank) + 1, offsets(rank) + mine
      call rotated_block(axial, real(canonical_list(:, missing(h)), dp), gathered(:, :, h))
    end do
    counts = counts * nb * nb
    offsets = offsets * nb * nb
    call MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, gathered, counts, offsets, &
                        MPI_DOUBLE_PRECISION, comm, ierr)
    if (ierr /= MPI_SUCCESS) call raise(err, 'MPI_Allgatherv of the block table failed')
    if (n_missing == n_canonical) then
      call move_alloc(gathered, table%canonical_blocks)
    else
      table%canonical_blocks(:, :, missing) = gathered(:, :, 1:n_missing)
    end if
    table%computed_blocks = n_missing
    table%cached_blocks = n_canonical - n_missing
    if (caching .and. rank == 0 .and. n_missing > 0 .and. .not. err%failed) then
      ! The union of the cached entry (also blocks this body does not need) and the new blocks.
      call write_cached_blocks(table%cache_file, block_cache_key(basis), &
                               reshape([cached_list, canonical_list(:, missing)], [3, size(cached_list, 2) + n_missing]), &
                               reshape([cached, table%canonical_blocks(:, :, missing)], &
                                       [nb, nb, size(cached, 3) + n_missing]), write_err)
      if (write_err%failed) call warn_cache(table%cache_file, 'not updated: ' // write_err%message)
    end if
    if (allocated(gathered)) deallocate (gathered)

    allocate (table%transforms(nb, nb, n_symmetries))
    call basis_transforms(basis, table%transforms)
    call sparse_rows(table)
    if (.not. expand) return

    n_blocks = product(width)
    centre_index = table_block_index(table, [0, 0, 0])
    allocate (table%blocks(nb, nb, n_blocks))
    do index = centre_index + 1, n_blocks
      d = displacement_of(index)
      call canonical_displacement(d, c, s)
      call turned_block(table, s, table%canonical_id(c(1), c(2), c(3)), table%blocks(:, :, index))
      ! Displacement -d has index 2 centre_index - index.
      table%blocks(:, :, 2 * centre_index - index) = transpose(table%blocks(:, :, index))
    end do
    table%blocks(:, :, centre_index) = 0.0_dp   ! the self block is the operator's business

  contains

    !> Collective. Rank 0 reads the cache entry and takes the blocks of the canonical
    !> displacements this table needs (known = .true.); all ranks receive them. A cache that cannot
    !> be used gives a warning and no blocks. cached_list, cached: the entry, on rank 0.
    subroutine take_cached_blocks()
      integer, allocatable :: taken(:)
      integer :: jj, kk, n_taken, flags(n_canonical), e(3)
      real(dp), allocatable :: buffer(:, :, :)
      if (rank == 0) then
        call read_cached_blocks(table%cache_file, block_cache_key(basis), nb, cached_list, cached, cache_err)
        if (cache_err%failed) call warn_cache(table%cache_file, cache_err%message // &
                                              '; computing every block and rewriting the cache')
        do jj = 1, size(cached_list, 2)
          e = cached_list(:, jj)   ! canonical (checked on reading): 0 <= e <= e(1)
          if (any(e > extent)) cycle
          kk = table%canonical_id(e(1), e(2), e(3))
          if (kk == 0) cycle
          if (known(kk)) cycle
          known(kk) = .true.
          table%canonical_blocks(:, :, kk) = cached(:, :, jj)
        end do
      else
        allocate (cached_list(3, 0), cached(nb, nb, 0))
      end if
      flags = merge(1, 0, known)
      call MPI_Bcast(flags, n_canonical, MPI_INTEGER, 0, comm, ierr)
      known = flags == 1
      taken = pack([(jj, jj = 1, n_canonical)], known)
      n_taken = size(taken)
      if (n_taken == 0) return
      allocate (buffer(nb, nb, n_taken))
      if (rank == 0) buffer = table%canonical_blocks(:, :, taken)
      call MPI_Bcast(buffer, nb * nb * n_taken, MPI_DOUBLE_PRECISION, 0, comm, ierr)
      table%canonical_blocks(:, :, taken) = buffer
    end subroutine take_cached_blocks

    pure function displacement_of(linear) result(dd)
      integer, intent(in) :: linear
      integer :: dd(3), rest
      rest = linear - 1
      dd(1) = mod(rest, width(1)) - table%span(1)
      rest = rest / width(1)
      dd(2) = mod(rest, width(2)) - table%span(2)
      dd(3) = rest / width(2) - table%span(3)
    end function displacement_of
  end subroutine fill_lattice_table

  !> Number of canonical displacements c(1) >= c(2) >= c(3) >= 0, c /= 0, c(k) <= extent(k)
  !> (extent sorted descending).
  pure integer function canonical_count(extent)
    integer, intent(in) :: extent(3)
    integer :: j, k
    canonical_count = 0
    do k = 0, extent(3)
      do j = k, extent(2)
        canonical_count = canonical_count + (extent(1) - j + 1)
      end do
    end do
    canonical_count = canonical_count - 1   ! c = 0
  end function canonical_count

  pure function sorted_descending(v) result(w)
    integer, intent(in) :: v(3)
    integer :: w(3)
    w = [maxval(v), sum(v) - maxval(v) - minval(v), minval(v)]
  end function sorted_descending

  !> The rows of every D_Q without their zeros. D_Q is block-diagonal in (n, sigma) and, in the
  !> real harmonic basis, a signed permutation for the 16 symmetries that keep the z axis: a block
  !> entry then needs a few products instead of nb^2. Entries below 1e-13 are quadrature
  !> rounding of exact zeros (D_Q is orthogonal: entries are at most 1).
  subroutine sparse_rows(table)
    type(block_table_t), intent(inout) :: table
    real(dp), parameter :: zero_entry = 1.0e-13_dp
    integer :: nb, s, r, a, widest
    nb = table%block_size
    widest = maxval(count(abs(table%transforms) > zero_entry, dim=2))
    allocate (table%transform_count(nb, n_symmetries), table%transform_column(widest, nb, n_symmetries), &
              table%transform_value(widest, nb, n_symmetries))
    table%transform_count = 0
    table%transform_column = 1
    table%transform_value = 0.0_dp
    do s = 1, n_symmetries
      do r = 1, nb
        do a = 1, nb
          if (abs(table%transforms(r, a, s)) <= zero_entry) cycle
          table%transform_count(r, s) = table%transform_count(r, s) + 1
          table%transform_column(table%transform_count(r, s), r, s) = a
          table%transform_value(table%transform_count(r, s), r, s) = table%transforms(r, a, s)
        end do
      end do
    end do
  end subroutine sparse_rows

  !> The block of lattice displacement d from the compact table (0 for d = 0).
  function lattice_block(table, d) result(block)
    type(block_table_t), intent(in) :: table
    integer, intent(in) :: d(3)
    real(dp) :: block(table%block_size, table%block_size)
    integer :: c(3), s
    if (all(d == 0)) then
      block = 0.0_dp
      return
    end if
    call canonical_displacement(d, c, s)
    call turned_block(table, s, table%canonical_id(c(1), c(2), c(3)), block)
  end function lattice_block

  !> block = D_s A_k D_s^T, canonical block k turned by lattice symmetry s: two BLAS products
  !> (the intrinsic matmul took most of a high-L job's set-up: 120 x 120 at L = 6).
  subroutine turned_block(table, s, k, block)
    type(block_table_t), intent(in) :: table
    integer, intent(in) :: s, k
    real(dp), intent(out) :: block(:, :)
    real(dp) :: half(table%block_size, table%block_size)
    integer :: nb
    nb = table%block_size
    call dgemm('N', 'T', nb, nb, nb, 1.0_dp, table%canonical_blocks(:, :, k), nb, table%transforms(:, :, s), nb, &
               0.0_dp, half, nb)   ! A_k D_s^T
    call dgemm('N', 'N', nb, nb, nb, 1.0_dp, table%transforms(:, :, s), nb, half, nb, 0.0_dp, block, nb)
  end subroutine turned_block

  !> values(e) = A(d)(rows(e), columns(e)) from the compact table (0 for d = 0).
  pure subroutine lattice_block_entries(table, d, rows, columns, values)
    type(block_table_t), intent(in) :: table
    integer, intent(in) :: d(3), rows(:), columns(:)
    real(dp), intent(out) :: values(:)
    type(entry_terms_t) :: terms
    integer :: c(3), s
    values = 0.0_dp
    if (all(d == 0)) return
    call canonical_displacement(d, c, s)
    call make_entry_terms(table, rows, columns, terms)
    call entries_by_terms(terms, s, table%canonical_blocks(:, :, table%canonical_id(c(1), c(2), c(3))), values)
  end subroutine lattice_block_entries

  !> The terms of the entries (rows(e), columns(e)) under every lattice symmetry:
  !> (D A D^T)(r, t) = sum_a sum_b D(r, a) D(t, b) A(a, b) over the nonzeros of D's rows only.
  pure subroutine make_entry_terms(table, rows, columns, terms)
    type(block_table_t), intent(in) :: table
    integer, intent(in) :: rows(:), columns(:)
    type(entry_terms_t), intent(out) :: terms
    integer :: nb, widest, e, s, a, b, r, t, j
    nb = table%block_size
    widest = size(table%transform_column, 1)**2
    allocate (terms%count(size(rows), n_symmetries), terms%index(widest, size(rows), n_symmetries), &
              terms%value(widest, size(rows), n_symmetries))
    terms%index = 1
    terms%value = 0.0_dp
    do s = 1, n_symmetries
      do e = 1, size(rows)
        r = rows(e)
        t = columns(e)
        j = 0
        do a = 1, table%transform_count(r, s)
          do b = 1, table%transform_count(t, s)
            j = j + 1
            terms%index(j, e, s) = table%transform_column(a, r, s) + nb * (table%transform_column(b, t, s) - 1)
            terms%value(j, e, s) = table%transform_value(a, r, s) * table%transform_value(b, t, s)
          end do
        end do
        terms%count(e, s) = j
      end do
    end do
  end subroutine make_entry_terms

  !> values(e) = entry e of D_s A D_s^T (make_entry_terms) for the block A.
  pure subroutine entries_by_terms(terms, s, block, values)
    type(entry_terms_t), intent(in) :: terms
    integer, intent(in) :: s
    real(dp), intent(in) :: block(*)   ! nb x nb, column-major
    real(dp), intent(out) :: values(:)
    integer :: e, j
    do e = 1, size(values)
      values(e) = 0.0_dp
      do j = 1, terms%count(e, s)
        values(e) = values(e) + terms%value(j, e, s) * block(terms%index(j, e, s))
      end do
    end do
  end subroutine entries_by_terms

  subroutine fill_pair_store(comm, basis, centres, first, n_local, table, err)
    integer, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :)
    integer(i8), intent(in) :: first, n_local
    type(block_table_t), intent(inout) :: table
    type(error_t), intent(inout) :: err
    integer :: nb, n, i, j
    real(dp) :: bytes
    type(axial_table_t) :: axial
    nb = basis%size
    n = size(centres, 2)
    bytes = real(n, dp) * n_local * nb * nb * 8
    if (bytes > max_store_bytes) then
      call raise(err, 'the beads are not on a cubic lattice of spacing d, and storing the blocks of ' // str(n) // &
                 ' beads needs ' // str(bytes / 1.0e9_dp) // ' GB per rank (limit ' // str(max_store_bytes / 1.0e9_dp) // &
                 ' GB): place the beads on the lattice or use more ranks')
      return
    end if
    allocate (table%blocks(nb, nb, n * n_local))
    ! Every block from the axial table turned to the pair (theory.md T15), not a quadrature each.
    call make_axial_table(basis, axial, comm)
    do i = 1, int(n_local)
      do j = 1, n
        if (j == first + i - 1) then
          table%blocks(:, :, (i - 1) * n + j) = 0.0_dp
        else
          call rotated_block(axial, centres(:, first + i - 1) - centres(:, j), table%blocks(:, :, (i - 1) * n + j))
        end if
      end do
    end do
    table%computed_blocks = size(axial%nodes)
  end subroutine fill_pair_store
end module beadmob_block_table
