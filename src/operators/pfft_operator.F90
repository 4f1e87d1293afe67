!> The multipole operator of an off-lattice bead model with a precorrected-FFT far field
!> (Phillips & White, IEEE TCAD 16, 1059 (1997); theory.md T16), a PETSc MATSHELL:
!>   y = I G I^T x + C x.
!> G is the lattice FFT operator (fft_operator.F90) on the nodes of the unit grid that carry
!> beads' stencils: the exact product of the blocks A(g - g') of grid displacements (and S at
!> g = g'). I interpolates: A(t - s), analytic in s and t for |t - s| > 1 d, is approximated by
!> tensor Lagrange interpolation of degree p in each coordinate over the p + 1 nearest grid
!> points of each bead (weights l_g(R), the same for every unknown):
!>   A(R_i - R_j) ~ sum_{g, g'} l_g(R_i) l_g'(R_j) A(g - g').
!> C (a sparse PETSc matrix, this rank's rows) makes the near pairs (|R_i - R_j| < near_radius,
!> and i = j) exact: C_ij = A(R_i - R_j) - (the grid's approximation of it), the exact block
!> from the axial table (axial_table.f90). Far pairs carry the interpolation error, controlled by
!> p and near_radius (measured: bench/offlattice/offlattice.md). Beads on the lattice get l = delta, C = 0 to
!> rounding and the lattice operator itself. Memory per rank: the FFT slab, I (nb (p+1)^3 entries
!> per bead row) and C (nb^2 per near pair): O(N/P) for a fixed near radius.
module beadmob_pfft_operator
#include "petsc/finclude/petscmat.h"
  use petscmat
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_progress, only: progress_line, progress_seconds
  use beadmob_multipole_basis, only: multipole_basis_t, inversion_parity
  use beadmob_pair_blocks, only: self_block
  use beadmob_lapack, only: dgemm
  use beadmob_axial_table, only: axial_table_t, make_axial_table, rotated_block
  use beadmob_harmonic_rotation, only: make_rotation_rule, degree_rotations
  use beadmob_lapack, only: dsyev
  use beadmob_fft_operator, only: fft_operator_t, create_fft_operator, destroy_fft_operator, create_fft_companion, fft_size
  use beadmob_multipole_operator, only: multipole_operator_t, operator_options_t
  use beadmob_near_pair_matrix, only: near_pair_matrix_t, make_near_pair_matrix, near_pair_product, &
                                      destroy_near_pair_matrix, hand_over_near_pair_matrix
  use beadmob_operator_cost, only: job_size_t, operator_cost_t, quadrature_seconds, direct_seconds
  use beadmob_fft_operator, only: fft_cost
  use beadmob_spatial_index, only: spatial_index_t, build_spatial_index, beads_within, sort_keys
  use beadmob_counting_sort, only: counting_sort
  implicit none
  private
  public :: pfft_operator_t, create_pfft_operator, destroy_pfft_operator, create_pfft_companion, pfft_grid_nodes
  public :: pfft_expected_error, pfft_radius_for

  !> The far field's expected error, largest over the bodies measured (bench/offlattice/pfft_near_radius.md:
  !> jittered clusters, beads on a sphere, turned paper shapes and a turned rod, L = 1 and 2), relative
  !> to the largest friction or mobility entry: expected_error_at_3 at the stencil of 4 points and the
  !> near radius 3 d, falling as (3 d / r_near)^expected_error_decay (theory.md T16, "Error").
  real(dp), parameter :: expected_error_at_3 = 5.0e-4_dp, expected_error_decay = 2.6_dp

  type, extends(multipole_operator_t) :: pfft_operator_t
    !> Interpolation points per axis (degree + 1) and the near radius (d): set before create.
    integer :: stencil = 4
    real(dp) :: near_radius = 3.0_dp
    type(fft_operator_t) :: grid
    integer(i8) :: n_grid = 0          ! grid nodes carrying a stencil
    integer(i8) :: near_pairs = 0      ! near pairs of this rank's rows (i = j included)
    !> C is block-sparse, each pair's block kept once (near_pair_matrix.F90, block size nb: 8 bytes
    !> per entry). With a companion in view (create_pfft_operator's companion_unknowns) its
    !> sub-blocks are assembled in the same pass, kept here until the companion takes them.
    !> I = W (x) 1_nb: W (beads x grid nodes, s^3 weights per bead row) is assembled once, I is
    !> PETSc's MAIJ view of it for nb unknowns per bead and node (the companion's for its own
    !> number), so a product reads each weight once for all of a bead's unknowns.
    Mat :: grid_matrix, node_weights, interpolation
    type(near_pair_matrix_t) :: correction, companion_correction
    logical :: has_companion_correction = .false.
    !> Grid vectors (and frame vectors) of the products, single or batched (apply_many), one per
    !> vector of the largest batch yet; freed by free_batches.
    Vec, allocatable :: batch_grid_x(:), batch_grid_y(:), batch_frame_x(:), batch_frame_y(:)
    !> The grid is laid along the beads' principal axes when that makes the FFT box smaller (a
    !> turned elongated body): positions in that frame are Q^T (R - centroid), and the operator is
    !> D_Q A' D_Q^T with A' the frame's (theory.md T15), D_Q = O^n(Q) on each (n, sigma) group of
    !> a bead's unknowns (turn(:, :, n); unknown_degree and group_first/last name the groups).
    logical :: turned = .false.
    real(dp) :: frame(3, 3) = 0.0_dp
    real(dp), allocatable :: turn(:, :, :)
    integer, allocatable :: group_first(:), group_last(:), group_degree(:)
    !> The axial table of the exact pair blocks (theory.md T15), kept for the far field's error
    !> measured on exact rows after the solves (solvers/operator_error.F90)
    type(axial_table_t) :: axial
    logical :: created = .false.
  contains
    procedure :: create => create_pfft
    procedure :: create_companion => pfft_companion
    procedure :: destroy => destroy_pfft
    procedure :: apply_many => apply_pfft_many
    procedure :: free_batches => free_pfft_batches
    procedure, nopass :: cost => pfft_cost
  end type pfft_operator_t

  interface
    subroutine MatCreateShell(comm, m_local, n_local, m, n, context, matrix, ierr)
      use petscmat
      import :: pfft_operator_t
      MPI_Comm :: comm
      PetscInt :: m_local, n_local, m, n
      type(pfft_operator_t) :: context
      Mat :: matrix
      PetscErrorCode :: ierr
    end subroutine MatCreateShell
    subroutine MatShellGetContext(matrix, context, ierr)
      use petscmat
      import :: pfft_operator_t
      Mat :: matrix
      type(pfft_operator_t), pointer :: context
      PetscErrorCode :: ierr
    end subroutine MatShellGetContext
  end interface

contains

  !> multipole_operator_t%create: stencil, near radius, FFTW planner, progress and the
  !> companion's unknowns from the options.
  subroutine create_pfft(this, comm, basis, centres, first_bead, n_local, options, err)
    class(pfft_operator_t), target, intent(inout) :: this
    MPI_Comm, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :)
    integer(i8), intent(in) :: first_bead, n_local
    type(operator_options_t), intent(in) :: options
    type(error_t), intent(inout) :: err
    Mat :: matrix
    this%stencil = options%pfft_stencil
    this%near_radius = options%pfft_near_radius
    this%grid%measure_plans = options%measure_plans
    if (allocated(options%cache_file)) this%grid%table%cache_file = options%cache_file
    if (allocated(options%companion_unknowns)) then
      call create_pfft_operator(comm, basis, centres, first_bead, n_local, this, matrix, err, options%report, &
                                options%companion_unknowns)
    else
      call create_pfft_operator(comm, basis, centres, first_bead, n_local, this, matrix, err, options%report)
    end if
    if (err%failed) return
    this%matrix = matrix
    this%computed_blocks = this%grid%table%computed_blocks
    this%plans_from_wisdom = this%grid%plans_from_wisdom
  end subroutine create_pfft

  subroutine pfft_companion(this, comm, unknowns, companion, err)
    class(pfft_operator_t), target, intent(inout) :: this
    MPI_Comm, intent(in) :: comm
    integer, intent(in) :: unknowns(:)
    class(multipole_operator_t), allocatable, target, intent(inout) :: companion
    type(error_t), intent(inout) :: err
    Mat :: matrix
    allocate (pfft_operator_t :: companion)
    select type (companion)
    type is (pfft_operator_t)
      call create_pfft_companion(comm, this, unknowns, companion, matrix, err)
      if (companion%created) companion%matrix = matrix
    end select
  end subroutine pfft_companion

  !> multipole_operator_t%cost: the FFT operator's on the grid (size%spans: the grid's) and the
  !> near-pair corrections (the companion's too), at most one bead per d^3 within the near radius
  !> (the lattice's density, above a jittered cluster's 0.75); per pair its share of a BLAS
  !> product over (2 s - 1)^3 = 343 kernel blocks' upper triangles and its turned block; per
  !> product one block read.
  pure subroutine pfft_cost(size, cost)
    type(job_size_t), intent(in) :: size
    type(operator_cost_t), intent(out) :: cost
    real(dp) :: near_pairs
    call fft_cost(size, cost)
    near_pairs = size%local_beads * min(real(size%solve_beads, dp), 4.0_dp / 3.0_dp * acos(-1.0_dp) * size%near_radius**3)
    ! half of them stored and computed (each pair once, C symmetric), applied both ways per product
    cost%blocks = near_pairs / 2 * 8 * (size%nb**2 + size%nb_low**2)
    cost%seconds_setup = cost%seconds_setup + near_pairs / 2 * (0.1_dp * direct_seconds * size%nb * (size%nb + 1) / 2 * 343 + &
                                                                quadrature_seconds(size) / 100)
    cost%seconds_product = cost%seconds_product + direct_seconds * size%nb**2 * near_pairs
    cost%seconds_low_product = cost%seconds_low_product + direct_seconds * size%nb_low**2 * near_pairs
  end subroutine pfft_cost

  !> The error the far field is expected to make at this stencil and near radius (d), relative to
  !> the largest friction or mobility entry: the envelope of the measured bodies (the constants
  !> above). Only the default stencil of 4 points is measured: another stencil is expected to err
  !> as much as the default at its near radius (a larger stencil errs less, a smaller one more:
  !> s = 2 is not promised, 1: no promise).
  pure real(dp) function pfft_expected_error(stencil, near_radius)
    integer, intent(in) :: stencil
    real(dp), intent(in) :: near_radius
    if (stencil < 4) then
      pfft_expected_error = 1.0_dp
    else
      pfft_expected_error = expected_error_at_3 * (3.0_dp / max(near_radius, 1.0_dp))**expected_error_decay
    end if
  end function pfft_expected_error

  !> The smallest near radius, in steps of 0.5 d from `radius`, whose expected error
  !> (pfft_expected_error) is within `accuracy`; `radius` itself when it is already.
  pure real(dp) function pfft_radius_for(stencil, radius, accuracy)
    integer, intent(in) :: stencil
    real(dp), intent(in) :: radius, accuracy
    real(dp) :: wanted
    pfft_radius_for = radius
    if (accuracy <= 0.0_dp .or. pfft_expected_error(stencil, radius) <= accuracy .or. stencil < 4) return
    wanted = 3.0_dp * (expected_error_at_3 / accuracy)**(1.0_dp / expected_error_decay)
    pfft_radius_for = radius + 0.5_dp * ceiling((wanted - radius) / 0.5_dp - 1.0e-9_dp)
  end function pfft_radius_for

  subroutine destroy_pfft(this)
    class(pfft_operator_t), intent(inout) :: this
    Mat :: matrix
    matrix = this%matrix
    call destroy_pfft_operator(this, matrix)
  end subroutine destroy_pfft

  !> The grid of `centres` for a stencil of `stencil` points per axis: first(:, j), the lowest
  !> stencil node of bead j (grid coordinates from the lowest corner), and the 1-D Lagrange
  !> weights(m, axis, j) of its nodes first + m - 1. node_id(grid point) numbers the nodes that
  !> carry a stencil (x fastest), 0 elsewhere; nodes(:, k) their coordinates.
  subroutine pfft_grid_nodes(centres, stencil, first, weights, node_id, nodes)
    real(dp), intent(in) :: centres(:, :)
    integer, intent(in) :: stencil
    integer, allocatable, intent(out) :: first(:, :), node_id(:, :, :)
    real(dp), allocatable, intent(out) :: weights(:, :, :)
    real(dp), allocatable, intent(out) :: nodes(:, :)
    real(dp) :: corner(3), t
    integer :: j, axis, m, q, extent(3), a, b, c, count
    corner = minval(centres, dim=2)
    allocate (first(3, size(centres, 2)), weights(stencil, 3, size(centres, 2)))
    do j = 1, size(centres, 2)
      do axis = 1, 3
        ! Offsets in [s/2 - 1, s/2) from the first node: the bead sits in the stencil's middle cell.
        first(axis, j) = floor(centres(axis, j) - corner(axis) + 1.0e-12_dp) - (stencil / 2 - 1)
        t = centres(axis, j) - corner(axis) - first(axis, j)
        do m = 0, stencil - 1
          weights(m + 1, axis, j) = 1.0_dp
          do q = 0, stencil - 1
            if (q /= m) weights(m + 1, axis, j) = weights(m + 1, axis, j) * (t - q) / real(m - q, dp)
          end do
        end do
      end do
    end do
    first = first - spread(minval(first, dim=2), 2, size(centres, 2))
    extent = maxval(first, dim=2) + stencil
    allocate (node_id(0:extent(1) - 1, 0:extent(2) - 1, 0:extent(3) - 1))
    node_id = 0
    do j = 1, size(centres, 2)
      node_id(first(1, j):first(1, j) + stencil - 1, first(2, j):first(2, j) + stencil - 1, &
              first(3, j):first(3, j) + stencil - 1) = 1
    end do
    count = 0
    do c = 0, extent(3) - 1
      do b = 0, extent(2) - 1
        do a = 0, extent(1) - 1
          if (node_id(a, b, c) == 0) cycle
          count = count + 1
          node_id(a, b, c) = count
        end do
      end do
    end do
    allocate (nodes(3, count))
    do c = 0, extent(3) - 1
      do b = 0, extent(2) - 1
        do a = 0, extent(1) - 1
          if (node_id(a, b, c) > 0) nodes(:, node_id(a, b, c)) = [a, b, c]
        end do
      end do
    end do
  end subroutine pfft_grid_nodes

  !> Collective. op%stencil and op%near_radius as wanted before the call. `op` must stay in place
  !> while `matrix` lives. companion_unknowns: the sub-basis of a companion to come
  !> (create_pfft_companion), whose parts are then kept.
  subroutine create_pfft_operator(comm, basis, centres, first_bead, n_local, op, matrix, err, report, companion_unknowns)
    MPI_Comm, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :)
    integer(i8), intent(in) :: first_bead, n_local
    type(pfft_operator_t), target, intent(inout) :: op
    Mat, intent(out) :: matrix
    type(error_t), intent(inout) :: err
    logical, intent(in) :: report
    integer, intent(in), optional :: companion_unknowns(:)
    integer, allocatable :: first(:, :), node_id(:, :, :)
    real(dp), allocatable :: weights(:, :, :), nodes(:, :), grid_centres(:, :)
    integer(i8) :: grid_first, grid_count
    integer :: rank, n_ranks
    PetscErrorCode :: ierr
    real(dp) :: start

    start = MPI_Wtime()
    if (op%stencil < 2 .or. mod(op%stencil, 2) /= 0) then
      call raise(err, 'the pfft stencil must be an even number of points >= 2, got ' // str(op%stencil))
      return
    end if
    op%block_size = basis%size
    op%n_beads = size(centres, 2, kind=i8)
    op%first_bead = first_bead
    op%n_local = n_local
    allocate (op%self_block(basis%size, basis%size))
    call self_block(basis, op%self_block)
    call choose_frame(op, centres, grid_centres)
    if (op%turned) call set_turn(op, basis%order, basis%degree, basis%family)
    call pfft_grid_nodes(grid_centres, op%stencil, first, weights, node_id, nodes)
    op%n_grid = size(nodes, 2, kind=i8)
    call MPI_Comm_rank(comm, rank, ierr)
    call MPI_Comm_size(comm, n_ranks, ierr)
    grid_count = op%n_grid / n_ranks
    grid_first = 1 + rank * grid_count + min(int(rank, i8), mod(op%n_grid, int(n_ranks, i8)))
    if (rank < mod(op%n_grid, int(n_ranks, i8))) grid_count = grid_count + 1
    call progress_line(report, 'pfft grid: ' // str(op%n_grid) // ' nodes carry the stencils of ' // &
                       str(op%stencil) // '^3 points; near radius ' // str(op%near_radius) // ' d' // &
                       trim(merge(', along the principal axes', '                          ', op%turned)))
    call create_fft_operator(comm, basis, nodes, grid_first, grid_count, op%grid, op%grid_matrix, err, report, &
                             keep_lattice=present(companion_unknowns))
    if (err%failed) return
    call assemble_interpolation(comm, op, first, weights, node_id)
    call assemble_correction(comm, basis, op, grid_centres, first, weights, err, companion_unknowns)
    if (err%failed) return
    call make_shell(comm, op, matrix)
    call progress_line(report, 'pfft operator: ' // str(op%near_pairs) // ' near pairs on rank 0 (' // &
                       progress_seconds(MPI_Wtime() - start) // ' s)')
  end subroutine create_pfft_operator

  !> W (this rank's bead rows x grid nodes): entry l_g(R_j) between bead j and node g; and I, the
  !> same weight between unknown a of bead j and unknown a of node g, as W's MAIJ view.
  subroutine assemble_interpolation(comm, op, first, weights, node_id)
    MPI_Comm, intent(in) :: comm
    type(pfft_operator_t), intent(inout) :: op
    integer, intent(in) :: first(:, :), node_id(0:, 0:, 0:)
    real(dp), intent(in) :: weights(:, :, :)
    PetscInt :: local_rows, local_nodes, column_start, column_end, row(1)
    PetscInt, allocatable :: diagonal(:), off_diagonal(:), columns(:)
    PetscScalar, allocatable :: values(:)
    PetscErrorCode :: ierr
    integer :: s, nb, m1, m2, m3, n
    integer(i8) :: i, bead
    Vec :: template
    s = op%stencil
    nb = op%block_size
    PetscCallA(MatCreateVecs(op%grid_matrix, template, PETSC_NULL_VEC, ierr))
    PetscCallA(VecGetOwnershipRange(template, column_start, column_end, ierr))
    PetscCallA(VecDestroy(template, ierr))
    column_start = column_start / nb   ! in nodes
    column_end = column_end / nb
    local_rows = int(op%n_local)
    local_nodes = column_end - column_start
    allocate (diagonal(max(local_rows, 1)), off_diagonal(max(local_rows, 1)), columns(s**3), values(s**3))
    do i = 1, op%n_local
      call stencil_columns(op%first_bead + i - 1)
      diagonal(i) = count(columns >= column_start .and. columns < column_end)
      off_diagonal(i) = s**3 - diagonal(i)
    end do
    PetscCallA(MatCreateAIJ(comm, local_rows, local_nodes, int(op%n_beads), int(op%n_grid), 0, diagonal, 0, off_diagonal, op%node_weights, ierr))
    do i = 1, op%n_local
      bead = op%first_bead + i - 1
      call stencil_columns(bead)
      row(1) = int(bead - 1)
      PetscCallA(MatSetValues(op%node_weights, 1, row, s**3, columns, values, INSERT_VALUES, ierr))
    end do
    PetscCallA(MatAssemblyBegin(op%node_weights, MAT_FINAL_ASSEMBLY, ierr))
    PetscCallA(MatAssemblyEnd(op%node_weights, MAT_FINAL_ASSEMBLY, ierr))
    PetscCallA(MatCreateMAIJ(op%node_weights, nb, op%interpolation, ierr))

  contains

    !> columns/values of bead j: its stencil's nodes (0-based) and weights.
    subroutine stencil_columns(j)
      integer(i8), intent(in) :: j
      n = 0
      do m3 = 1, s
        do m2 = 1, s
          do m1 = 1, s
            n = n + 1
            columns(n) = node_id(first(1, j) + m1 - 1, first(2, j) + m2 - 1, first(3, j) + m3 - 1) - 1
            values(n) = weights(m1, 1, j) * weights(m2, 2, j) * weights(m3, 3, j)
          end do
        end do
      end do
    end subroutine stencil_columns
  end subroutine assemble_interpolation

  !> C: for every near pair (i in this rank's rows, each pair kept once, in one of its two rows:
  !> C is symmetric; near_beads), the exact block minus the grid's approximation
  !> sum_delta w(delta) K(g_i - g_j + delta), w the tensor product of the 1-D correlations of the
  !> two beads' Lagrange weights, K(0) = S, K(d) = A(d). Pairs with the same
  !> stencil offset D = g_i - g_j use the same (2s - 1)^3 kernel blocks: they are done together,
  !> one BLAS product of the gathered blocks with the pairs' weights (the kernel is read once
  !> per offset instead of once per pair). Every block obeys A(d)_ba = p_a p_b A(d)_ab
  !> (A(-d) = A(d)^T and the inversion parities p, multipole_basis.f90), and so does any sum of
  !> blocks: the kernel and the approximations are kept and formed on the upper triangle only.
  subroutine assemble_correction(comm, basis, op, centres, first, weights, err, companion_unknowns)
    MPI_Comm, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    type(pfft_operator_t), intent(inout) :: op
    real(dp), intent(in) :: centres(:, :)
    integer, intent(in) :: first(:, :)
    real(dp), intent(in) :: weights(:, :, :)
    type(error_t), intent(inout) :: err
    integer, intent(in), optional :: companion_unknowns(:)
    integer, parameter :: batch = 256   ! pairs per BLAS product: its scratch stays in cache
    real(dp), allocatable :: kernel(:, :, :, :), gathered(:, :), pair_weights(:, :), approximate(:, :), block(:, :), &
                             lower_sign(:)
    integer, allocatable :: near(:), pair_row(:), pair_column(:), pair_offset(:), upper_row(:), upper_column(:)
    integer(i8), allocatable :: order(:), offset_start(:)
    type(spatial_index_t) :: cells
    integer(i8), allocatable :: found(:), kept(:), unused(:)
    integer(i8) :: n_found, q
    integer :: reach, nb, s, n_near, k, e, u, dx, dy, dz, d(3), offsets, width, n_pairs, p, stride, in_batch
    integer(i8) :: i
    nb = op%block_size
    s = op%stencil
    call upper_triangle(basis, upper_row, upper_column, lower_sign)
    call make_axial_table(basis, op%axial, comm)
    ! K(d) for every displacement a near pair's stencils can meet, upper triangles
    reach = ceiling(op%near_radius) + s
    allocate (kernel(size(upper_row), -reach:reach, -reach:reach, -reach:reach), block(nb, nb))
    do dz = -reach, reach
      do dy = -reach, reach
        do dx = -reach, reach
          if (dx == 0 .and. dy == 0 .and. dz == 0) then
            block = op%self_block
          else
            call rotated_block(op%axial, real([dx, dy, dz], dp), block)
          end if
          do u = 1, size(upper_row)
            kernel(u, dx, dy, dz) = block(upper_row(u), upper_column(u))
          end do
        end do
      end do
    end do

    ! The near pairs of this rank's rows, and the structure of C.
    call build_spatial_index(centres, cells, err)
    if (err%failed) return
    allocate (near(op%n_beads))
    n_pairs = 0
    do i = 1, op%n_local
      call near_beads(op%first_bead + i - 1)
      n_pairs = n_pairs + n_near
    end do
    allocate (pair_row(n_pairs), pair_column(n_pairs))
    n_pairs = 0
    do i = 1, op%n_local
      call near_beads(op%first_bead + i - 1)
      pair_row(n_pairs + 1:n_pairs + n_near) = int(op%first_bead + i - 1)
      pair_column(n_pairs + 1:n_pairs + n_near) = near(1:n_near)
      n_pairs = n_pairs + n_near
    end do
    op%near_pairs = n_pairs
    call make_near_pair_matrix(comm, nb, op%n_beads, op%first_bead, op%n_local, pair_row, pair_column, op%correction)
    op%has_companion_correction = present(companion_unknowns)
    if (op%has_companion_correction) &
      call make_near_pair_matrix(comm, size(companion_unknowns), op%n_beads, op%first_bead, op%n_local, pair_row, &
                                 pair_column, op%companion_correction)

    ! The pairs by stencil offset (counting sort), each offset's kernel blocks gathered once.
    width = 2 * (reach - s) + 1
    offsets = width**3
    stride = (2 * s - 1)**3
    allocate (pair_offset(n_pairs), order(n_pairs), offset_start(0:offsets + 1))
    do p = 1, n_pairs
      d = first(:, pair_row(p)) - first(:, pair_column(p)) + (reach - s)
      pair_offset(p) = 1 + d(1) + width * (d(2) + width * d(3))
    end do
    call counting_sort(pair_offset, offsets, order, offset_start)
    allocate (gathered(size(upper_row), stride), pair_weights(stride, batch), approximate(size(upper_row), batch))
    do e = 1, offsets
      if (offset_start(e + 1) == offset_start(e)) cycle
      ! the offset's kernel blocks, in the order of the weights (x fastest)
      p = int(order(offset_start(e)))
      d = first(:, pair_row(p)) - first(:, pair_column(p))
      k = 0
      do dz = 1 - s, s - 1
        do dy = 1 - s, s - 1
          do dx = 1 - s, s - 1
            k = k + 1
            gathered(:, k) = kernel(:, d(1) + dx, d(2) + dy, d(3) + dz)
          end do
        end do
      end do
      do q = offset_start(e), offset_start(e + 1) - 1, batch
        in_batch = int(min(int(batch, i8), offset_start(e + 1) - q))
        do k = 1, in_batch
          call stencil_correlation(int(order(q + k - 1)), pair_weights(:, k))
        end do
        call dgemm('N', 'N', size(upper_row), in_batch, stride, 1.0_dp, gathered, size(upper_row), pair_weights, stride, &
                   0.0_dp, approximate, size(upper_row))
        ! C_ij = exact - approximate, the approximation's lower triangle by the parities
        do k = 1, in_batch
          p = int(order(q + k - 1))
          if (pair_row(p) == pair_column(p)) then
            block = op%self_block
          else
            call rotated_block(op%axial, centres(:, pair_row(p)) - centres(:, pair_column(p)), block)
          end if
          do u = 1, size(upper_row)
            block(upper_row(u), upper_column(u)) = block(upper_row(u), upper_column(u)) - approximate(u, k)
            if (upper_row(u) /= upper_column(u)) block(upper_column(u), upper_row(u)) = &
              block(upper_column(u), upper_row(u)) - lower_sign(u) * approximate(u, k)
          end do
          op%correction%blocks(:, :, p) = block
          if (op%has_companion_correction) &
            op%companion_correction%blocks(:, :, p) = block(companion_unknowns, companion_unknowns)
        end do
      end do
    end do

  contains


    !> near(1:n_near): the beads j closer than the near radius to bead b whose pair is kept in
    !> b's row (b itself included), in increasing order. C being symmetric, each pair is kept
    !> once: in the row of the lower bead when b + j is odd, of the higher when it is even, so
    !> the pairs across two ranks' beads are shared between them (in the lower bead's row only,
    !> the first rank would hold them all: 2.8 times the second's pairs on 2000 jittered beads).
    subroutine near_beads(b)
      integer(i8), intent(in) :: b
      call beads_within(cells, centres, centres(:, b), op%near_radius, found, n_found)
      kept = pack(found(1:n_found), found(1:n_found) == b .or. &
                  ((found(1:n_found) > b) .eqv. (mod(found(1:n_found) + b, 2_i8) == 1)))
      unused = kept
      call sort_keys(kept, unused)
      n_near = size(kept)
      near(1:n_near) = int(kept)
    end subroutine near_beads

    !> w(delta) of pair p, delta in the (2s - 1)^3 box x fastest: the product over the axes of
    !> the correlation sum_{m - m' = delta} l_m(R_i) l_m'(R_j) of the two beads' weights.
    subroutine stencil_correlation(p, w)
      integer, intent(in) :: p
      real(dp), intent(out) :: w(:)
      real(dp) :: correlation(1 - s:s - 1, 3)
      integer :: axis, m, n, ex, ey, ez
      do axis = 1, 3
        correlation(:, axis) = 0.0_dp
        do m = 1, s
          correlation(m - s:m - 1, axis) = correlation(m - s:m - 1, axis) + &
                                           weights(m, axis, pair_row(p)) * weights(s:1:-1, axis, pair_column(p))
        end do
      end do
      n = 0
      do ez = 1 - s, s - 1
        do ey = 1 - s, s - 1
          do ex = 1 - s, s - 1
            n = n + 1
            w(n) = correlation(ex, 1) * correlation(ey, 2) * correlation(ez, 3)
          end do
        end do
      end do
    end subroutine stencil_correlation
  end subroutine assemble_correction

  !> The upper triangle (a <= b) of a block of this basis, column by column, and the sign
  !> p_a p_b that gives the lower triangle: A(d)_ba = p_a p_b A(d)_ab.
  subroutine upper_triangle(basis, upper_row, upper_column, lower_sign)
    type(multipole_basis_t), intent(in) :: basis
    integer, allocatable, intent(out) :: upper_row(:), upper_column(:)
    real(dp), allocatable, intent(out) :: lower_sign(:)
    integer :: a, b, u
    allocate (upper_row(basis%size * (basis%size + 1) / 2), upper_column(basis%size * (basis%size + 1) / 2), &
              lower_sign(basis%size * (basis%size + 1) / 2))
    u = 0
    do b = 1, basis%size
      do a = 1, b
        u = u + 1
        upper_row(u) = a
        upper_column(u) = b
        lower_sign(u) = real(inversion_parity(basis%degree(a), basis%family(a)) * &
                             inversion_parity(basis%degree(b), basis%family(b)), dp)
      end do
    end do
  end subroutine upper_triangle

  !> grid_centres: the centres in the frame of the grid, the principal axes of the bead set (about
  !> its centroid) when their padded FFT box is smaller by 10 % or more, else the centres as given.
  subroutine choose_frame(op, centres, grid_centres)
    type(pfft_operator_t), intent(inout) :: op
    real(dp), intent(in) :: centres(:, :)
    real(dp), allocatable, intent(out) :: grid_centres(:, :)
    real(dp) :: centroid(3), gyration(3, 3), eigenvalues(3), work(64)
    real(dp), allocatable :: turned(:, :)
    integer :: info
    centroid = sum(centres, dim=2) / size(centres, 2)
    turned = centres - spread(centroid, 2, size(centres, 2))
    gyration = matmul(turned, transpose(turned))
    call dsyev('V', 'U', 3, gyration, 3, eigenvalues, work, size(work), info)
    op%turned = .false.
    if (info == 0) then
      ! a proper rotation: the third axis the cross product of the first two
      gyration(:, 3) = [gyration(2, 1) * gyration(3, 2) - gyration(3, 1) * gyration(2, 2), &
                        gyration(3, 1) * gyration(1, 2) - gyration(1, 1) * gyration(3, 2), &
                        gyration(1, 1) * gyration(2, 2) - gyration(2, 1) * gyration(1, 2)]
      turned = matmul(transpose(gyration), turned)
      op%turned = box_sites(turned) <= 0.9_dp * box_sites(centres)
    end if
    if (op%turned) then
      op%frame = gyration
      call move_alloc(turned, grid_centres)
    else
      grid_centres = centres
    end if

  contains

    !> Sites of the padded FFT box of the grid of these centres (fft_operator.F90's rule).
    real(dp) function box_sites(points)
      real(dp), intent(in) :: points(:, :)
      integer :: axis
      box_sites = 1.0_dp
      do axis = 1, 3
        box_sites = box_sites * fft_size(2 * (ceiling(maxval(points(axis, :)) - minval(points(axis, :))) + op%stencil) + 1)
      end do
    end function box_sites
  end subroutine choose_frame

  !> D_Q of the frame for unknowns of these degrees and families (groups: runs of one (n, sigma)).
  subroutine set_turn(op, order, degree, family)
    type(pfft_operator_t), intent(inout) :: op
    integer, intent(in) :: order, degree(:), family(:)
    integer :: a, groups
    allocate (op%turn(2 * order + 1, 2 * order + 1, order))
    call degree_rotations(make_rotation_rule(order), op%frame, op%turn)
    allocate (op%group_first(size(degree)), op%group_last(size(degree)), op%group_degree(size(degree)))
    groups = 0
    do a = 1, size(degree)
      if (a > 1) then
        if (degree(a) == degree(a - 1) .and. family(a) == family(a - 1)) cycle
      end if
      groups = groups + 1
      op%group_first(groups) = a
      op%group_last(groups) = a + 2 * degree(a)
      op%group_degree(groups) = degree(a)
    end do
    op%group_first = op%group_first(1:groups)
    op%group_last = op%group_last(1:groups)
    op%group_degree = op%group_degree(1:groups)
  end subroutine set_turn

  !> out = D_Q in (to_lab) or D_Q^T in, bead by bead and group by group.
  subroutine turn_vector(op, in, out, to_lab, ierr)
    type(pfft_operator_t), intent(in) :: op
    Vec, intent(in) :: in
    Vec, intent(in) :: out   ! a PETSc handle: the vector behind it is written
    logical, intent(in) :: to_lab
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: source(:), target_(:)
    integer(i8) :: bead
    integer :: g, n, f, l, offset
    PetscCall(VecGetArrayReadF90(in, source, ierr))
    PetscCall(VecGetArrayF90(out, target_, ierr))
    do bead = 1, op%n_local
      offset = int((bead - 1) * op%block_size)
      do g = 1, size(op%group_first)
        n = op%group_degree(g)
        f = offset + op%group_first(g)
        l = offset + op%group_last(g)
        if (to_lab) then
          target_(f:l) = matmul(op%turn(1:2 * n + 1, 1:2 * n + 1, n), source(f:l))
        else
          target_(f:l) = matmul(source(f:l), op%turn(1:2 * n + 1, 1:2 * n + 1, n))
        end if
      end do
    end do
    PetscCall(VecRestoreArrayF90(out, target_, ierr))
    PetscCall(VecRestoreArrayReadF90(in, source, ierr))
  end subroutine turn_vector

  subroutine make_shell(comm, op, matrix)
    MPI_Comm, intent(in) :: comm
    type(pfft_operator_t), target, intent(inout) :: op
    Mat, intent(out) :: matrix
    PetscErrorCode :: ierr
    PetscInt :: local_size, global_size
    local_size = int(op%n_local * op%block_size)
    global_size = int(op%n_beads * op%block_size)
    PetscCallA(MatCreateShell(comm, local_size, local_size, global_size, global_size, op, matrix, ierr))
    PetscCallA(MatShellSetOperation(matrix, MATOP_MULT, apply_pfft_operator, ierr))
    PetscCallA(MatSetOption(matrix, MAT_SYMMETRIC, PETSC_TRUE, ierr))
    op%created = .true.
  end subroutine make_shell

  !> Collective. The operator of the sub-basis `unknowns` (theory.md T14): the grid's companion,
  !> the sub-matrix of I and the companion C assembled with the parent (a block entry depends on
  !> its two functions only). The parent must have been created with these companion_unknowns
  !> and outlive the companion.
  subroutine create_pfft_companion(comm, parent, unknowns, companion, matrix, err)
    MPI_Comm, intent(in) :: comm
    type(pfft_operator_t), target, intent(inout) :: parent
    integer, intent(in) :: unknowns(:)
    type(pfft_operator_t), target, intent(inout) :: companion
    Mat, intent(out) :: matrix
    type(error_t), intent(inout) :: err
    PetscErrorCode :: ierr
    companion%block_size = size(unknowns)
    companion%n_beads = parent%n_beads
    companion%first_bead = parent%first_bead
    companion%n_local = parent%n_local
    companion%stencil = parent%stencil
    companion%near_radius = parent%near_radius
    companion%self_block = parent%self_block(unknowns, unknowns)
    companion%turned = parent%turned
    if (parent%turned) then
      companion%frame = parent%frame
      companion%turn = parent%turn
      call companion_groups()
    end if
    companion%n_grid = parent%n_grid
    companion%near_pairs = parent%near_pairs
    if (.not. parent%has_companion_correction) then
      call raise(err, 'internal: the pfft operator was created without its companion''s unknowns')
      return
    end if
    call create_fft_companion(comm, parent%grid, unknowns, companion%grid, companion%grid_matrix, err)
    if (err%failed) return
    ! The same weights for the sub-basis's unknowns (a reference: each operator destroys its own).
    companion%node_weights = parent%node_weights
    PetscCallA(PetscObjectReference(parent%node_weights, ierr))
    PetscCallA(MatCreateMAIJ(companion%node_weights, companion%block_size, companion%interpolation, ierr))
    call hand_over_near_pair_matrix(parent%companion_correction, companion%correction)   ! the companion destroys it
    parent%has_companion_correction = .false.
    call make_shell(comm, companion, matrix)

  contains

    !> The parent's (n, sigma) groups that the sub-basis keeps whole (a lower order keeps whole
    !> degrees), renumbered in the sub-basis.
    subroutine companion_groups()
      integer :: g, a, groups
      allocate (companion%group_first(size(parent%group_first)), companion%group_last(size(parent%group_first)), &
                companion%group_degree(size(parent%group_first)))
      groups = 0
      do g = 1, size(parent%group_first)
        a = findloc(unknowns, parent%group_first(g), dim=1)
        if (a == 0) cycle
        groups = groups + 1
        companion%group_first(groups) = a
        companion%group_last(groups) = a + parent%group_last(g) - parent%group_first(g)
        companion%group_degree(groups) = parent%group_degree(g)
      end do
      companion%group_first = companion%group_first(1:groups)
      companion%group_last = companion%group_last(1:groups)
      companion%group_degree = companion%group_degree(1:groups)
    end subroutine companion_groups
  end subroutine create_pfft_companion

  subroutine destroy_pfft_operator(op, matrix)
    type(pfft_operator_t), intent(inout) :: op
    Mat, intent(inout) :: matrix
    PetscErrorCode :: ierr
    if (.not. op%created) then
      call destroy_fft_operator(op%grid, op%grid_matrix)
      return
    end if
    PetscCallA(MatDestroy(op%interpolation, ierr))
    PetscCallA(MatDestroy(op%node_weights, ierr))
    call free_pfft_batches(op)
    call destroy_near_pair_matrix(op%correction)
    if (op%has_companion_correction) then
      call destroy_near_pair_matrix(op%companion_correction)
      op%has_companion_correction = .false.
    end if
    call destroy_fft_operator(op%grid, op%grid_matrix)
    PetscCallA(MatDestroy(matrix, ierr))
    op%created = .false.
  end subroutine destroy_pfft_operator

  !> MATOP_MULT: y = I G I^T x + C x.
  subroutine apply_pfft_operator(matrix, x, y, ierr)
    Mat :: matrix
    Vec :: x, y
    PetscErrorCode :: ierr
    type(pfft_operator_t), pointer :: op
    PetscCall(MatShellGetContext(matrix, op, ierr))
    call apply_pfft_many(op, [x], [y])
    ierr = 0
  end subroutine apply_pfft_operator

  !> multipole_operator_t%apply_many: y(j) = A x(j) for the batch at once: the grid's batched
  !> product (the kernel streamed once, fft_operator.F90) and one pass over C's blocks for all
  !> vectors (near_pair_matrix.F90).
  subroutine apply_pfft_many(this, x, y)
    class(pfft_operator_t), target, intent(inout) :: this
    Vec, intent(in) :: x(:)
    Vec, intent(in) :: y(:)   ! PETSc handles: the vectors behind them are written
    integer :: n, v
    PetscErrorCode :: ierr
    n = size(x)
    if (.not. allocated(this%batch_grid_x)) call make_batch_vectors(this, n, x(1))
    if (size(this%batch_grid_x) < n) call make_batch_vectors(this, n, x(1))
    if (this%turned) then
      do v = 1, n
        PetscCallA(turn_vector(this, x(v), this%batch_frame_x(v), .false., ierr))
      end do
      call frame_products(this, this%batch_frame_x(1:n), this%batch_frame_y(1:n), this%batch_grid_x(1:n), &
                          this%batch_grid_y(1:n))
      do v = 1, n
        PetscCallA(turn_vector(this, this%batch_frame_y(v), y(v), .true., ierr))
      end do
    else
      call frame_products(this, x, y, this%batch_grid_x(1:n), this%batch_grid_y(1:n))
    end if
  end subroutine apply_pfft_many

  !> v(j) = I G I^T u(j) + C u(j) in the grid's frame, grid_x and grid_y the grid vectors to use.
  subroutine frame_products(op, u, v, grid_x, grid_y)
    type(pfft_operator_t), intent(inout) :: op
    Vec, intent(in) :: u(:), v(:), grid_x(:), grid_y(:)
    PetscErrorCode :: ierr
    integer :: j
    do j = 1, size(u)
      PetscCallA(MatMultTranspose(op%interpolation, u(j), grid_x(j), ierr))
    end do
    if (size(u) == 1) then   ! a single product makes no batch copies the grid would keep at one
      PetscCallA(MatMult(op%grid_matrix, grid_x(1), grid_y(1), ierr))
    else
      call op%grid%apply_many(grid_x, grid_y)
    end if
    do j = 1, size(u)
      PetscCallA(MatMult(op%interpolation, grid_y(j), v(j), ierr))
    end do
    call near_pair_product(op%correction, u, v)
  end subroutine frame_products

  !> Collective. The grid (and frame) vectors for batches of up to n vectors; the frame vectors
  !> have the layout of `bead_vector`, any vector of the operator's beads.
  subroutine make_batch_vectors(op, n, bead_vector)
    type(pfft_operator_t), intent(inout) :: op
    integer, intent(in) :: n
    Vec, intent(in) :: bead_vector
    PetscErrorCode :: ierr
    integer :: v
    call destroy_batch_vectors(op)
    allocate (op%batch_grid_x(n), op%batch_grid_y(n), op%batch_frame_x(merge(n, 0, op%turned)), &
              op%batch_frame_y(merge(n, 0, op%turned)))
    do v = 1, n
      PetscCallA(MatCreateVecs(op%grid_matrix, op%batch_grid_x(v), op%batch_grid_y(v), ierr))
      if (.not. op%turned) cycle
      PetscCallA(VecDuplicate(bead_vector, op%batch_frame_x(v), ierr))
      PetscCallA(VecDuplicate(bead_vector, op%batch_frame_y(v), ierr))
    end do
  end subroutine make_batch_vectors

  subroutine destroy_batch_vectors(op)
    type(pfft_operator_t), intent(inout) :: op
    PetscErrorCode :: ierr
    integer :: v
    if (.not. allocated(op%batch_grid_x)) return
    do v = 1, size(op%batch_grid_x)
      PetscCallA(VecDestroy(op%batch_grid_x(v), ierr))
      PetscCallA(VecDestroy(op%batch_grid_y(v), ierr))
    end do
    do v = 1, size(op%batch_frame_x)
      PetscCallA(VecDestroy(op%batch_frame_x(v), ierr))
      PetscCallA(VecDestroy(op%batch_frame_y(v), ierr))
    end do
    deallocate (op%batch_grid_x, op%batch_grid_y, op%batch_frame_x, op%batch_frame_y)
  end subroutine destroy_batch_vectors

  !> multipole_operator_t%free_batches: the product vectors and the grid's batch buffers.
  subroutine free_pfft_batches(this)
    class(pfft_operator_t), intent(inout) :: this
    call destroy_batch_vectors(this)
    call this%grid%free_batches()
  end subroutine free_pfft_batches
end module beadmob_pfft_operator
