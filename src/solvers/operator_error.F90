!> The error of an approximate operator's friction, measured in the run that uses it
!> (docs/theory.md T16, "The far field's error in every run"). The pfft operator A~ differs from
!> the Galerkin operator A by E = A - A~ on the pairs beyond its near radius (its far-field
!> interpolation). With q_m = A~^-1 c_m the run's solutions,
!>   zeta_mn(A) - zeta_mn(A~) = -q_m . E q_n + (E q_m) . A^-1 (E q_n) + O(E^3)
!> (A^-1 = A~^-1 - A~^-1 E A~^-1 + A~^-1 E A~^-1 E A~^-1 - ...), sums over the beads of the rows'
!>   t_i(m, n) = -q_m,i . (E q_n)_i   and, with S the single-bead block,
!>   w_i(m, n) = (E q_m)_i . S^-1 (E q_n)_i   (the second order is about rho sum w, rho ~ 0.5 .. 2.5),
!> where (E q)_i = (A q)_i - (A~ q)_i: (A~ q)_i = c_i - r_i is known from the solve (its true
!> residual r), (A q)_i is the exact product of row i, every pair of bead i (the axial table turned
!> to the pair, theory.md T15), N pairs per row. So the rows are sampled (all of them for small
!> models): s draws with probabilities p_i, half uniform and half in proportion to the bead's share
!> of the solutions (sum over m of |q_m,i|^2 / |q_m|^2: the first-order terms follow it), taken
!> systematically along the bead numbering from a fixed start; the sums are estimated as the mean
!> of t / p over the draws, with its standard error (hydro/operator_error_bar.f90 turns both into
!> the mobility's error bar).
module beadmob_operator_error
#include "petsc/finclude/petscvec.h"
  use petscvec
  use beadmob_kinds, only: dp, i8
  use beadmob_multipole_basis, only: multipole_basis_t
  use beadmob_axial_table, only: axial_table_t, make_axial_table
  use beadmob_harmonic_rotation, only: direction_rotations
  use beadmob_lapack, only: dgemm, dpotrf, dpotrs
  implicit none
  private
  public :: operator_sample_t, sample_operator_error, operator_error_rows, systematic_rows, default_rows
  public :: sparse_axial_t, make_sparse_axial, add_pair_product

  !> Rows of a sample (an exact row costs N pair products: about 5 % of a default pfft job at
  !> L = 1 and 2, bench/error_estimate/operator_error.md), and every row when N^2 pair products
  !> are at most every_row_pairs (at L = 2; in proportion to 16 / nb at other orders: the cost
  !> of a pair product follows nb).
  integer, parameter :: default_rows = 64
  real(dp), parameter :: every_row_pairs = 2.5e4_dp
  !> The share of the draws in proportion to the solutions (the rest uniform)
  real(dp), parameter :: solution_share = 0.5_dp

  !> The axial table's blocks on their nonzero entries (an axial pair couples only functions of
  !> the same harmonic index), for products without forming a block (add_pair_product).
  type :: sparse_axial_t
    integer, allocatable :: row(:), column(:)
    real(dp), allocatable :: values(:, :)      ! (nonzero entries, nodes)
  end type sparse_axial_t

  !> The sampled rows of a run and their terms (theory.md T16), in the frame of the solve.
  type :: operator_sample_t
    integer(i8) :: n_beads = 0                 ! N, the beads of the solve
    integer :: rows = 0                        ! s draws (0: no sample taken)
    logical :: every_row = .false.             ! rows 1..N, each once: the sums exact
    integer(i8), allocatable :: row(:)         ! the bead of each draw (a bead may be drawn twice)
    real(dp), allocatable :: probability(:)    ! p of each draw's bead (1 / N for every_row)
    real(dp), allocatable :: terms(:, :, :)    ! (6, 6, s): t_i(m, n) of each draw
    real(dp), allocatable :: second(:, :, :)   ! (6, 6, s): w_i(m, n) of each draw
    real(dp), allocatable :: size_of_row(:)    ! the draw's bead's share of the solutions (of 1)
    real(dp) :: seconds = 0.0_dp               ! wall time of the sample (max over ranks)
  end type operator_sample_t

contains

  !> The draws of a sample of N beads with nb unknowns each: every row when N^2 pair products
  !> are within every_row_pairs (scaled to nb), else default_rows; `requested` > 0 instead: that
  !> many (every row when >= N).
  pure integer function operator_error_rows(n_beads, nb, requested)
    integer(i8), intent(in) :: n_beads
    integer, intent(in) :: nb, requested
    if (requested > 0) then
      operator_error_rows = int(min(int(requested, i8), n_beads))
    else if (real(n_beads, dp)**2 <= every_row_pairs * 16.0_dp / nb) then
      operator_error_rows = int(n_beads)
    else
      operator_error_rows = int(min(int(default_rows, i8), n_beads))
    end if
  end function operator_error_rows

  !> s draws with the probabilities p (summing to 1), taken systematically: the points
  !> (k - 1 + u) / s, k = 1..s, of the cumulative distribution along the numbering, u = 0.618...
  !> (a fixed start: every rank and every run of a job draws the same rows). A bead of p > 1 / s
  !> is drawn floor(p s) or more times.
  pure function systematic_rows(probability, s) result(row)
    real(dp), intent(in) :: probability(:)
    integer, intent(in) :: s
    integer(i8) :: row(s), i
    real(dp), parameter :: start = 0.6180339887498949_dp
    real(dp) :: cumulative, point
    integer :: k
    i = 1
    cumulative = probability(1)
    do k = 1, s
      point = (k - 1 + start) / s
      do while (cumulative < point .and. i < size(probability, kind=i8))
        i = i + 1
        cumulative = cumulative + probability(i)
      end do
      row(k) = i
    end do
  end function systematic_rows

  !> Collective. A sample of `draws` rows (every row when draws >= N) for the solutions q_m (this
  !> rank's beads first_bead .. first_bead + n_local - 1), the right-hand sides c_m and the true
  !> residuals r_m = c_m - A~ q_m of the operator A~, nb = basis%size unknowns per bead; centres:
  !> all beads of the solve, in its frame; self_block: the single-bead block S. The rows are drawn
  !> from every bead's share of the solutions (gathered on every rank); each rank sums the exact
  !> pair products of its own beads into every drawn row, the sums are added over the ranks, and
  !> the owner of each row forms its terms. table: the basis's axial table when the operator kept
  !> one (made here otherwise).
  subroutine sample_operator_error(comm, basis, self_block, centres, first_bead, n_local, solution, rhs, residual, &
                                   draws, sample, table)
    MPI_Comm, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: self_block(:, :), centres(:, :)
    integer(i8), intent(in) :: first_bead, n_local
    Vec, intent(in) :: solution(6), rhs(6), residual(6)
    integer, intent(in) :: draws
    type(operator_sample_t), intent(out) :: sample
    type(axial_table_t), intent(in), optional :: table
    type(axial_table_t) :: axial
    type(sparse_axial_t) :: sparse
    real(dp), allocatable :: q(:, :, :), exact(:, :, :), factor(:, :), difference(:, :), solved(:, :)
    integer :: info, n_ranks
    real(dp) :: total(6)
    real(dp), allocatable :: share(:), local_share(:)
    integer, allocatable :: counts(:), offsets(:)
    integer(i8), allocatable :: rows(:)
    PetscScalar, pointer :: values(:), c_values(:), r_values(:)
    PetscErrorCode :: ierr
    real(dp) :: start
    integer :: nb, m, n, k
    integer(i8) :: i, j, local
    start = MPI_Wtime()
    nb = basis%size
    sample%n_beads = size(centres, 2, kind=i8)
    allocate (q(nb, 6, n_local))
    do m = 1, 6
      PetscCallA(VecGetArrayReadF90(solution(m), values, ierr))
      do local = 1, n_local
        q(:, m, local) = values(nb * (local - 1) + 1:nb * local)
      end do
      PetscCallA(VecRestoreArrayReadF90(solution(m), values, ierr))
    end do
    ! Every bead's share of the solutions, on every rank; the draws from it.
    total = sum(sum(q**2, dim=3), dim=1)
    call MPI_Allreduce(MPI_IN_PLACE, total, 6, MPI_DOUBLE_PRECISION, MPI_SUM, comm, ierr)
    allocate (local_share(n_local), share(sample%n_beads))
    do local = 1, n_local
      local_share(local) = 0.0_dp
      do m = 1, 6
        if (total(m) > 0.0_dp) local_share(local) = local_share(local) + sum(q(:, m, local)**2) / total(m)
      end do
    end do
    call MPI_Comm_size(comm, n_ranks, ierr)
    allocate (counts(n_ranks), offsets(n_ranks))
    call MPI_Allgather(int(n_local), 1, MPI_INTEGER, counts, 1, MPI_INTEGER, comm, ierr)
    offsets(1) = 0
    do k = 2, n_ranks
      offsets(k) = offsets(k - 1) + counts(k - 1)
    end do
    call MPI_Allgatherv(local_share, int(n_local), MPI_DOUBLE_PRECISION, share, counts, offsets, MPI_DOUBLE_PRECISION, &
                        comm, ierr)
    sample%every_row = draws >= sample%n_beads .or. sum(share) <= 0.0_dp
    if (sample%every_row) then
      rows = [(i, i = 1, sample%n_beads)]
      sample%probability = [(1.0_dp / sample%n_beads, i = 1, sample%n_beads)]
    else
      share = share / sum(share)
      rows = systematic_rows(solution_share * share + (1.0_dp - solution_share) / sample%n_beads, draws)
      sample%probability = solution_share * share(rows) + (1.0_dp - solution_share) / sample%n_beads
    end if
    sample%size_of_row = share(rows)
    sample%rows = size(rows)
    sample%row = rows
    allocate (exact(nb, 6, size(rows)))
    if (present(table)) then
      axial = table
    else
      call make_axial_table(basis, axial, comm)
    end if
    call make_sparse_axial(axial, sparse)
    ! (A q)_i of every sampled row i, this rank's columns j
    exact = 0.0_dp
    do local = 1, n_local
      j = first_bead + local - 1
      do k = 1, size(rows)
        i = rows(k)
        if (i == j) then
          call dgemm('N', 'N', nb, 6, nb, 1.0_dp, self_block, nb, q(:, :, local), nb, 1.0_dp, exact(:, :, k), nb)
        else
          call add_pair_product(axial, sparse, centres(:, i) - centres(:, j), q(:, :, local), exact(:, :, k))
        end if
      end do
    end do
    call MPI_Allreduce(MPI_IN_PLACE, exact, size(exact), MPI_DOUBLE_PRECISION, MPI_SUM, comm, ierr)
    ! The owner's terms: (E q_n)_i = (A q_n)_i - (c_n - r_n)_i, t_i(m, n) = -q_m,i . (E q_n)_i
    allocate (sample%terms(6, 6, size(rows)), sample%second(6, 6, size(rows)))
    sample%terms = 0.0_dp
    sample%second = 0.0_dp
    factor = self_block
    call dpotrf('L', nb, factor, nb, info)
    allocate (difference(nb, 6), solved(nb, 6))
    do n = 1, 6
      PetscCallA(VecGetArrayReadF90(rhs(n), c_values, ierr))
      PetscCallA(VecGetArrayReadF90(residual(n), r_values, ierr))
      do k = 1, size(rows)
        local = rows(k) - first_bead + 1
        if (local < 1 .or. local > n_local) cycle
        exact(:, n, k) = exact(:, n, k) - (c_values(nb * (local - 1) + 1:nb * local) - &
                                           r_values(nb * (local - 1) + 1:nb * local))
      end do
      PetscCallA(VecRestoreArrayReadF90(residual(n), r_values, ierr))
      PetscCallA(VecRestoreArrayReadF90(rhs(n), c_values, ierr))
    end do
    do k = 1, size(rows)
      local = rows(k) - first_bead + 1
      if (local < 1 .or. local > n_local) cycle
      difference = exact(:, :, k)
      solved = difference
      call dpotrs('L', nb, 6, factor, nb, solved, nb, info)
      sample%terms(:, :, k) = -matmul(transpose(q(:, :, local)), difference)
      sample%second(:, :, k) = matmul(transpose(difference), solved)
    end do
    call MPI_Allreduce(MPI_IN_PLACE, sample%terms, size(sample%terms), MPI_DOUBLE_PRECISION, MPI_SUM, comm, ierr)
    call MPI_Allreduce(MPI_IN_PLACE, sample%second, size(sample%second), MPI_DOUBLE_PRECISION, MPI_SUM, comm, ierr)
    sample%seconds = MPI_Wtime() - start
    call MPI_Allreduce(MPI_IN_PLACE, sample%seconds, 1, MPI_DOUBLE_PRECISION, MPI_MAX, comm, ierr)
  end subroutine sample_operator_error

  !> The nonzero entries of the table's node blocks (an entry zero at every node is zero at every
  !> distance; zero means within rounding, 1e-13 of the nodes' largest entry) and their values at
  !> the nodes.
  subroutine make_sparse_axial(axial, sparse)
    type(axial_table_t), intent(in) :: axial
    type(sparse_axial_t), intent(out) :: sparse
    logical :: nonzero(axial%block_size, axial%block_size)
    integer :: a, b, e
    nonzero = maxval(abs(axial%blocks), dim=3) > 1.0e-13_dp * maxval(abs(axial%blocks))
    allocate (sparse%row(count(nonzero)), sparse%column(count(nonzero)), &
              sparse%values(count(nonzero), size(axial%nodes)))
    e = 0
    do b = 1, axial%block_size
      do a = 1, axial%block_size
        if (.not. nonzero(a, b)) cycle
        e = e + 1
        sparse%row(e) = a
        sparse%column(e) = b
        sparse%values(e, :) = axial%blocks(a, b, :)
      end do
    end do
  end subroutine make_sparse_axial

  !> y = y + A(displacement) x, x and y (nb, 6): A = D_Q A_z D_Q^T (theory.md T15) applied as
  !> D_Q^T x group by group, the axial block's nonzero entries interpolated in 1 / r and applied,
  !> then D_Q group by group; a tenth of the flops of forming the block (rotated_block) first.
  pure subroutine add_pair_product(axial, sparse, displacement, x, y)
    type(axial_table_t), intent(in) :: axial
    type(sparse_axial_t), intent(in) :: sparse
    real(dp), intent(in) :: displacement(3), x(:, :)
    real(dp), intent(inout) :: y(:, :)
    real(dp) :: rotations(2 * axial%order + 1, 2 * axial%order + 1, axial%order), weights(size(axial%nodes)), &
                values(size(sparse%row)), turned(size(x, 1), size(x, 2)), product(size(x, 1), size(x, 2))
    integer :: g, n, f, e, k, a, b, v
    ! the interpolation weights in x = 1 / r (axial_table.f90, axial_block)
    weights = 1.0_dp / norm2(displacement) - axial%nodes
    k = minloc(abs(weights), dim=1)
    if (weights(k) == 0.0_dp) then
      values = sparse%values(:, k)
    else
      weights = axial%barycentric_weights / weights
      weights = weights / sum(weights)
      values = matmul(sparse%values, weights)
    end if
    call direction_rotations(axial%rotation, displacement, rotations)
    ! turned = D^T x, product = A_z turned, y += D product (loops: no temporaries)
    turned = 0.0_dp
    do g = 1, size(axial%group_first)
      n = 2 * axial%group_degree(g) + 1
      f = axial%group_first(g) - 1
      do v = 1, size(x, 2)
        do b = 1, n
          do a = 1, n
            turned(f + b, v) = turned(f + b, v) + rotations(a, b, axial%group_degree(g)) * x(f + a, v)
          end do
        end do
      end do
    end do
    product = 0.0_dp
    do v = 1, size(x, 2)
      do e = 1, size(sparse%row)
        product(sparse%row(e), v) = product(sparse%row(e), v) + values(e) * turned(sparse%column(e), v)
      end do
    end do
    do g = 1, size(axial%group_first)
      n = 2 * axial%group_degree(g) + 1
      f = axial%group_first(g) - 1
      do v = 1, size(x, 2)
        do b = 1, n
          do a = 1, n
            y(f + a, v) = y(f + a, v) + rotations(a, b, axial%group_degree(g)) * product(f + b, v)
          end do
        end do
      end do
    end do
  end subroutine add_pair_product
end module beadmob_operator_error
