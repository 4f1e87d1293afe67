!> Whole products on every rank, for jobs whose FFT box is small (docs/theory.md T6, "Products
!> of a batch on whole operators"). The operator of all beads is built on every rank alone
!> (PETSC_COMM_SELF); a batch of vectors is dealt out to the ranks, vector j to rank
!> mod(j - 1, P), and each rank multiplies its vectors whole, with no transposes between ranks:
!> a small box's distributed FFT spends more in its transposes and short passes than the rank
!> gains from its share. The vectors stay distributed by beads as in every operator; one
!> VecScatter per rank gathers a vector whole on that rank and spreads its product back.
!> A single product (MatMult) is the batch of one, on rank 0.
module beadmob_replicated_operator
#include "petsc/finclude/petscmat.h"
  use petscmat
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t
  use beadmob_parallel, only: run_context_t, make_run_context, agree_on_error
  use beadmob_multipole_basis, only: multipole_basis_t
  use beadmob_multipole_operator, only: multipole_operator_t, operator_options_t
  use beadmob_operator_cost, only: job_size_t, operator_cost_t
  implicit none
  private
  public :: replicated_operator_t

  !> The MATSHELL context. `inner` is the whole operator of this rank (allocated to its kind by
  !> the caller before create, operator_catalog.f90).
  type, extends(multipole_operator_t) :: replicated_operator_t
    class(multipole_operator_t), allocatable :: inner
    integer :: n_ranks = 1, rank = 0
    VecScatter, allocatable :: to_rank(:)     ! (0:P-1): a distributed vector -> whole on that rank
    Vec :: nothing                            ! the empty end of a scatter to another rank
    Vec, allocatable :: whole_x(:), whole_y(:)   ! this rank's share of the batch, whole
    logical :: made = .false.
  contains
    procedure :: create => create_replicated
    procedure :: create_companion => replicated_companion
    procedure :: destroy => destroy_replicated
    procedure :: apply_many => apply_replicated_many
    procedure :: free_batches => free_replicated_batches
    procedure, nopass :: cost => replicated_cost
  end type replicated_operator_t

  interface
    subroutine MatCreateShell(comm, m_local, n_local, m, n, context, matrix, ierr)
      use petscmat
      import :: replicated_operator_t
      MPI_Comm :: comm
      PetscInt :: m_local, n_local, m, n
      type(replicated_operator_t) :: context
      Mat :: matrix
      PetscErrorCode :: ierr
    end subroutine MatCreateShell
    subroutine MatShellGetContext(matrix, context, ierr)
      use petscmat
      import :: replicated_operator_t
      Mat :: matrix
      type(replicated_operator_t), pointer :: context
      PetscErrorCode :: ierr
    end subroutine MatShellGetContext
  end interface

contains

  !> multipole_operator_t%create: the inner operator of all beads on this rank alone (the table
  !> cache and FFTW wisdom read and written by rank 0 only: one writer), then, once every rank has
  !> its own (an error on any rank is every rank's), the shell of the distributed rows
  !> first_bead .. first_bead + n_local - 1.
  subroutine create_replicated(this, comm, basis, centres, first_bead, n_local, options, err)
    class(replicated_operator_t), target, intent(inout) :: this
    MPI_Comm, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :)
    integer(i8), intent(in) :: first_bead, n_local
    type(operator_options_t), intent(in) :: options
    type(error_t), intent(inout) :: err
    type(operator_options_t) :: whole_options
    type(run_context_t) :: ctx
    ctx = make_run_context(comm)
    whole_options = options
    if (ctx%rank /= 0) then
      whole_options%cache_file = ''
      whole_options%report = .false.
    end if
    call this%inner%create(PETSC_COMM_SELF, basis, centres, 1_i8, size(centres, 2, kind=i8), whole_options, err)
    call agree_on_error(ctx, err)
    if (err%failed) return
    this%n_beads = size(centres, 2, kind=i8)
    this%first_bead = first_bead
    this%n_local = n_local
    call copy_description(this%inner, this)
    call make_shell(ctx, this)
  end subroutine create_replicated

  !> multipole_operator_t%create_companion: the inner operator's companion, replicated alike.
  subroutine replicated_companion(this, comm, unknowns, companion, err)
    class(replicated_operator_t), target, intent(inout) :: this
    MPI_Comm, intent(in) :: comm
    integer, intent(in) :: unknowns(:)
    class(multipole_operator_t), allocatable, target, intent(inout) :: companion
    type(error_t), intent(inout) :: err
    type(run_context_t) :: ctx
    if (err%failed) return
    ctx = make_run_context(comm)
    allocate (replicated_operator_t :: companion)
    select type (companion)
    type is (replicated_operator_t)
      call this%inner%create_companion(PETSC_COMM_SELF, unknowns, companion%inner, err)
      call agree_on_error(ctx, err)
      if (err%failed) return
      companion%n_beads = this%n_beads
      companion%first_bead = this%first_bead
      companion%n_local = this%n_local
      call copy_description(companion%inner, companion)
      call make_shell(ctx, companion)
    end select
  end subroutine replicated_companion

  !> What the friction job reads of an operator, as the whole operator has it.
  subroutine copy_description(whole, op)
    class(multipole_operator_t), intent(in) :: whole
    class(multipole_operator_t), intent(inout) :: op
    op%block_size = whole%block_size
    op%self_block = whole%self_block
    op%on_lattice = whole%on_lattice
    op%computed_blocks = whole%computed_blocks
    op%cached_blocks = whole%cached_blocks
    op%plans_from_wisdom = whole%plans_from_wisdom
    op%by_mirror_class = whole%by_mirror_class
    op%assembled = .false.
  end subroutine copy_description

  !> Collective. The distributed MATSHELL and, for every rank r, the scatter of a distributed
  !> vector to the whole vector on r (every index on r, none elsewhere).
  subroutine make_shell(ctx, op)
    type(run_context_t), intent(in) :: ctx
    type(replicated_operator_t), target, intent(inout) :: op
    PetscInt :: local_size, global_size, whole_size
    Vec :: distributed, whole
    IS :: from, to
    PetscErrorCode :: ierr
    integer :: r
    op%rank = ctx%rank
    op%n_ranks = ctx%n_ranks
    local_size = int(op%n_local * op%block_size)
    global_size = int(op%n_beads * op%block_size)
    PetscCallA(MatCreateShell(ctx%comm, local_size, local_size, global_size, global_size, op, op%matrix, ierr))
    PetscCallA(MatShellSetOperation(op%matrix, MATOP_MULT, apply_replicated_operator, ierr))
    PetscCallA(MatSetOption(op%matrix, MAT_SYMMETRIC, PETSC_TRUE, ierr))
    PetscCallA(MatSetOption(op%matrix, MAT_SPD, PETSC_TRUE, ierr))
    PetscCallA(MatCreateVecs(op%matrix, distributed, PETSC_NULL_VEC, ierr))
    PetscCallA(VecCreateSeq(PETSC_COMM_SELF, 0, op%nothing, ierr))
    PetscCallA(VecCreateSeq(PETSC_COMM_SELF, global_size, whole, ierr))
    allocate (op%to_rank(0:op%n_ranks - 1))
    do r = 0, op%n_ranks - 1
      whole_size = merge(global_size, 0, r == op%rank)
      PetscCallA(ISCreateStride(PETSC_COMM_SELF, whole_size, 0, 1, from, ierr))
      PetscCallA(ISCreateStride(PETSC_COMM_SELF, whole_size, 0, 1, to, ierr))
      if (r == op%rank) then
        PetscCallA(VecScatterCreate(distributed, from, whole, to, op%to_rank(r), ierr))
      else
        PetscCallA(VecScatterCreate(distributed, from, op%nothing, to, op%to_rank(r), ierr))
      end if
      PetscCallA(ISDestroy(from, ierr))
      PetscCallA(ISDestroy(to, ierr))
    end do
    PetscCallA(VecDestroy(whole, ierr))
    PetscCallA(VecDestroy(distributed, ierr))
    op%made = .true.
  end subroutine make_shell

  !> MATOP_MULT: y = A x, the batch of one.
  subroutine apply_replicated_operator(matrix, x, y, ierr)
    Mat :: matrix
    Vec :: x, y
    PetscErrorCode :: ierr
    type(replicated_operator_t), pointer :: op
    PetscCall(MatShellGetContext(matrix, op, ierr))
    call apply_replicated_many(op, [x], [y])
    ierr = 0
  end subroutine apply_replicated_operator

  !> Collective. y(j) = A x(j): x(j) gathered whole on rank mod(j - 1, P), each rank's vectors
  !> multiplied as one batch of its whole operator, the products spread back.
  subroutine apply_replicated_many(this, x, y)
    class(replicated_operator_t), target, intent(inout) :: this
    Vec, intent(in) :: x(:)
    Vec, intent(in) :: y(:)   ! PETSc handles: the vectors behind them are written
    integer :: j, mine
    PetscErrorCode :: ierr
    if (size(x) == 0) return
    mine = count([(owner(j) == this%rank, j = 1, size(x))])
    call provide_whole_vectors(this, mine)
    do j = 1, size(x)
      PetscCallA(VecScatterBegin(this%to_rank(owner(j)), x(j), whole_of(j, this%whole_x), INSERT_VALUES, SCATTER_FORWARD, ierr))
      PetscCallA(VecScatterEnd(this%to_rank(owner(j)), x(j), whole_of(j, this%whole_x), INSERT_VALUES, SCATTER_FORWARD, ierr))
    end do
    if (mine > 0) call this%inner%apply_many(this%whole_x(1:mine), this%whole_y(1:mine))
    do j = 1, size(x)
      PetscCallA(VecScatterBegin(this%to_rank(owner(j)), whole_of(j, this%whole_y), y(j), INSERT_VALUES, SCATTER_REVERSE, ierr))
      PetscCallA(VecScatterEnd(this%to_rank(owner(j)), whole_of(j, this%whole_y), y(j), INSERT_VALUES, SCATTER_REVERSE, ierr))
    end do

  contains

    integer function owner(k)
      integer, intent(in) :: k
      owner = mod(k - 1, this%n_ranks)
    end function owner

    !> Vector k's whole copy on this rank (its owner), else the empty vector.
    function whole_of(k, whole) result(v)
      integer, intent(in) :: k
      Vec, intent(in) :: whole(:)
      Vec :: v
      v = this%nothing
      if (owner(k) == this%rank) v = whole(1 + (k - 1) / this%n_ranks)
    end function whole_of
  end subroutine apply_replicated_many

  !> At least `count` whole vectors of each kind on this rank (made once, grown when a batch is larger).
  subroutine provide_whole_vectors(op, count)
    type(replicated_operator_t), intent(inout) :: op
    integer, intent(in) :: count
    integer :: have, j
    PetscErrorCode :: ierr
    have = 0
    if (allocated(op%whole_x)) have = size(op%whole_x)
    if (have >= count) return
    call free_whole_vectors(op)   ! only these: the inner operator's batch buffers stay
    allocate (op%whole_x(count), op%whole_y(count))
    do j = 1, count
      PetscCallA(VecCreateSeq(PETSC_COMM_SELF, int(op%n_beads * op%block_size), op%whole_x(j), ierr))
      PetscCallA(VecDuplicate(op%whole_x(j), op%whole_y(j), ierr))
    end do
  end subroutine provide_whole_vectors

  subroutine free_whole_vectors(op)
    type(replicated_operator_t), intent(inout) :: op
    integer :: j
    PetscErrorCode :: ierr
    if (.not. allocated(op%whole_x)) return
    do j = 1, size(op%whole_x)
      PetscCallA(VecDestroy(op%whole_x(j), ierr))
      PetscCallA(VecDestroy(op%whole_y(j), ierr))
    end do
    deallocate (op%whole_x, op%whole_y)
  end subroutine free_whole_vectors

  !> multipole_operator_t%free_batches: the whole vectors and the inner operator's batch buffers.
  subroutine free_replicated_batches(this)
    class(replicated_operator_t), intent(inout) :: this
    call free_whole_vectors(this)
    if (allocated(this%inner)) call this%inner%free_batches()
  end subroutine free_replicated_batches

  subroutine destroy_replicated(this)
    class(replicated_operator_t), intent(inout) :: this
    integer :: r
    PetscErrorCode :: ierr
    call free_replicated_batches(this)
    if (this%made) then
      do r = 0, size(this%to_rank) - 1
        PetscCallA(VecScatterDestroy(this%to_rank(r), ierr))
      end do
      deallocate (this%to_rank)
      PetscCallA(VecDestroy(this%nothing, ierr))
      PetscCallA(MatDestroy(this%matrix, ierr))
      this%made = .false.
    end if
    if (allocated(this%inner)) call this%inner%destroy()
  end subroutine destroy_replicated

  !> Not asked: job_estimate.f90 asks the whole operator's own cost on one rank and deals out
  !> its products (replicated_share); this gives nothing.
  pure subroutine replicated_cost(size, cost)
    type(job_size_t), intent(in) :: size
    type(operator_cost_t), intent(out) :: cost
    cost%seconds_product = 0.0_dp * size%nb
  end subroutine replicated_cost
end module beadmob_replicated_operator
