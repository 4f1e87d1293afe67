!> The near-field part of the multipole operator as an assembled, distributed PETSc block matrix
!> (block size = unknowns per bead, theory.md T6): the single-bead blocks plus the two-bead blocks
!> of every pair closer than a radius and of every pair in the same cluster (a cube of
!> cluster_edge x cluster_edge x cluster_edge lattice cells). Cluster blocks are exact principal
!> submatrices of the SPD operator, so the matrix stays SPD with clusters alone, which a radius
!> >= 1 does not guarantee (docs/theory.md T11). It is the preconditioning matrix of the Krylov solves
!> (method.md, "Preconditioning"): factorised by MUMPS through PETSc by default, or used by any
!> other PETSc preconditioner (-pc_type pbjacobi = the single-bead blocks alone, bjacobi, asm, ...).
!> Beads on the lattice find their neighbours through a grid of lattice sites and share the blocks
!> by displacement; other bead sets scan all pairs (small models only).
module beadmob_near_field_matrix
#include "petsc/finclude/petscmat.h"
  use petscmat
  use beadmob_kinds, only: dp, i8
  use beadmob_multipole_basis, only: multipole_basis_t
  use beadmob_pair_blocks, only: pair_block
  use beadmob_unit_lattice, only: on_unit_lattice
  implicit none
  private
  public :: assemble_near_field

contains

  !> Collective. Rows of beads first..first+n_local-1; `radius` in d (pairs with centre
  !> distance <= radius); cluster_edge > 0 adds the pairs within the same cube of that edge (d),
  !> cubes counted from the bead set's lower corner; `self_block` the single-bead block. Returns
  !> the number of pair blocks this rank stored.
  subroutine assemble_near_field(comm, basis, self_block, centres, first, n_local, radius, cluster_edge, matrix, &
                                 n_pairs)
    MPI_Comm, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: self_block(:, :), centres(:, :), radius
    integer, intent(in) :: cluster_edge
    integer(i8), intent(in) :: first, n_local
    Mat, intent(out) :: matrix
    integer(i8), intent(out) :: n_pairs
    integer, allocatable :: site(:, :, :), lattice(:, :), offsets(:, :), cluster(:, :), offset_number(:, :, :)
    integer(i8), allocatable :: columns(:)
    real(dp), allocatable :: offset_blocks(:, :, :), block(:, :)
    PetscInt, allocatable :: diagonal_count(:), off_diagonal_count(:), diagonal_upper(:), off_diagonal_upper(:)
    PetscInt :: nb, local_size, global_size, row_index(1), column_index(1)
    PetscErrorCode :: ierr
    real(dp) :: corner(3)
    integer(i8) :: i, bead, k, n_columns, last
    integer :: n_offsets, reach, dx, dy, dz, c(3)
    logical :: lattice_model
    MatType :: matrix_type

    nb = basis%size
    last = first + n_local - 1
    lattice_model = on_unit_lattice(centres)
    reach = max(floor(radius + 1.0e-9_dp), cluster_edge - 1)
    allocate (columns(64), block(nb, nb))
    corner = minval(centres, dim=2)
    allocate (cluster(3, size(centres, 2)))
    cluster = 0
    if (cluster_edge > 0) cluster = floor((centres - spread(corner, 2, size(centres, 2))) / cluster_edge + 1.0e-9_dp)

    if (lattice_model) then
      ! Lattice sites -> bead number, and the blocks of every offset within the radius.
      allocate (lattice(3, size(centres, 2)))
      lattice = nint(centres - spread(corner, 2, size(centres, 2)))
      allocate (site(-reach:maxval(lattice(1, :)) + reach, -reach:maxval(lattice(2, :)) + reach, &
                     -reach:maxval(lattice(3, :)) + reach))
      site = 0
      do i = 1, size(centres, 2)
        site(lattice(1, i), lattice(2, i), lattice(3, i)) = int(i)
      end do
      allocate (offsets(3, (2 * reach + 1)**3), offset_blocks(nb, nb, (2 * reach + 1)**3))
      allocate (offset_number(-reach:reach, -reach:reach, -reach:reach))
      offset_number = 0
      n_offsets = 0
      do dz = -reach, reach
        do dy = -reach, reach
          do dx = -reach, reach
            if (dx == 0 .and. dy == 0 .and. dz == 0) cycle
            if (real(dx * dx + dy * dy + dz * dz, dp) > radius**2 * (1.0_dp + 1.0e-9_dp) .and. &
                any(abs([dx, dy, dz]) >= cluster_edge)) cycle
            n_offsets = n_offsets + 1
            offsets(:, n_offsets) = [dx, dy, dz]
            offset_number(dx, dy, dz) = n_offsets
            ! Row bead minus column bead = -offset (the column bead sits at +offset).
            call pair_block(basis, -real([dx, dy, dz], dp), offset_blocks(:, :, n_offsets))
          end do
        end do
      end do
    end if

    ! Preallocation: neighbour counts per block row, inside and outside this rank's columns.
    ! Block counts per row, inside and outside this rank's columns, all and upper triangle (SBAIJ).
    allocate (diagonal_count(n_local), off_diagonal_count(n_local), diagonal_upper(n_local), off_diagonal_upper(n_local))
    do i = 1, n_local
      bead = first + i - 1
      call neighbours_of(bead, n_columns)
      diagonal_count(i) = 1 + count(columns(1:n_columns) >= first .and. columns(1:n_columns) <= last)
      off_diagonal_count(i) = int(n_columns) - (diagonal_count(i) - 1)
      diagonal_upper(i) = 1 + count(columns(1:n_columns) > bead .and. columns(1:n_columns) <= last)
      off_diagonal_upper(i) = count(columns(1:n_columns) > last)
    end do
    local_size = int(n_local) * nb
    global_size = size(centres, 2) * nb
    PetscCallA(MatCreate(comm, matrix, ierr))
    PetscCallA(MatSetSizes(matrix, local_size, local_size, global_size, global_size, ierr))
    PetscCallA(MatSetType(matrix, MATSBAIJ, ierr))   ! symmetric: one half stored, MUMPS Cholesky
    PetscCallA(MatSetOptionsPrefix(matrix, 'near_field_', ierr))
    PetscCallA(MatSetFromOptions(matrix, ierr))
    PetscCallA(MatXAIJSetPreallocation(matrix, nb, diagonal_count, off_diagonal_count, diagonal_upper, off_diagonal_upper, ierr))
    PetscCallA(MatSetOption(matrix, MAT_ROW_ORIENTED, PETSC_FALSE, ierr))   ! Fortran blocks are column-major
    PetscCallA(MatGetType(matrix, matrix_type, ierr))
    if (index(matrix_type, 'sbaij') > 0) then
      PetscCallA(MatSetOption(matrix, MAT_IGNORE_LOWER_TRIANGULAR, PETSC_TRUE, ierr))   ! SBAIJ stores one half
    end if
    PetscCallA(MatSetOption(matrix, MAT_SYMMETRIC, PETSC_TRUE, ierr))
    PetscCallA(MatSetOption(matrix, MAT_SYMMETRY_ETERNAL, PETSC_TRUE, ierr))

    n_pairs = 0
    do i = 1, n_local
      bead = first + i - 1
      row_index(1) = int(bead - 1)
      PetscCallA(MatSetValuesBlocked(matrix, 1, row_index, 1, row_index, reshape(self_block, [nb * nb]), INSERT_VALUES, ierr))
      call neighbours_of(bead, n_columns)
      do k = 1, n_columns
        column_index(1) = int(columns(k) - 1)
        if (lattice_model) then
          c = lattice(:, columns(k)) - lattice(:, bead)
          block = offset_blocks(:, :, offset_number(c(1), c(2), c(3)))
        else
          call pair_block(basis, centres(:, bead) - centres(:, columns(k)), block)
        end if
        PetscCallA(MatSetValuesBlocked(matrix, 1, row_index, 1, column_index, reshape(block, [nb * nb]), INSERT_VALUES, ierr))
        n_pairs = n_pairs + 1
      end do
    end do
    PetscCallA(MatAssemblyBegin(matrix, MAT_FINAL_ASSEMBLY, ierr))
    PetscCallA(MatAssemblyEnd(matrix, MAT_FINAL_ASSEMBLY, ierr))

  contains

    !> columns(1:n) = the other beads within the radius of `bead` (1-based numbers).
    subroutine neighbours_of(bead, n)
      integer(i8), intent(in) :: bead
      integer(i8), intent(out) :: n
      integer(i8) :: j
      integer :: q
      n = 0
      if (lattice_model) then
        do q = 1, n_offsets
          c = lattice(:, bead) + offsets(:, q)
          if (any(c < lbound(site) .or. c > ubound(site))) cycle
          if (site(c(1), c(2), c(3)) == 0) cycle
          if (.not. in_near_field(bead, int(site(c(1), c(2), c(3)), i8))) cycle
          n = n + 1
          if (n > size(columns)) columns = [columns, columns]
          columns(n) = site(c(1), c(2), c(3))
        end do
      else
        do j = 1, size(centres, 2)
          if (j == bead) cycle
          if (.not. in_near_field(bead, j)) cycle
          n = n + 1
          if (n > size(columns)) columns = [columns, columns]
          columns(n) = j
        end do
      end if
    end subroutine neighbours_of

    !> Whether the pair (a, b) enters the matrix: within the radius or in the same cluster.
    pure logical function in_near_field(a, b)
      integer(i8), intent(in) :: a, b
      in_near_field = norm2(centres(:, a) - centres(:, b)) <= radius * (1.0_dp + 1.0e-9_dp)
      if (cluster_edge > 0) in_near_field = in_near_field .or. all(cluster(:, a) == cluster(:, b))
    end function in_near_field
  end subroutine assemble_near_field
end module beadmob_near_field_matrix
