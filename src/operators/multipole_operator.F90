!> The one interface of the bead operators (the Galerkin matrix A of theory.md T4 as a
!> distributed PETSc matrix, rows split by beads): direct (bead_operator.F90), lattice FFT
!> (fft_operator.F90), precorrected FFT (pfft_operator.F90) and dense (dense_operator.F90) all
!> extend multipole_operator_t. The friction job creates one by name (new_operator), applies it
!> through its PETSc matrix (CG calls MatMult), makes its companion of a sub-basis for the error
!> bar (theory.md T14) and destroys it, and the dry run asks it its cost, without knowing which
!> one it has.
module beadmob_multipole_operator
#include "petsc/finclude/petscmat.h"
  use petscmat
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t
  use beadmob_multipole_basis, only: multipole_basis_t
  use beadmob_operator_cost, only: job_size_t, operator_cost_t
  implicit none
  private
  public :: multipole_operator_t, operator_options_t, place_block_in_row

  !> What some operators need beyond the beads and the basis (the friction job fills it from its
  !> settings, friction_settings.f90, which hold the defaults).
  type :: operator_options_t
    character(len=:), allocatable :: cache_file   ! table cache of the lattice blocks ('' = none)
    logical :: measure_plans = .true.             ! FFTW_MEASURE plans (fft, pfft)
    logical :: mirror_classes = .true.            ! products by mirror class where they apply (fft)
    logical :: report = .false.                   ! progress lines of the set-up (rank 0)
    integer :: pfft_stencil = 0                   ! interpolation points per axis (pfft)
    real(dp) :: pfft_near_radius = 0.0_dp         ! radius (d) of the exact pairs (pfft)
    !> Allocated: a companion of these unknowns (indices into the unknowns per bead) will be
    !> made, and the operator keeps what it needs for it.
    integer, allocatable :: companion_unknowns(:)
  end type operator_options_t

  type, abstract :: multipole_operator_t
    integer :: block_size = 0                     ! unknowns per bead
    integer(i8) :: n_beads = 0, first_bead = 1, n_local = 0   ! all beads; this rank's rows
    real(dp), allocatable :: self_block(:, :)     ! the single-bead block S (preconditioner)
    logical :: on_lattice = .false.
    integer(i8) :: computed_blocks = 0            ! pair blocks (or table nodes) by quadrature
    integer(i8) :: cached_blocks = 0              ! pair blocks read from the table cache
    logical :: plans_from_wisdom = .false.        ! FFT plans from the wisdom remembered with the cache
    logical :: by_mirror_class = .false.          ! products by mirror class (the FFT operator)
    Mat :: matrix                                 ! y = A x by MatMult; valid after create
    !> The matrix is assembled and exact (the dense operator): its Cholesky factorisation is the
    !> solve's preconditioner, instead of the single-bead blocks.
    logical :: assembled = .false.
  contains
    !> Collective. The operator of `basis` on `centres` (this rank's rows first_bead ..
    !> first_bead + n_local - 1). On error (err set on any rank, agreed) destroy is still safe.
    !> The object must stay in place while its matrix lives (PETSc keeps its address).
    procedure(create_interface), deferred :: create
    !> Collective. The operator of the sub-basis `unknowns` on the same beads, from this one's
    !> blocks (no new quadrature); `companion` is allocated to this operator's type. This one must
    !> outlive it.
    procedure(companion_interface), deferred :: create_companion
    !> Collective. Frees the matrix and everything the operator holds.
    procedure(destroy_interface), deferred :: destroy
    !> y = A x (collective).
    procedure :: apply
    !> y(j) = A x(j) for several vectors (collective): one product each, unless the operator
    !> batches them (the FFT operator streams its kernel once for all).
    procedure :: apply_many
    !> Frees what apply_many made for its batches (the next call makes it again).
    procedure :: free_batches
    !> Memory per rank and time of this kind of operator for a job of the given sizes, before
    !> anything is built (the dry run and the memory check, job_estimate.f90).
    procedure(cost_interface), deferred, nopass :: cost
  end type multipole_operator_t

  abstract interface
    subroutine create_interface(this, comm, basis, centres, first_bead, n_local, options, err)
      import :: multipole_operator_t, multipole_basis_t, operator_options_t, error_t, dp, i8
      class(multipole_operator_t), target, intent(inout) :: this
      MPI_Comm, intent(in) :: comm
      type(multipole_basis_t), intent(in) :: basis
      real(dp), intent(in) :: centres(:, :)
      integer(i8), intent(in) :: first_bead, n_local
      type(operator_options_t), intent(in) :: options
      type(error_t), intent(inout) :: err
    end subroutine create_interface
    subroutine companion_interface(this, comm, unknowns, companion, err)
      import :: multipole_operator_t, error_t
      class(multipole_operator_t), target, intent(inout) :: this
      MPI_Comm, intent(in) :: comm
      integer, intent(in) :: unknowns(:)
      class(multipole_operator_t), allocatable, target, intent(inout) :: companion
      type(error_t), intent(inout) :: err
    end subroutine companion_interface
    subroutine destroy_interface(this)
      import :: multipole_operator_t
      class(multipole_operator_t), intent(inout) :: this
    end subroutine destroy_interface
    pure subroutine cost_interface(size, cost)
      import :: job_size_t, operator_cost_t
      type(job_size_t), intent(in) :: size
      type(operator_cost_t), intent(out) :: cost
    end subroutine cost_interface
  end interface

contains

  !> Block number `slot` (0-based) of `blocks` blocks in the values of one block row as PETSc's
  !> MatSetValuesBlocked takes them: row-major over the (block size) x (blocks x block size)
  !> dense rows.
  pure subroutine place_block_in_row(block, slot, blocks, values)
    real(dp), intent(in) :: block(:, :)
    integer, intent(in) :: slot, blocks
    real(dp), intent(inout) :: values(:)
    integer :: r, m
    m = size(block, 1)
    do r = 1, m
      values((r - 1) * m * blocks + slot * m + 1:(r - 1) * m * blocks + (slot + 1) * m) = block(r, :)
    end do
  end subroutine place_block_in_row

  subroutine apply(this, x, y)
    class(multipole_operator_t), intent(in) :: this
    Vec, intent(in) :: x
    Vec, intent(inout) :: y
    PetscErrorCode :: ierr
    PetscCallA(MatMult(this%matrix, x, y, ierr))
  end subroutine apply

  subroutine apply_many(this, x, y)
    class(multipole_operator_t), target, intent(inout) :: this
    Vec, intent(in) :: x(:)
    Vec, intent(in) :: y(:)   ! PETSc handles: the vectors behind them are written
    integer :: j
    PetscErrorCode :: ierr
    do j = 1, size(x)
      PetscCallA(MatMult(this%matrix, x(j), y(j), ierr))
    end do
  end subroutine apply_many

  !> The plain products of apply_many keep nothing.
  subroutine free_batches(this)
    class(multipole_operator_t), intent(inout) :: this
  end subroutine free_batches
end module beadmob_multipole_operator
