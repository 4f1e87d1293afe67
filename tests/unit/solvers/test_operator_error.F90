!> Tests src/solvers/operator_error.F90 and src/hydro/operator_error_bar.f90: the pfft far field's
!> error measured on exact rows (docs/theory.md T16, "The far field's error in every run").
!> CTest: test_operator_error_np1 and test_operator_error_np2.
!>  1. The pair product without the block (add_pair_product: D_Q^T, the axial block's nonzero
!>     entries, D_Q) equals the turned block's product (rotated_block, theory.md T15) to 1e-12 of
!>     the product, L = 1, 2, 3, at twelve displacements from touching to 30 d.
!>  2. The systematic draws: with equal probabilities and s = N, every bead once; otherwise
!>     nondecreasing along the numbering, draw k where the cumulative probability passes
!>     (k - 1 + u) / s, and a bead of p > 1 / s drawn at least floor(p s) times.
!>  3. The terms of all rows of a jittered 4 x 4 x 4 cluster (L = 2, pfft at near radius 3 d against
!>     the direct operator, random vectors q and right-hand sides c, r = c - A~ q) add up to
!>     -q_m . (A - A~) q_n, and their second-order parts to (E q_m) . S^-1 (E q_n) summed over the
!>     beads, both to 1e-10 of the sum's largest entry, on 1 and 2 ranks.
!>  4. The error bar of a sample: with every row, no standard error and the change exact (the first
!>     order and the second's mid value); the bound of a diagonal entry is |change| and the second
!>     order's allowance (operator_error_bar.f90).
program test_operator_error
#include "petsc/finclude/petscmat.h"
  use petscmat
  use beadmob_kinds, only: dp, i8
  use beadmob_testing
  use beadmob_random_vectors, only: fill_random, hash_uniform
  use beadmob_errors, only: error_t
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t, make_run_context, block_range
  use beadmob_multipole_basis, only: multipole_basis_t, make_multipole_basis
  use beadmob_axial_table, only: axial_table_t, make_axial_table, rotated_block
  use beadmob_bead_operator, only: bead_operator_t, create_bead_operator, destroy_bead_operator
  use beadmob_pfft_operator, only: pfft_operator_t, create_pfft_operator, destroy_pfft_operator
  use beadmob_pair_blocks, only: self_block
  use beadmob_lapack, only: dpotrf, dpotrs
  use beadmob_operator_error, only: operator_sample_t, sample_operator_error, systematic_rows, sparse_axial_t, &
                                    make_sparse_axial, add_pair_product
  use beadmob_operator_error_bar, only: operator_error_t, estimate_operator_error, second_order_mid, second_order_half, &
                                        coverage
  implicit none
  type(test_suite_t) :: suite
  type(run_context_t) :: ctx
  PetscErrorCode :: ierr
  integer :: order

  PetscCallA(PetscInitialize(ierr))
  suite = start_tests('test_operator_error')
  ctx = make_run_context(PETSC_COMM_WORLD)
  do order = 1, 3
    call check_pair_products(order)
  end do
  call check_systematic_rows()
  call check_terms()
  call finish_tests(suite)
  PetscCallA(PetscFinalize(ierr))

contains

  subroutine check_pair_products(order)
    integer, intent(in) :: order
    type(multipole_basis_t) :: basis
    type(axial_table_t) :: table
    type(sparse_axial_t) :: sparse
    real(dp), allocatable :: block(:, :), x(:, :), y(:, :)
    real(dp) :: d(3), worst
    integer :: k, a, v
    basis = make_multipole_basis(order, max(order - 2, 0))
    call make_axial_table(basis, table)
    call make_sparse_axial(table, sparse)
    allocate (block(basis%size, basis%size), x(basis%size, 6), y(basis%size, 6))
    do v = 1, 6
      do a = 1, basis%size
        x(a, v) = hash_uniform(int(97 * a + 13 * v, i8)) - 0.5_dp
      end do
    end do
    worst = 0.0_dp
    do k = 1, 12
      d = [hash_uniform(int(5 * k, i8)), hash_uniform(int(5 * k + 1, i8)), hash_uniform(int(5 * k + 2, i8))] - 0.5_dp
      d = d / norm2(d) * (1.0_dp + 29.0_dp * hash_uniform(int(300 + k, i8))**2)
      if (k == 1) d = [0.0_dp, 0.0_dp, 1.0_dp]     ! touching on the z axis (the table's own direction)
      if (k == 2) d = [0.0_dp, -1.0_dp, 0.0_dp]
      call rotated_block(table, d, block)
      y = 0.0_dp
      call add_pair_product(table, sparse, d, x, y)
      worst = max(worst, maxval(abs(y - matmul(block, x))) / maxval(abs(matmul(block, x))))
    end do
    call check(suite, worst <= 1.0e-12_dp, 'L = ' // str(order) // ': pair product without the block = the turned ' // &
               'block''s product, worst relative difference ' // str(worst))
  end subroutine check_pair_products

  subroutine check_systematic_rows()
    integer(i8), allocatable :: rows(:)
    real(dp) :: p(1000), cumulative
    integer :: k
    logical :: placed
    rows = systematic_rows([(1.0_dp / 50, k = 1, 50)], 50)
    call check(suite, all(rows == [(int(k, i8), k = 1, 50)]), 'systematic draws: every bead once at s = N, ' // &
               'equal probabilities')
    do k = 1, 1000
      p(k) = 1.0_dp + 10.0_dp * hash_uniform(int(k, i8))**4
    end do
    p(500) = 200.0_dp        ! a bead of p > 1 / s
    p = p / sum(p)
    rows = systematic_rows(p, 37)
    placed = all(rows(2:) >= rows(:36))
    do k = 1, 37
      cumulative = sum(p(1:rows(k)))
      placed = placed .and. cumulative >= (k - 1 + 0.6180339887498949_dp) / 37 .and. &
               cumulative - p(rows(k)) < (k - 1 + 0.6180339887498949_dp) / 37
    end do
    call check(suite, placed, 'systematic draws: along the numbering, each where its point falls')
    call check(suite, count(rows == 500) >= floor(p(500) * 37), 'systematic draws: a bead of p = ' // str(p(500)) // &
               ' drawn ' // str(count(rows == 500)) // ' times of 37')
  end subroutine check_systematic_rows

  !> Item 3 and 4 on a jittered cluster.
  subroutine check_terms()
    type(multipole_basis_t) :: basis
    type(bead_operator_t), target :: direct
    type(pfft_operator_t), target :: fast
    type(operator_sample_t) :: sample
    type(operator_error_t) :: bar
    type(error_t) :: err
    real(dp), allocatable :: centres(:, :), self(:, :), factor(:, :), local_e(:, :), solved(:, :)
    Mat :: direct_matrix, pfft_matrix
    Vec :: q(6), c(6), r(6), exact_product(6)
    integer(i8) :: first, count, i
    real(dp) :: expected(6, 6), expected_second(6, 6), worst, worst_second, mobility(6, 6), friction(6, 6)
    PetscScalar, pointer :: qv(:), ev(:), av(:)
    integer :: m, n, info, nb
    centres = jittered([4, 4, 4])
    basis = make_multipole_basis(2, 0)
    nb = basis%size
    call block_range(ctx, size(centres, 2, kind=i8), first, count)
    call create_bead_operator(ctx%comm, basis, centres, first, count, direct, direct_matrix, err)
    fast%near_radius = 3.0_dp
    if (.not. err%failed) call create_pfft_operator(ctx%comm, basis, centres, first, count, fast, pfft_matrix, err, .false.)
    call check(suite, .not. err%failed, 'terms: operators created')
    if (err%failed) return
    do m = 1, 6
      PetscCallA(MatCreateVecs(direct_matrix, q(m), c(m), ierr))
      PetscCallA(VecDuplicate(q(m), r(m), ierr))
      PetscCallA(VecDuplicate(q(m), exact_product(m), ierr))
      call fill_random(q(m), m)
      call fill_random(c(m), 10 + m)
      ! r = c - A~ q
      PetscCallA(MatMult(pfft_matrix, q(m), r(m), ierr))
      PetscCallA(VecAYPX(r(m), -1.0_dp, c(m), ierr))
      PetscCallA(MatMult(direct_matrix, q(m), exact_product(m), ierr))
    end do
    allocate (self(nb, nb))
    call self_block(basis, self)
    call sample_operator_error(ctx%comm, basis, self, centres, first, count, q, c, r, size(centres, 2), sample)
    call check(suite, sample%every_row .and. sample%rows == size(centres, 2), 'terms: every row drawn once')
    ! The same sums from the whole products: E q = A q - (c - r)
    factor = self
    call dpotrf('L', nb, factor, nb, info)
    allocate (local_e(nb, 6), solved(nb, 6))
    expected = 0.0_dp
    expected_second = 0.0_dp
    do i = 1, count
      do n = 1, 6
        PetscCallA(VecGetArrayReadF90(exact_product(n), ev, ierr))
        PetscCallA(VecGetArrayReadF90(c(n), av, ierr))
        local_e(:, n) = ev(nb * (i - 1) + 1:nb * i) - av(nb * (i - 1) + 1:nb * i)
        PetscCallA(VecRestoreArrayReadF90(c(n), av, ierr))
        PetscCallA(VecRestoreArrayReadF90(exact_product(n), ev, ierr))
        PetscCallA(VecGetArrayReadF90(r(n), av, ierr))
        local_e(:, n) = local_e(:, n) + av(nb * (i - 1) + 1:nb * i)
        PetscCallA(VecRestoreArrayReadF90(r(n), av, ierr))
      end do
      solved = local_e
      call dpotrs('L', nb, 6, factor, nb, solved, nb, info)
      expected_second = expected_second + matmul(transpose(local_e), solved)
      do m = 1, 6
        PetscCallA(VecGetArrayReadF90(q(m), qv, ierr))
        do n = 1, 6
          expected(m, n) = expected(m, n) - dot_product(qv(nb * (i - 1) + 1:nb * i), local_e(:, n))
        end do
        PetscCallA(VecRestoreArrayReadF90(q(m), qv, ierr))
      end do
    end do
    call MPI_Allreduce(MPI_IN_PLACE, expected, 36, MPI_DOUBLE_PRECISION, MPI_SUM, ctx%comm, ierr)
    call MPI_Allreduce(MPI_IN_PLACE, expected_second, 36, MPI_DOUBLE_PRECISION, MPI_SUM, ctx%comm, ierr)
    worst = maxval(abs(sum(sample%terms, dim=3) - expected)) / maxval(abs(expected))
    worst_second = maxval(abs(sum(sample%second, dim=3) - expected_second)) / maxval(abs(expected_second))
    call check(suite, worst <= 1.0e-10_dp .and. maxval(abs(expected)) > 0.0_dp, 'terms of all ' // &
               str(size(centres, 2)) // ' rows add up to -q . (A - A~) q, relative ' // str(worst))
    call check(suite, worst_second <= 1.0e-10_dp .and. maxval(abs(expected_second)) > 0.0_dp, 'second-order ' // &
               'terms add up to (E q) . S^-1 (E q), relative ' // str(worst_second))
    ! Item 4: every row sampled: no standard error, and the bound is the change and the allowance.
    friction = 0.0_dp
    mobility = 0.0_dp
    do m = 1, 6
      friction(m, m) = 2.0_dp
      mobility(m, m) = 0.5_dp
    end do
    bar = estimate_operator_error(sample%terms, sample%second, sample%probability, sample%every_row, &
                                  size(centres, 2, kind=i8), friction, mobility, &
                                  reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], &
                                          [3, 3]), 1.0_dp)
    call check(suite, maxval(bar%mobility_standard_error) == 0.0_dp, 'every row: no standard error')
    worst = maxval(abs(bar%friction_change - (expected + second_order_mid * expected_second))) / maxval(abs(expected))
    call check(suite, worst <= 1.0e-10_dp, 'every row: the change (first order and the second''s mid value) ' // &
               'exact, relative ' // str(worst))
    do m = 1, 6
      worst = abs(bar%mobility_error(m, m) - coverage * (abs(-0.25_dp * (expected(m, m) + second_order_mid * &
                                                                          expected_second(m, m))) &
                                                         + second_order_half * 0.25_dp * expected_second(m, m)))
      call check(suite, worst <= 1.0e-10_dp * bar%mobility_error(m, m), 'every row: the bound of diagonal entry ' // &
                 str(m) // ' = coverage (|change + mid second order| + the allowance)')
    end do
    do m = 1, 6
      PetscCallA(VecDestroy(q(m), ierr))
      PetscCallA(VecDestroy(c(m), ierr))
      PetscCallA(VecDestroy(r(m), ierr))
      PetscCallA(VecDestroy(exact_product(m), ierr))
    end do
    call destroy_pfft_operator(fast, pfft_matrix)
    call destroy_bead_operator(direct, direct_matrix)
  end subroutine check_terms

  function jittered(counts) result(beads)
    integer, intent(in) :: counts(3)
    real(dp), allocatable :: beads(:, :)
    integer :: i, a, b, e
    allocate (beads(3, product(counts)))
    i = 0
    do e = 0, counts(3) - 1
      do b = 0, counts(2) - 1
        do a = 0, counts(1) - 1
          i = i + 1
          beads(:, i) = 1.1_dp * [a, b, e] + 0.08_dp * ([hash_uniform(int(7 * i, i8)), hash_uniform(int(7 * i + 1, i8)), &
                                                          hash_uniform(int(7 * i + 2, i8))] - 0.5_dp)
        end do
      end do
    end do
  end function jittered
end program test_operator_error
