!> The two-bead blocks an operator product needs, computed once. Beads on a cubic lattice of
!> spacing d (the paper's models) have blocks that depend on the integer lattice displacement
!> only: one table over the displacement box [-span, span]^3 serves every pair. Quadrature is done
!> only for displacements that the 48 lattice symmetries and A(-r) = A(r)^T (theory.md T4) do not
!> relate, shared over the MPI ranks. Off-lattice bead sets
!> (bead files) store the blocks of this rank's rows for every column bead instead.
module beadmob_block_table
  use mpi
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_multipole_basis, only: multipole_basis_t
  use beadmob_pair_blocks, only: pair_block
  use beadmob_lattice_symmetry, only: n_symmetries, canonical_displacement, basis_transforms
  implicit none
  private
  public :: block_table_t, make_block_table, table_block_index, lattice_tolerance, on_unit_lattice

  !> Beads are on the lattice when every centre is within this distance (d) of a lattice point.
  real(dp), parameter :: lattice_tolerance = 1.0e-9_dp
  !> Largest block store allowed per rank (bytes) before refusing an off-lattice model.
  real(dp), parameter :: max_store_bytes = 8.0e9_dp

  type :: block_table_t
    logical :: on_lattice = .false.
    integer :: block_size = 0
    integer :: span(3) = 0
    integer, allocatable :: lattice(:, :)      ! (3, N) integer coordinates (lattice models)
    real(dp), allocatable :: blocks(:, :, :)   ! (nb, nb, n_blocks)
    integer(i8) :: computed_blocks = 0         ! blocks evaluated by quadrature (all ranks)
  end type block_table_t

contains

  pure integer function table_block_index(table, displacement)
    type(block_table_t), intent(in) :: table
    integer, intent(in) :: displacement(3)
    integer :: width(3)
    width = 2 * table%span + 1
    table_block_index = 1 + (displacement(1) + table%span(1)) + width(1) * ((displacement(2) + table%span(2)) &
                        + width(2) * (displacement(3) + table%span(3)))
  end function table_block_index

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

  !> Collective over comm. first, n_local: this rank's rows (off-lattice case).
  subroutine make_block_table(comm, basis, centres, first, n_local, table, err)
    integer, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :)
    integer(i8), intent(in) :: first, n_local
    type(block_table_t), intent(out) :: table
    type(error_t), intent(inout) :: err
    real(dp) :: corner(3)
    integer :: i

    table%block_size = basis%size
    corner = minval(centres, dim=2)
    allocate (table%lattice(3, size(centres, 2)))
    do i = 1, size(centres, 2)
      table%lattice(:, i) = nint(centres(:, i) - corner)
    end do
    table%on_lattice = all(abs(centres - spread(corner, 2, size(centres, 2)) - table%lattice) <= lattice_tolerance)
    if (table%on_lattice) then
      table%span = maxval(table%lattice, dim=2)
      call fill_lattice_table(comm, basis, table, err)
    else
      deallocate (table%lattice)
      call fill_pair_store(basis, centres, first, n_local, table, err)
    end if
  end subroutine make_block_table

  !> Every displacement of the box. Quadrature only for the canonical displacements
  !> (d_1 >= d_2 >= d_3 >= 0, shared over the ranks); the rest by the lattice symmetries,
  !> A(Q c) = D_Q A(c) D_Q^T, on the half box, and A(-d) = A(d)^T for the other half.
  subroutine fill_lattice_table(comm, basis, table, err)
    integer, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    type(block_table_t), intent(inout) :: table
    type(error_t), intent(inout) :: err
    integer :: width(3), n_blocks, centre_index, rank, n_ranks, ierr, nb, h, index, d(3), c(3), s, m, n_canonical, mine
    integer, allocatable :: counts(:), offsets(:), canonical_id(:, :, :), canonical_list(:, :)
    real(dp), allocatable :: canonical_blocks(:, :, :), computed(:, :, :), transforms(:, :, :)
    real(dp) :: bytes

    nb = basis%size
    width = 2 * table%span + 1
    n_blocks = product(width)
    bytes = real(n_blocks, dp) * nb * nb * 8
    if (bytes > max_store_bytes) then
      call raise(err, 'the block table of this model needs ' // str(bytes / 1.0e9_dp) // ' GB per rank (box ' // &
                 str(width(1)) // ' x ' // str(width(2)) // ' x ' // str(width(3)) // ' displacements, ' // &
                 str(nb) // ' unknowns per bead); the limit is ' // str(max_store_bytes / 1.0e9_dp) // ' GB')
      return
    end if
    centre_index = table_block_index(table, [0, 0, 0])

    ! The canonical displacements the half box needs.
    m = maxval(table%span)
    allocate (canonical_id(0:m, 0:m, 0:m), canonical_list(3, (m + 1)**3))
    canonical_id = 0
    n_canonical = 0
    do index = centre_index + 1, n_blocks
      call canonical_displacement(displacement_of(index), c, s)
      if (canonical_id(c(1), c(2), c(3)) == 0) then
        n_canonical = n_canonical + 1
        canonical_id(c(1), c(2), c(3)) = n_canonical
        canonical_list(:, n_canonical) = c
      end if
    end do

    call MPI_Comm_rank(comm, rank, ierr)
    call MPI_Comm_size(comm, n_ranks, ierr)
    allocate (counts(0:n_ranks - 1), offsets(0:n_ranks - 1))
    do h = 0, n_ranks - 1
      counts(h) = n_canonical / n_ranks + merge(1, 0, h < mod(n_canonical, n_ranks))
    end do
    offsets(0) = 0
    do h = 1, n_ranks - 1
      offsets(h) = offsets(h - 1) + counts(h - 1)
    end do
    mine = counts(rank)
    allocate (computed(nb, nb, max(mine, 1)), canonical_blocks(nb, nb, max(n_canonical, 1)))
    do h = 1, mine
      call pair_block(basis, real(canonical_list(:, offsets(rank) + h), dp), computed(:, :, h))
    end do
    counts = counts * nb * nb
    offsets = offsets * nb * nb
    call MPI_Allgatherv(computed, mine * nb * nb, MPI_DOUBLE_PRECISION, canonical_blocks, counts, offsets, &
                        MPI_DOUBLE_PRECISION, comm, ierr)
    if (ierr /= MPI_SUCCESS) call raise(err, 'MPI_Allgatherv of the block table failed')
    deallocate (computed)

    allocate (transforms(nb, nb, n_symmetries), table%blocks(nb, nb, n_blocks))
    call basis_transforms(basis, transforms)
    do index = centre_index + 1, n_blocks
      d = displacement_of(index)
      call canonical_displacement(d, c, s)
      table%blocks(:, :, index) = matmul(transforms(:, :, s), &
                                         matmul(canonical_blocks(:, :, canonical_id(c(1), c(2), c(3))), &
                                                transpose(transforms(:, :, s))))
      ! Displacement -d has index 2 centre_index - index.
      table%blocks(:, :, 2 * centre_index - index) = transpose(table%blocks(:, :, index))
    end do
    table%blocks(:, :, centre_index) = 0.0_dp   ! the self block is the operator's business
    table%computed_blocks = n_canonical

  contains

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

  subroutine fill_pair_store(basis, centres, first, n_local, table, err)
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :)
    integer(i8), intent(in) :: first, n_local
    type(block_table_t), intent(inout) :: table
    type(error_t), intent(inout) :: err
    integer :: nb, n, i, j
    real(dp) :: bytes
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
    do i = 1, int(n_local)
      do j = 1, n
        if (j == first + i - 1) then
          table%blocks(:, :, (i - 1) * n + j) = 0.0_dp
        else
          call pair_block(basis, centres(:, first + i - 1) - centres(:, j), table%blocks(:, :, (i - 1) * n + j))
        end if
      end do
    end do
    table%computed_blocks = n * n_local
  end subroutine fill_pair_store
end module beadmob_block_table
