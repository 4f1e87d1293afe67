!> The multipole operator of a bead model as a PETSc MATSHELL, distributed by beads: each rank
!> owns a contiguous range of beads (block size = unknowns per bead) and computes, for its beads i,
!>   y_i = S x_i + sum_{j /= i} A(R_i - R_j) x_j
!> with S the single-bead block and A the two-bead blocks from the block table (theory.md T4).
!> The whole x is gathered on every rank once per product (direct O(N^2) operator); a batch of
!> vectors (apply_many) is multiplied in one pass over the blocks.
module beadmob_bead_operator
#include "petsc/finclude/petscmat.h"
  use petscmat
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t
  use beadmob_multipole_basis, only: multipole_basis_t
  use beadmob_pair_blocks, only: self_block
  use beadmob_block_table, only: block_table_t, make_block_table, table_block_index
  use beadmob_multipole_operator, only: multipole_operator_t, operator_options_t
  use beadmob_operator_cost, only: job_size_t, operator_cost_t, canonical_blocks_of, quadrature_seconds, &
                                   lattice_blocks_seconds, direct_seconds, lattice_block_seconds, &
                                   lattice_entry_seconds, transform_bytes
  use beadmob_axial_table, only: axial_nodes
  implicit none
  private
  public :: bead_operator_t, create_bead_operator, destroy_bead_operator, create_bead_companion

  !> The MATSHELL context: what a product needs, set once.
  type, extends(multipole_operator_t) :: bead_operator_t
    type(block_table_t) :: table
    VecScatter :: gather
    Vec :: gathered
    logical :: made = .false.
  contains
    procedure :: create => create_direct
    procedure :: create_companion => direct_companion
    procedure :: destroy => destroy_direct
    procedure :: apply_many => apply_direct_many
    procedure, nopass :: cost => direct_cost
  end type bead_operator_t

  interface
    subroutine MatCreateShell(comm, m_local, n_local, m, n, context, matrix, ierr)
      use petscmat
      import :: bead_operator_t
      MPI_Comm :: comm
      PetscInt :: m_local, n_local, m, n
      type(bead_operator_t) :: context
      Mat :: matrix
      PetscErrorCode :: ierr
    end subroutine MatCreateShell
    subroutine MatShellGetContext(matrix, context, ierr)
      use petscmat
      import :: bead_operator_t
      Mat :: matrix
      type(bead_operator_t), pointer :: context
      PetscErrorCode :: ierr
    end subroutine MatShellGetContext
  end interface

contains

  !> multipole_operator_t%create: the cache file of the options (lattice models).
  subroutine create_direct(this, comm, basis, centres, first_bead, n_local, options, err)
    class(bead_operator_t), target, intent(inout) :: this
    MPI_Comm, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :)
    integer(i8), intent(in) :: first_bead, n_local
    type(operator_options_t), intent(in) :: options
    type(error_t), intent(inout) :: err
    Mat :: matrix
    if (allocated(options%cache_file)) this%table%cache_file = options%cache_file
    call create_bead_operator(comm, basis, centres, first_bead, n_local, this, matrix, err)
    if (err%failed) return
    this%matrix = matrix
    this%made = .true.
    this%on_lattice = this%table%on_lattice
    this%computed_blocks = this%table%computed_blocks
    this%cached_blocks = this%table%cached_blocks
  end subroutine create_direct

  subroutine direct_companion(this, comm, unknowns, companion, err)
    class(bead_operator_t), target, intent(inout) :: this
    MPI_Comm, intent(in) :: comm
    integer, intent(in) :: unknowns(:)
    class(multipole_operator_t), allocatable, target, intent(inout) :: companion
    type(error_t), intent(inout) :: err
    Mat :: matrix
    if (err%failed) return
    allocate (bead_operator_t :: companion)
    select type (companion)
    type is (bead_operator_t)
      call create_bead_companion(comm, this, unknowns, companion, matrix)
      companion%matrix = matrix
      companion%made = .true.
    end select
  end subroutine direct_companion

  !> multipole_operator_t%cost. Lattice: the canonical blocks (axial table) and the expanded
  !> box table on every rank; off the lattice: a block per pair of this rank's rows, from the
  !> axial table (2 L + 6 quadratures) turned to each pair (about a hundredth of a quadrature).
  !> The companion copies its sub-blocks; a product reads every block once.
  pure subroutine direct_cost(size, cost)
    type(job_size_t), intent(in) :: size
    type(operator_cost_t), intent(out) :: cost
    real(dp) :: block_bytes, pairs
    block_bytes = 8 * size%nb**2
    if (size%on_lattice) then
      cost%canonical_blocks = canonical_blocks_of(size%spans)
      cost%blocks = block_bytes * cost%canonical_blocks + transform_bytes(size)
      cost%kernel = block_bytes * product(real(2 * size%spans + 1, dp))
      cost%seconds_setup = lattice_blocks_seconds(size, cost%canonical_blocks)
    else
      cost%kernel = block_bytes * real(size%solve_beads, dp) * size%local_beads
      cost%seconds_setup = quadrature_seconds(size) * (axial_nodes(size%order) + &
                                                       real(size%solve_beads, dp) * size%local_beads / 100)
    end if
    cost%companion = cost%kernel * (size%nb_low / size%nb)**2
    pairs = real(size%solve_beads, dp) * size%local_beads
    if (size%on_lattice) then
      cost%seconds_product = (lattice_block_seconds + lattice_entry_seconds * size%nb**2) * pairs
      cost%seconds_low_product = (lattice_block_seconds + lattice_entry_seconds * size%nb_low**2) * pairs
    else
      cost%seconds_product = direct_seconds * size%nb**2 * pairs
      cost%seconds_low_product = direct_seconds * size%nb_low**2 * pairs
    end if
  end subroutine direct_cost

  subroutine destroy_direct(this)
    class(bead_operator_t), intent(inout) :: this
    Mat :: matrix
    if (.not. this%made) return
    matrix = this%matrix
    call destroy_bead_operator(this, matrix)
    this%made = .false.
  end subroutine destroy_direct

  !> Collective. `op` must stay in place (not be moved or copied) while `matrix` lives: PETSc
  !> keeps its address. On error (err set on some rank) no matrix is created.
  subroutine create_bead_operator(comm, basis, centres, first_bead, n_local, op, matrix, err)
    MPI_Comm, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :)
    integer(i8), intent(in) :: first_bead, n_local
    type(bead_operator_t), target, intent(inout) :: op
    Mat, intent(out) :: matrix
    type(error_t), intent(inout) :: err
    PetscErrorCode :: ierr
    integer :: failed_here, failed_anywhere

    op%block_size = basis%size
    op%n_beads = size(centres, 2, kind=i8)
    op%first_bead = first_bead
    op%n_local = n_local
    allocate (op%self_block(basis%size, basis%size))
    call self_block(basis, op%self_block)
    call make_block_table(comm, basis, centres, first_bead, n_local, op%table, err)
    failed_here = merge(1, 0, err%failed)
    call MPI_Allreduce(failed_here, failed_anywhere, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
    if (failed_anywhere /= 0) return
    call make_shell(comm, op, matrix)
  end subroutine create_bead_operator

  !> Collective. The operator of the sub-basis `unknowns` (indices into the parent's unknowns per
  !> bead, e.g. the order L - 1 functions of an order-L basis) on the same beads: the principal
  !> sub-blocks of the parent's blocks (a Galerkin entry depends on its two functions only,
  !> theory.md T14), copied, so no quadrature is repeated. `companion` must stay in place while
  !> `matrix` lives.
  subroutine create_bead_companion(comm, parent, unknowns, companion, matrix)
    MPI_Comm, intent(in) :: comm
    type(bead_operator_t), intent(in) :: parent
    integer, intent(in) :: unknowns(:)
    type(bead_operator_t), target, intent(inout) :: companion
    Mat, intent(out) :: matrix
    companion%block_size = size(unknowns)
    companion%n_beads = parent%n_beads
    companion%first_bead = parent%first_bead
    companion%n_local = parent%n_local
    companion%self_block = parent%self_block(unknowns, unknowns)
    companion%table%on_lattice = parent%table%on_lattice
    companion%table%block_size = size(unknowns)
    companion%table%span = parent%table%span
    if (allocated(parent%table%lattice)) companion%table%lattice = parent%table%lattice
    companion%table%blocks = parent%table%blocks(unknowns, unknowns, :)
    call make_shell(comm, companion, matrix)
  end subroutine create_bead_companion

  !> The MATSHELL of a set-up operator and the gather of x its products need.
  subroutine make_shell(comm, op, matrix)
    MPI_Comm, intent(in) :: comm
    type(bead_operator_t), target, intent(inout) :: op
    Mat, intent(out) :: matrix
    PetscErrorCode :: ierr
    PetscInt :: local_size, global_size
    Vec :: template
    local_size = int(op%n_local * op%block_size)
    global_size = int(op%n_beads * op%block_size)
    PetscCallA(MatCreateShell(comm, local_size, local_size, global_size, global_size, op, matrix, ierr))
    PetscCallA(MatShellSetOperation(matrix, MATOP_MULT, apply_bead_operator, ierr))
    PetscCallA(MatSetOption(matrix, MAT_SYMMETRIC, PETSC_TRUE, ierr))
    PetscCallA(MatSetOption(matrix, MAT_SPD, PETSC_TRUE, ierr))
    PetscCallA(MatCreateVecs(matrix, template, PETSC_NULL_VEC, ierr))
    PetscCallA(VecScatterCreateToAll(template, op%gather, op%gathered, ierr))
    PetscCallA(VecDestroy(template, ierr))
  end subroutine make_shell

  subroutine destroy_bead_operator(op, matrix)
    type(bead_operator_t), intent(inout) :: op
    Mat, intent(inout) :: matrix
    PetscErrorCode :: ierr
    PetscCallA(VecScatterDestroy(op%gather, ierr))
    PetscCallA(VecDestroy(op%gathered, ierr))
    PetscCallA(MatDestroy(matrix, ierr))
  end subroutine destroy_bead_operator

  !> MATOP_MULT: y = A x.
  subroutine apply_bead_operator(matrix, x, y, ierr)
    Mat :: matrix
    Vec :: x, y
    PetscErrorCode :: ierr
    type(bead_operator_t), pointer :: op
    PetscCall(MatShellGetContext(matrix, op, ierr))
    call direct_products(op, [x], [y])
    ierr = 0
  end subroutine apply_bead_operator

  !> multipole_operator_t%apply_many: y(v) = A x(v) for the batch at once, each block looked up
  !> and read once for all vectors.
  subroutine apply_direct_many(this, x, y)
    class(bead_operator_t), target, intent(inout) :: this
    Vec, intent(in) :: x(:)
    Vec, intent(in) :: y(:)   ! PETSc handles: the vectors behind them are written
    call direct_products(this, x, y)
  end subroutine apply_direct_many

  !> y(v)_i = S x(v)_i + sum_{j /= i} A(R_i - R_j) x(v)_j for this rank's beads i: every x
  !> gathered whole, the batch interleaved per bead so that a block meets all its vectors at once.
  subroutine direct_products(op, x, y)
    type(bead_operator_t), intent(in) :: op
    Vec, intent(in) :: x(:), y(:)
    PetscScalar, pointer :: values(:)
    real(dp), allocatable :: all_x(:, :, :), local_y(:, :, :)
    integer(i8) :: i, j, bead
    integer :: nb, k, v
    PetscErrorCode :: ierr
    nb = op%block_size
    allocate (all_x(nb, size(x), op%n_beads), local_y(nb, size(x), op%n_local))
    do v = 1, size(x)
      PetscCallA(VecScatterBegin(op%gather, x(v), op%gathered, INSERT_VALUES, SCATTER_FORWARD, ierr))
      PetscCallA(VecScatterEnd(op%gather, x(v), op%gathered, INSERT_VALUES, SCATTER_FORWARD, ierr))
      PetscCallA(VecGetArrayReadF90(op%gathered, values, ierr))
      all_x(:, v, :) = reshape(values, [nb, int(op%n_beads)])
      PetscCallA(VecRestoreArrayReadF90(op%gathered, values, ierr))
    end do
    do i = 1, op%n_local
      bead = op%first_bead + i - 1
      local_y(:, :, i) = 0.0_dp
      call add_block_product(nb, size(x), op%self_block, all_x(:, :, bead), local_y(:, :, i))
      do j = 1, op%n_beads
        if (j == bead) cycle
        if (op%table%on_lattice) then
          k = table_block_index(op%table, op%table%lattice(:, bead) - op%table%lattice(:, j))
        else
          k = int((i - 1) * op%n_beads + j)
        end if
        call add_block_product(nb, size(x), op%table%blocks(:, :, k), all_x(:, :, j), local_y(:, :, i))
      end do
    end do
    do v = 1, size(x)
      PetscCallA(VecGetArrayF90(y(v), values, ierr))
      values = reshape(local_y(:, v, :), [nb * int(op%n_local)])
      PetscCallA(VecRestoreArrayF90(y(v), values, ierr))
    end do
  end subroutine direct_products

  !> y += B x for one nb x nb block and n_vectors columns (column-major loop order for contiguous
  !> access).
  pure subroutine add_block_product(nb, n_vectors, block, x, y)
    integer, intent(in) :: nb, n_vectors
    real(dp), intent(in) :: block(nb, nb), x(nb, n_vectors)
    real(dp), intent(inout) :: y(nb, n_vectors)
    integer :: column, v
    do v = 1, n_vectors
      do column = 1, nb
        y(:, v) = y(:, v) + block(:, column) * x(column, v)
      end do
    end do
  end subroutine add_block_product
end module beadmob_bead_operator
