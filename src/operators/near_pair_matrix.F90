!> A symmetric block-sparse matrix over bead pairs with a product of several vectors at once: the
!> pfft operator's near-pair correction C (theory.md T16). Each pair's block is kept once, in the
!> row of either bead (the caller chooses, e.g. to balance the ranks), and applied both ways,
!> C_ij x_j to row i and C_ij^T x_i to row j. A pass reads each block once for the whole batch: a
!> row of blocks makes two BLAS products over all its pairs and vectors (a product per vector,
!> PETSc's SBAIJ, read all blocks once per vector with one small BLAS call per block and way).
!> Columns on other ranks are gathered by one VecScatter per vector before the pass, and their
!> transposed contributions added back by the reverse scatter after it (each scatter finished
!> before the next begins: several in flight on one VecScatter failed in PETSc 3.18 to match
!> their ends to their starts, "Could not find pack").
module beadmob_near_pair_matrix
#include "petsc/finclude/petscvec.h"
  use petscvec
  use beadmob_kinds, only: dp, i8
  use beadmob_lapack, only: dgemm
  implicit none
  private
  public :: near_pair_matrix_t, make_near_pair_matrix, near_pair_product, destroy_near_pair_matrix, &
            hand_over_near_pair_matrix

  type :: near_pair_matrix_t
    integer :: block_size = 0
    integer :: n_local = 0                   ! this rank's beads (rows)
    !> The pairs of local row i are row_start(i) .. row_start(i + 1) - 1; column(p) is
    !> 1 .. n_local for this rank's beads, n_local + g for ghost g.
    integer, allocatable :: row_start(:), column(:)
    !> C_ij (block_size, block_size, pairs) of pair p = (i, column(p)); filled by the caller.
    real(dp), allocatable :: blocks(:, :, :)
    integer :: n_ghosts = 0                  ! column beads of other ranks
    VecScatter :: to_ghosts                  ! global vector -> the ghosts' unknowns (sequential)
    Vec, allocatable :: ghost_in(:), ghost_out(:)   ! one pair per vector of the largest batch yet
    !> Work of a pass: (block_size, vectors, n_local + n_ghosts), the batch interleaved per bead
    !> so that a block meets all its vectors as one small dense matrix.
    real(dp), allocatable :: x_work(:, :, :), y_work(:, :, :)
    logical :: created = .false.
  end type near_pair_matrix_t

contains

  !> Collective. The structure of C for this rank's rows first_bead .. first_bead + n_local - 1 of
  !> n_beads beads (1-based, global): pair p joins row bead pair_row(p) (ascending) and column bead
  !> pair_column(p), any bead; every pair of beads appears at most once (C_ij in row i or C_ji =
  !> C_ij^T in row j), the diagonal as (i, i). matrix%blocks is allocated for the caller to fill in
  !> the same order.
  subroutine make_near_pair_matrix(comm, block_size, n_beads, first_bead, n_local, pair_row, pair_column, matrix)
    MPI_Comm, intent(in) :: comm
    integer, intent(in) :: block_size
    integer(i8), intent(in) :: n_beads, first_bead, n_local
    integer, intent(in) :: pair_row(:), pair_column(:)
    type(near_pair_matrix_t), intent(out) :: matrix
    integer, allocatable :: ghost_of(:)
    PetscInt, allocatable :: ghost_block(:)
    integer :: p, i, c, first, last
    IS :: from, to
    Vec :: template, ghosts
    PetscErrorCode :: ierr
    matrix%block_size = block_size
    matrix%n_local = int(n_local)
    first = int(first_bead)
    last = int(first_bead + n_local - 1)
    allocate (matrix%row_start(matrix%n_local + 1), matrix%column(size(pair_row)))
    allocate (matrix%blocks(block_size, block_size, size(pair_row)))
    matrix%row_start = 0
    do p = 1, size(pair_row)
      i = pair_row(p) - int(first_bead) + 1
      matrix%row_start(i + 1) = matrix%row_start(i + 1) + 1
    end do
    matrix%row_start(1) = 1
    do i = 1, matrix%n_local
      matrix%row_start(i + 1) = matrix%row_start(i + 1) + matrix%row_start(i)
    end do
    ! Ghosts: the columns of other ranks' beads, numbered in increasing bead order.
    allocate (ghost_of(int(n_beads)))
    ghost_of = 0
    do p = 1, size(pair_column)
      if (pair_column(p) < first .or. pair_column(p) > last) ghost_of(pair_column(p)) = 1
    end do
    matrix%n_ghosts = 0
    do c = 1, int(n_beads)
      if (ghost_of(c) == 0) cycle
      matrix%n_ghosts = matrix%n_ghosts + 1
      ghost_of(c) = matrix%n_ghosts
    end do
    allocate (ghost_block(matrix%n_ghosts))
    do c = 1, int(n_beads)
      if (ghost_of(c) > 0) ghost_block(ghost_of(c)) = c - 1
    end do
    do p = 1, size(pair_column)
      c = pair_column(p)
      if (c < first .or. c > last) then
        matrix%column(p) = matrix%n_local + ghost_of(c)
      else
        matrix%column(p) = c - first + 1
      end if
    end do
    PetscCallA(VecCreateMPI(comm, int(n_local) * block_size, int(n_beads) * block_size, template, ierr))
    PetscCallA(VecCreateSeq(PETSC_COMM_SELF, matrix%n_ghosts * block_size, ghosts, ierr))
    PetscCallA(ISCreateBlock(PETSC_COMM_SELF, block_size, matrix%n_ghosts, ghost_block, PETSC_COPY_VALUES, from, ierr))
    PetscCallA(ISCreateStride(PETSC_COMM_SELF, matrix%n_ghosts * block_size, 0, 1, to, ierr))
    PetscCallA(VecScatterCreate(template, from, ghosts, to, matrix%to_ghosts, ierr))
    PetscCallA(ISDestroy(from, ierr))
    PetscCallA(ISDestroy(to, ierr))
    PetscCallA(VecDestroy(template, ierr))
    PetscCallA(VecDestroy(ghosts, ierr))
    allocate (matrix%ghost_in(0), matrix%ghost_out(0))
    matrix%created = .true.
  end subroutine make_near_pair_matrix

  !> Collective: y(v) = y(v) + C x(v) for every vector of the batch.
  subroutine near_pair_product(matrix, x, y)
    type(near_pair_matrix_t), intent(inout) :: matrix
    Vec, intent(in) :: x(:)
    Vec, intent(in) :: y(:)   ! PETSc handles: the vectors behind them are written
    PetscScalar, pointer :: values(:)
    integer :: v, n_vectors, nb, n_columns
    PetscErrorCode :: ierr
    n_vectors = size(x)
    nb = matrix%block_size
    n_columns = matrix%n_local + matrix%n_ghosts
    if (size(matrix%ghost_in) < n_vectors) call make_ghost_vectors(matrix, n_vectors)
    if (allocated(matrix%x_work)) then
      if (size(matrix%x_work, 2) /= n_vectors) deallocate (matrix%x_work, matrix%y_work)
    end if
    if (.not. allocated(matrix%x_work)) then
      allocate (matrix%x_work(nb, n_vectors, n_columns), matrix%y_work(nb, n_vectors, n_columns))
    end if
    do v = 1, n_vectors
      PetscCallA(VecScatterBegin(matrix%to_ghosts, x(v), matrix%ghost_in(v), INSERT_VALUES, SCATTER_FORWARD, ierr))
      PetscCallA(VecScatterEnd(matrix%to_ghosts, x(v), matrix%ghost_in(v), INSERT_VALUES, SCATTER_FORWARD, ierr))
      PetscCallA(VecGetArrayReadF90(x(v), values, ierr))
      matrix%x_work(:, v, 1:matrix%n_local) = reshape(values, [nb, matrix%n_local])
      PetscCallA(VecRestoreArrayReadF90(x(v), values, ierr))
      PetscCallA(VecGetArrayReadF90(matrix%ghost_in(v), values, ierr))
      matrix%x_work(:, v, matrix%n_local + 1:) = reshape(values, [nb, matrix%n_ghosts])
      PetscCallA(VecRestoreArrayReadF90(matrix%ghost_in(v), values, ierr))
    end do
    call multiply_pairs(nb, n_vectors, n_columns, matrix%row_start, matrix%column, matrix%blocks, matrix%x_work, &
                        matrix%y_work)
    do v = 1, n_vectors
      PetscCallA(VecGetArrayF90(matrix%ghost_out(v), values, ierr))
      values = reshape(matrix%y_work(:, v, matrix%n_local + 1:), [nb * matrix%n_ghosts])
      PetscCallA(VecRestoreArrayF90(matrix%ghost_out(v), values, ierr))
      PetscCallA(VecScatterBegin(matrix%to_ghosts, matrix%ghost_out(v), y(v), ADD_VALUES, SCATTER_REVERSE, ierr))
      PetscCallA(VecScatterEnd(matrix%to_ghosts, matrix%ghost_out(v), y(v), ADD_VALUES, SCATTER_REVERSE, ierr))
      PetscCallA(VecGetArrayF90(y(v), values, ierr))
      values = values + reshape(matrix%y_work(:, v, 1:matrix%n_local), [nb * matrix%n_local])
      PetscCallA(VecRestoreArrayF90(y(v), values, ierr))
    end do
  end subroutine near_pair_product

  !> y = C x over the interleaved batch: for pair (i, j), y_i += C_ij x_j and, off the diagonal,
  !> y_j += C_ij^T x_i. A row's blocks are one nb x (nb k) matrix in memory, so each row is two
  !> BLAS products over all its pairs and vectors: y_i += [C_i1 .. C_ik] [x_1; ..; x_k] and
  !> [z_1; ..; z_k] = [C_i1 .. C_ik]^T x_i, z_m added to y of column m.
  subroutine multiply_pairs(nb, n_vectors, n_columns, row_start, column, blocks, x, y)
    integer, intent(in) :: nb, n_vectors, n_columns, row_start(:), column(:)
    real(dp), intent(in) :: blocks(nb, nb, size(column)), x(nb, n_vectors, n_columns)
    real(dp), intent(out) :: y(nb, n_vectors, n_columns)
    real(dp), allocatable :: stacked(:, :, :), image(:, :, :)
    integer :: i, p, c, m, k
    k = 0
    do i = 1, size(row_start) - 1
      k = max(k, row_start(i + 1) - row_start(i))
    end do
    allocate (stacked(nb, k, n_vectors), image(nb, k, n_vectors))
    y = 0.0_dp
    do i = 1, size(row_start) - 1
      k = row_start(i + 1) - row_start(i)
      if (k == 0) cycle
      p = row_start(i)
      do m = 1, k
        stacked(:, m, :) = x(:, :, column(p + m - 1))
      end do
      call dgemm('N', 'N', nb, n_vectors, nb * k, 1.0_dp, blocks(1, 1, p), nb, stacked, nb * size(stacked, 2), 1.0_dp, &
                 y(1, 1, i), nb)
      call dgemm('T', 'N', nb * k, n_vectors, nb, 1.0_dp, blocks(1, 1, p), nb, x(1, 1, i), nb, 0.0_dp, image, &
                 nb * size(image, 2))
      do m = 1, k
        c = column(p + m - 1)
        if (c /= i) y(:, :, c) = y(:, :, c) + image(:, m, :)
      end do
    end do
  end subroutine multiply_pairs

  !> The ghosts' sequential vectors for batches of up to n_vectors.
  subroutine make_ghost_vectors(matrix, n_vectors)
    type(near_pair_matrix_t), intent(inout) :: matrix
    integer, intent(in) :: n_vectors
    PetscErrorCode :: ierr
    integer :: v
    call destroy_ghost_vectors(matrix)
    allocate (matrix%ghost_in(n_vectors), matrix%ghost_out(n_vectors))
    do v = 1, n_vectors
      PetscCallA(VecCreateSeq(PETSC_COMM_SELF, matrix%n_ghosts * matrix%block_size, matrix%ghost_in(v), ierr))
      PetscCallA(VecDuplicate(matrix%ghost_in(v), matrix%ghost_out(v), ierr))
    end do
  end subroutine make_ghost_vectors

  subroutine destroy_ghost_vectors(matrix)
    type(near_pair_matrix_t), intent(inout) :: matrix
    PetscErrorCode :: ierr
    integer :: v
    if (.not. allocated(matrix%ghost_in)) return
    do v = 1, size(matrix%ghost_in)
      PetscCallA(VecDestroy(matrix%ghost_in(v), ierr))
      PetscCallA(VecDestroy(matrix%ghost_out(v), ierr))
    end do
    deallocate (matrix%ghost_in, matrix%ghost_out)
  end subroutine destroy_ghost_vectors

  !> `to` takes over what `from` holds (its arrays moved, its scatter handle passed on); `from`
  !> is left empty.
  subroutine hand_over_near_pair_matrix(from, to)
    type(near_pair_matrix_t), intent(inout) :: from
    type(near_pair_matrix_t), intent(out) :: to
    to%block_size = from%block_size
    to%n_local = from%n_local
    to%n_ghosts = from%n_ghosts
    to%to_ghosts = from%to_ghosts
    call move_alloc(from%row_start, to%row_start)
    call move_alloc(from%column, to%column)
    call move_alloc(from%blocks, to%blocks)
    call move_alloc(from%ghost_in, to%ghost_in)
    call move_alloc(from%ghost_out, to%ghost_out)
    if (allocated(from%x_work)) deallocate (from%x_work, from%y_work)
    to%created = from%created
    from%created = .false.
  end subroutine hand_over_near_pair_matrix

  subroutine destroy_near_pair_matrix(matrix)
    type(near_pair_matrix_t), intent(inout) :: matrix
    PetscErrorCode :: ierr
    if (.not. matrix%created) return
    call destroy_ghost_vectors(matrix)
    PetscCallA(VecScatterDestroy(matrix%to_ghosts, ierr))
    if (allocated(matrix%x_work)) deallocate (matrix%x_work, matrix%y_work)
    deallocate (matrix%row_start, matrix%column, matrix%blocks)
    matrix%created = .false.
  end subroutine destroy_near_pair_matrix
end module beadmob_near_pair_matrix
