!> The assembled Galerkin matrix of a bead model with few unknowns (theory.md T17): every block,
!> S on the diagonal and A(R_i - R_j) off it, in a PETSc MPISBAIJ matrix (block size nb, the
!> upper triangle of blocks: A_ji = A_ij^T), this rank's bead rows. Its Cholesky factorisation
!> (MUMPS, whose single dense front of a dense matrix is factorised by LAPACK/ScaLAPACK kernels)
!> is then the exact solve: CG preconditioned by it converges in one iteration, so the six motions
!> cost six triangular solves, and every check of the Krylov path (true residual, variational
!> friction, symmetry) is made the same way. At high L on a few beads this replaces hundreds of
!> CG iterations; the blocks come from the axial table (T15: a quadrature per distinct distance,
!> or per Chebyshev node, shared over the ranks), never from the lattice table, whose 48 basis
!> transforms dominate at high L.
module beadmob_dense_operator
#include "petsc/finclude/petscmat.h"
  use petscmat
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_multipole_basis, only: multipole_basis_t
  use beadmob_pair_blocks, only: self_block
  use beadmob_axial_table, only: axial_table_t, make_axial_table, rotated_block, axial_nodes
  use beadmob_multipole_operator, only: multipole_operator_t, operator_options_t, place_block_in_row
  use beadmob_operator_cost, only: job_size_t, operator_cost_t, quadrature_seconds
  implicit none
  private
  public :: dense_operator_t, dense_max_unknowns

  !> Largest number of unknowns of a dense job (memory ~ 8 n^2 bytes over the ranks, with the
  !> factor: 3.2 GB at 2e4; time ~ n^3 / 3 flops).
  integer, parameter :: dense_max_unknowns = 20000

  type, extends(multipole_operator_t) :: dense_operator_t
    !> The companion's matrix, assembled in the same pass (an SBAIJ matrix has no sub-matrix of
    !> part of each block), until the companion takes it.
    Mat :: companion_matrix
    logical :: has_companion_matrix = .false.
    logical :: made = .false.
  contains
    procedure :: create => create_dense
    procedure :: create_companion => dense_companion
    procedure :: destroy => destroy_dense
    procedure, nopass :: cost => dense_cost
  end type dense_operator_t

contains

  subroutine create_dense(this, comm, basis, centres, first_bead, n_local, options, err)
    class(dense_operator_t), target, intent(inout) :: this
    MPI_Comm, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :)
    integer(i8), intent(in) :: first_bead, n_local
    type(operator_options_t), intent(in) :: options
    type(error_t), intent(inout) :: err
    type(axial_table_t) :: axial
    real(dp), allocatable :: block(:, :), values(:), low_values(:)
    PetscInt, allocatable :: columns(:)
    PetscInt :: nb, low_size, local_rows, global_rows, row(1)
    PetscInt, allocatable :: diagonal(:), off_diagonal(:)
    PetscErrorCode :: ierr
    integer(i8) :: i, j, bead, last_bead, n
    integer :: k
    real(dp), allocatable :: distances(:)

    nb = basis%size
    n = size(centres, 2, kind=i8)
    if (n * nb > dense_max_unknowns) then
      call raise(err, 'the dense operator takes at most ' // str(dense_max_unknowns) // ' unknowns, this job has ' // &
                 str(n * nb) // ': use -operator fft, pfft or direct')
      return
    end if
    this%block_size = int(nb)
    this%n_beads = n
    this%first_bead = first_bead
    this%n_local = n_local
    allocate (this%self_block(nb, nb), block(nb, nb))
    call self_block(basis, this%self_block)
    last_bead = first_bead + n_local - 1
    ! Every block turned from an axial one (theory.md T15): at the model's distinct distances when
    ! there are fewer of them than Chebyshev nodes (a chain of 3 beads: 2), else the Chebyshev
    ! table; the quadratures are shared over the ranks.
    if (n <= 400) then
      allocate (distances(n * (n - 1) / 2))
      k = 0
      do i = 1, n
        do j = i + 1, n
          k = k + 1
          distances(k) = norm2(centres(:, i) - centres(:, j))
        end do
      end do
      call make_axial_table(basis, axial, comm, distances)
    else
      call make_axial_table(basis, axial, comm)
    end if
    this%computed_blocks = size(axial%nodes)

    ! Upper triangle of blocks: row bead i holds columns j >= i; j <= last_bead is this rank's.
    local_rows = int(n_local) * nb
    global_rows = int(n) * nb
    allocate (diagonal(n_local), off_diagonal(n_local))
    do i = 1, n_local
      bead = first_bead + i - 1
      diagonal(i) = int(last_bead - bead + 1)
      off_diagonal(i) = int(n - last_bead)
    end do
    PetscCallA(MatCreateSBAIJ(comm, nb, local_rows, local_rows, global_rows, global_rows, 0, diagonal, 0, off_diagonal, this%matrix, ierr))
    this%has_companion_matrix = allocated(options%companion_unknowns)
    if (this%has_companion_matrix) then
      low_size = size(options%companion_unknowns)
      PetscCallA(MatCreateSBAIJ(comm, low_size, int(n_local) * low_size, int(n_local) * low_size, int(n) * low_size, int(n) * low_size, 0, diagonal, 0, off_diagonal, this%companion_matrix, ierr))
    end if
    do i = 1, n_local
      bead = first_bead + i - 1
      allocate (values(nb * nb * (n - bead + 1)), columns(n - bead + 1))
      if (this%has_companion_matrix) allocate (low_values(low_size * low_size * (n - bead + 1)))
      do j = bead, n
        if (j == bead) then
          block = this%self_block
        else
          call rotated_block(axial, centres(:, bead) - centres(:, j), block)
        end if
        k = int(j - bead)
        call place_block_in_row(block, k, int(n - bead + 1), values)
        if (this%has_companion_matrix) call place_block_in_row(block(options%companion_unknowns, options%companion_unknowns), &
                                                        k, int(n - bead + 1), low_values)
        columns(k + 1) = int(j - 1)
      end do
      row(1) = int(bead - 1)
      PetscCallA(MatSetValuesBlocked(this%matrix, 1, row, int(size(columns)), columns, values, INSERT_VALUES, ierr))
      if (this%has_companion_matrix) then
        PetscCallA(MatSetValuesBlocked(this%companion_matrix, 1, row, int(size(columns)), columns, low_values, INSERT_VALUES, ierr))
        deallocate (low_values)
      end if
      deallocate (values, columns)
    end do
    call finish(this%matrix)
    if (this%has_companion_matrix) call finish(this%companion_matrix)
    this%on_lattice = .false.
    this%made = .true.
    this%assembled = .true.

  contains

    subroutine finish(matrix)
      Mat, intent(inout) :: matrix
      PetscCallA(MatAssemblyBegin(matrix, MAT_FINAL_ASSEMBLY, ierr))
      PetscCallA(MatAssemblyEnd(matrix, MAT_FINAL_ASSEMBLY, ierr))
      PetscCallA(MatSetOption(matrix, MAT_SPD, PETSC_TRUE, ierr))
    end subroutine finish
  end subroutine create_dense


  subroutine dense_companion(this, comm, unknowns, companion, err)
    class(dense_operator_t), target, intent(inout) :: this
    MPI_Comm, intent(in) :: comm
    integer, intent(in) :: unknowns(:)
    class(multipole_operator_t), allocatable, target, intent(inout) :: companion
    type(error_t), intent(inout) :: err
    if (.not. this%has_companion_matrix) then
      call raise(err, 'internal: the dense operator was created without its companion''s unknowns')
      return
    end if
    allocate (dense_operator_t :: companion)
    select type (companion)
    type is (dense_operator_t)
      companion%block_size = size(unknowns)
      companion%n_beads = this%n_beads
      companion%first_bead = this%first_bead
      companion%n_local = this%n_local
      companion%self_block = this%self_block(unknowns, unknowns)
      companion%matrix = this%companion_matrix   ! taken over: the companion destroys it
      companion%made = .true.
      companion%assembled = .true.
      this%has_companion_matrix = .false.
    end select
  end subroutine dense_companion

  subroutine destroy_dense(this)
    class(dense_operator_t), intent(inout) :: this
    PetscErrorCode :: ierr
    if (this%has_companion_matrix) then
      PetscCallA(MatDestroy(this%companion_matrix, ierr))
      this%has_companion_matrix = .false.
    end if
    if (.not. this%made) return
    PetscCallA(MatDestroy(this%matrix, ierr))
    this%made = .false.
  end subroutine destroy_dense

  !> multipole_operator_t%cost: the upper triangle of blocks (and the companion's), MUMPS's copy
  !> of it and its factor (a dense front, n^2 / 2 entries), split over the ranks; time: the axial
  !> blocks (at most one quadrature per pair, shared over the ranks) and the self block (a
  !> quadrature), the factorisation (n^3 / 3 flops at ~2 Gflop/s per rank) and two triangular
  !> solves per product.
  pure subroutine dense_cost(size, cost)
    type(job_size_t), intent(in) :: size
    type(operator_cost_t), intent(out) :: cost
    real(dp), parameter :: flop_seconds = 0.5e-9_dp
    real(dp) :: unknowns, pairs
    unknowns = size%nb * size%solve_beads
    pairs = real(size%solve_beads, dp) * (size%solve_beads - 1) / 2
    cost%blocks = 8 * unknowns**2 / 2 * (1 + (size%nb_low / size%nb)**2) / size%n_ranks
    cost%kernel = 2 * 8 * unknowns**2 / 2 / size%n_ranks   ! MUMPS: the entries and the factor
    cost%seconds_setup = quadrature_seconds(size) * (ceiling(min(pairs, real(axial_nodes(size%order), dp)) / &
                                                             size%n_ranks) + 1) + &
                         flop_seconds * unknowns**3 / 3 / size%n_ranks
    cost%seconds_product = flop_seconds * 2 * unknowns**2 / size%n_ranks
    cost%seconds_low_product = cost%seconds_product * (size%nb_low / size%nb)**2
  end subroutine dense_cost
end module beadmob_dense_operator
