!> Tests src/operators/near_pair_matrix.F90 (the pfft operator's near-pair correction, kept as its
!> upper triangle of blocks and applied to a batch of vectors at once). CTest: test_near_pair_matrix_np1/np2.
!>  1. A batch of three products y + C x equals the dense symmetric matrix built independently
!>     from the same blocks (C_ij above the diagonal, C_ij^T below it) times x, to 1e-13 of the
!>     result's max-norm; each pair kept in the row of either bead (by the parity of i + j), so
!>     on 2 ranks both ranks hold pairs across the boundary (ghost columns below and above the
!>     rank's beads and the reverse scatter of their transposed contributions).
!>  2. A batch of one vector gives the same as the batch of three, and the matrix handed over to
!>     another object (hand_over_near_pair_matrix) still gives it.
program test_near_pair_matrix
#include "petsc/finclude/petscvec.h"
  use petscvec
  use beadmob_kinds, only: dp, i8
  use beadmob_testing
  use beadmob_random_vectors, only: fill_random, hash_uniform
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t, make_run_context, block_range
  use beadmob_near_pair_matrix, only: near_pair_matrix_t, make_near_pair_matrix, near_pair_product, &
                                      destroy_near_pair_matrix, hand_over_near_pair_matrix
  implicit none
  integer, parameter :: n_beads = 23, nb = 5, n_vectors = 3
  type(test_suite_t) :: suite
  type(run_context_t) :: ctx
  type(near_pair_matrix_t) :: matrix, taken
  integer(i8) :: first, count
  integer, allocatable :: pair_row(:), pair_column(:)
  real(dp) :: dense(n_beads * nb, n_beads * nb), worst
  real(dp), allocatable :: stored(:, :, :)
  integer, allocatable :: order(:)
  Vec :: x(n_vectors), y(n_vectors), single(1)
  integer :: i, j, p, v
  PetscErrorCode :: ierr

  PetscCallA(PetscInitialize(ierr))
  suite = start_tests('test_near_pair_matrix')
  ctx = make_run_context(PETSC_COMM_WORLD)
  call block_range(ctx, int(n_beads, i8), first, count)

  ! Pairs i <= j: the diagonal, near neighbours in the numbering and some far ones (across ranks),
  ! kept in the row of i (block C_ij) when i + j is odd, of j (block C_ji = C_ij^T) otherwise.
  allocate (pair_row(0), pair_column(0), stored(nb, nb, 0))
  dense = 0.0_dp
  do i = 1, n_beads
    do j = i, n_beads
      if (.not. paired(i, j)) cycle
      dense(block(i), block(j)) = pair_values(i, j)
      dense(block(j), block(i)) = transpose(pair_values(i, j))
      if (mod(i + j, 2) == 1 .or. i == j) then
        call keep(i, j, pair_values(i, j))
      else
        call keep(j, i, transpose(pair_values(i, j)))
      end if
    end do
  end do
  ! in row order, as the matrix takes them
  order = [(p, p = 1, size(pair_row))]
  do p = 2, size(order)
    do j = p, 2, -1
      if (pair_row(order(j - 1)) <= pair_row(order(j))) exit
      order([j - 1, j]) = order([j, j - 1])
    end do
  end do
  call make_near_pair_matrix(ctx%comm, nb, int(n_beads, i8), first, count, pair_row(order), pair_column(order), matrix)
  matrix%blocks = stored(:, :, order)

  do v = 1, n_vectors
    PetscCallA(VecCreateMPI(ctx%comm, int(count) * nb, n_beads * nb, x(v), ierr))
    PetscCallA(VecDuplicate(x(v), y(v), ierr))
    call fill_random(x(v), v)
    call fill_random(y(v), 10 + v)   ! the product adds to what y holds
  end do
  call near_pair_product(matrix, x, y)
  worst = 0.0_dp
  do v = 1, n_vectors
    worst = max(worst, difference_from_dense(x(v), y(v), v))
  end do
  call check(suite, worst <= 1.0e-13_dp, 'batch of ' // str(n_vectors) // ': y + C x = the dense product, ' // &
             'relative ' // str(worst))

  ! One vector at a time, after the matrix has changed hands.
  call hand_over_near_pair_matrix(matrix, taken)
  call check(suite, .not. matrix%created .and. taken%created, 'handed over: the new holder has it, the old one not')
  worst = 0.0_dp
  do v = 1, n_vectors
    call fill_random(y(v), 10 + v)
    single(1) = y(v)
    call near_pair_product(taken, [x(v)], single)
    worst = max(worst, difference_from_dense(x(v), y(v), v))
  end do
  call check(suite, worst <= 1.0e-13_dp, 'one vector at a time: y + C x = the dense product, relative ' // str(worst))

  do v = 1, n_vectors
    PetscCallA(VecDestroy(x(v), ierr))
    PetscCallA(VecDestroy(y(v), ierr))
  end do
  call destroy_near_pair_matrix(matrix)   ! empty: nothing to free
  call destroy_near_pair_matrix(taken)
  call finish_tests(suite)
  PetscCallA(PetscFinalize(ierr))

contains

  !> The pair (row, column) with its block, if the row is this rank's.
  subroutine keep(row, column, values)
    integer, intent(in) :: row, column
    real(dp), intent(in) :: values(nb, nb)
    if (row < first .or. row >= first + count) return
    pair_row = [pair_row, row]
    pair_column = [pair_column, column]
    stored = reshape([stored, values], [nb, nb, size(pair_row)])
  end subroutine keep

  logical function paired(i, j)
    integer, intent(in) :: i, j
    paired = j - i <= 2 .or. hash_uniform(int(1000 * i + j, i8)) < 0.2_dp
  end function paired

  !> The unknowns of bead i.
  pure function block(i) result(range)
    integer, intent(in) :: i
    integer :: range(nb), a
    range = [((i - 1) * nb + a, a = 1, nb)]
  end function block

  !> C_ij from the pair's numbers only; C_ii symmetric, as the pfft correction's.
  function pair_values(i, j) result(values)
    integer, intent(in) :: i, j
    real(dp) :: values(nb, nb)
    integer :: a, b
    do b = 1, nb
      do a = 1, nb
        values(a, b) = hash_uniform(int(((i * 97 + j) * 13 + a) * 17 + b, i8)) - 0.5_dp
      end do
    end do
    if (i == j) values = 0.5_dp * (values + transpose(values))
  end function pair_values

  !> max |y - (y0 + dense x)| / max |y0 + dense x| over this rank's rows (all ranks' worst), y0
  !> the fill of stream 10 + stream.
  real(dp) function difference_from_dense(xv, yv, stream) result(relative)
    Vec, intent(in) :: xv, yv
    integer, intent(in) :: stream
    Vec :: everything, initial
    VecScatter :: to_all
    PetscScalar, pointer :: all_x(:), mine(:), start(:)
    real(dp), allocatable :: expected(:)
    real(dp) :: largest, off
    PetscErrorCode :: ierr
    PetscCallA(VecScatterCreateToAll(xv, to_all, everything, ierr))
    PetscCallA(VecScatterBegin(to_all, xv, everything, INSERT_VALUES, SCATTER_FORWARD, ierr))
    PetscCallA(VecScatterEnd(to_all, xv, everything, INSERT_VALUES, SCATTER_FORWARD, ierr))
    PetscCallA(VecDuplicate(yv, initial, ierr))
    call fill_random(initial, 10 + stream)
    PetscCallA(VecGetArrayReadF90(everything, all_x, ierr))
    PetscCallA(VecGetArrayReadF90(initial, start, ierr))
    PetscCallA(VecGetArrayReadF90(yv, mine, ierr))
    expected = start + matmul(dense((first - 1) * nb + 1:(first + count - 1) * nb, :), all_x)
    largest = 0.0_dp
    off = 0.0_dp
    if (size(expected) > 0) then
      largest = maxval(abs(expected))
      off = maxval(abs(mine - expected))
    end if
    PetscCallA(VecRestoreArrayReadF90(yv, mine, ierr))
    PetscCallA(VecRestoreArrayReadF90(initial, start, ierr))
    PetscCallA(VecRestoreArrayReadF90(everything, all_x, ierr))
    call MPI_Allreduce(MPI_IN_PLACE, largest, 1, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr)
    call MPI_Allreduce(MPI_IN_PLACE, off, 1, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr)
    relative = off / largest
    PetscCallA(VecDestroy(initial, ierr))
    PetscCallA(VecDestroy(everything, ierr))
    PetscCallA(VecScatterDestroy(to_all, ierr))
  end function difference_from_dense
end program test_near_pair_matrix
