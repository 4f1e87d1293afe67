!> Tests src/operators/replicated_operator.F90: the operator built whole on every rank, a batch of
!> products dealt out to the ranks (vector j to rank mod(j - 1, P)), against the distributed
!> direct operator (bead_operator.F90, a different method: every pair block summed, no FFT) on the
!> same beads. Checked to 1e-12 relative (max-norm of the difference over that of the direct
!> product): a single product (MatMult: the batch of one, on rank 0), seven products at once
!> (4 and 3 vectors on 2 ranks, 3, 2 and 2 on 3: uneven shares), and the companion of order 1.
!> Bead sets: a random compact subset of a 7 x 6 x 5 box (no mirror plane: the whole-box FFT
!> product) and a 5 x 4 x 3 box (two mirror planes: the inner FFT operator's class products), both
!> with the FFT operator inside; the random set also with the direct operator inside; and the
!> random set stretched and jittered off the lattice, the pfft operator replicated against the
!> distributed pfft operator (the wrapper's claim: the same products).
!> CTest: np1 (the wrapper on one rank), np2 and np3.
program test_replicated_operator
#include "petsc/finclude/petscmat.h"
  use petscmat
  use beadmob_kinds, only: dp, i8
  use beadmob_testing
  use beadmob_random_vectors, only: fill_random, hash_uniform
  use beadmob_errors, only: error_t
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t, make_run_context, block_range
  use beadmob_multipole_basis, only: multipole_basis_t, make_multipole_basis
  use beadmob_multipole_operator, only: multipole_operator_t, operator_options_t
  use beadmob_operator_catalog, only: new_operator
  use beadmob_job_defaults, only: default_pfft_stencil, default_pfft_near_radius
  implicit none
  type(test_suite_t) :: suite
  type(run_context_t) :: ctx
  PetscErrorCode :: ierr
  real(dp), allocatable :: random_set(:, :), box(:, :), jittered(:, :)
  integer :: j

  PetscCallA(PetscInitialize(ierr))
  suite = start_tests('test_replicated_operator')
  ctx = make_run_context(PETSC_COMM_WORLD)

  random_set = lattice_beads([7, 6, 5], 0.6_dp)
  box = lattice_beads([5, 4, 3], 1.0_dp)
  call check(suite, size(random_set, 2) > 100 .and. size(random_set, 2) < 7 * 6 * 5, 'the random set is a proper subset')
  call compare(random_set, 'fft', 'random subset of a 7 x 6 x 5 box')
  call compare(box, 'fft', '5 x 4 x 3 box (by mirror class)')
  call compare(random_set, 'direct', 'random subset of a 7 x 6 x 5 box')
  ! Off the lattice: the replicated pfft operator against the distributed one (the wrapper's
  ! claim: the same products; the pfft operator's own accuracy is test_offlattice's).
  jittered = random_set
  jittered(1, :) = jittered(1, :) * 1.1_dp + 0.03_dp * [(hash_uniform(int(5000 + j, i8)) - 0.5_dp, j = 1, size(jittered, 2))]
  call compare(jittered, 'pfft', 'the random subset stretched and jittered', 'pfft')

  call finish_tests(suite)
  PetscCallA(PetscFinalize(ierr))

contains

  !> The sites of a box, each kept with probability `fraction` (a fixed hash: the same set on any
  !> number of ranks).
  function lattice_beads(sides, fraction) result(centres)
    integer, intent(in) :: sides(3)
    real(dp), intent(in) :: fraction
    real(dp), allocatable :: centres(:, :)
    real(dp) :: sites(3, product(sides))
    integer :: i, j, k, n
    n = 0
    do k = 0, sides(3) - 1
      do j = 0, sides(2) - 1
        do i = 0, sides(1) - 1
          if (hash_uniform(int(1 + i + sides(1) * (j + sides(2) * k), i8)) >= fraction) cycle
          n = n + 1
          sites(:, n) = real([i, j, k], dp)
        end do
      end do
    end do
    centres = sites(:, 1:n)
  end function lattice_beads

  !> The replicated `inner` operator against the distributed `reference` one (default direct) at
  !> L = 2, and their companions of order 1.
  subroutine compare(centres, inner, name, reference)
    real(dp), intent(in) :: centres(:, :)
    character(len=*), intent(in) :: inner, name
    character(len=*), intent(in), optional :: reference
    type(multipole_basis_t) :: basis, low
    class(multipole_operator_t), allocatable, target :: whole, direct, whole_low, direct_low
    type(operator_options_t) :: options
    type(error_t) :: err
    integer(i8) :: first, n_mine
    character(len=:), allocatable :: label
    integer :: a, b

    label = name // ', ' // inner // ' replicated'
    basis = make_multipole_basis(2, 0)
    low = make_multipole_basis(1, 0)
    allocate (options%companion_unknowns(low%size))
    do a = 1, low%size
      do b = 1, basis%size
        if (basis%degree(b) == low%degree(a) .and. basis%family(b) == low%family(a) .and. &
            basis%harmonic(b) == low%harmonic(a)) options%companion_unknowns(a) = b
      end do
    end do
    options%measure_plans = .false.
    options%cache_file = ''
    call block_range(ctx, size(centres, 2, kind=i8), first, n_mine)
    options%pfft_stencil = default_pfft_stencil
    options%pfft_near_radius = default_pfft_near_radius
    if (present(reference)) then
      call new_operator(reference, direct)
    else
      call new_operator('direct', direct)
    end if
    call new_operator(inner, whole, replicated=.true.)
    call direct%create(ctx%comm, basis, centres, first, n_mine, options, err)
    call whole%create(ctx%comm, basis, centres, first, n_mine, options, err)
    call check(suite, .not. err%failed, label // ': operators created')
    if (err%failed) return
    call check(suite, inner /= 'fft' .or. (whole%by_mirror_class .eqv. (size(centres, 2) == 60)), &
               label // ': class products exactly where the set has its mirror planes')
    call compare_products(direct, whole, label)
    call direct%create_companion(ctx%comm, options%companion_unknowns, direct_low, err)
    call whole%create_companion(ctx%comm, options%companion_unknowns, whole_low, err)
    call check(suite, .not. err%failed, label // ': companions created')
    if (err%failed) return
    call compare_products(direct_low, whole_low, label // ', companion of order 1')
    call whole_low%destroy()
    call direct_low%destroy()
    call whole%destroy()
    call direct%destroy()
  end subroutine compare

  !> One product and a batch of seven different vectors of `whole` against the products of `direct`.
  subroutine compare_products(direct, whole, label)
    class(multipole_operator_t), target, intent(inout) :: direct, whole
    character(len=*), intent(in) :: label
    Vec :: x(7), reference_y(7), y(7)
    real(dp) :: scale, difference, single, worst
    integer :: j
    do j = 1, 7
      PetscCallA(MatCreateVecs(direct%matrix, x(j), reference_y(j), ierr))
      PetscCallA(VecDuplicate(x(j), y(j), ierr))
      call fill_random(x(j), 10 + j)
      PetscCallA(MatMult(direct%matrix, x(j), reference_y(j), ierr))
    end do
    PetscCallA(VecNorm(reference_y(1), NORM_INFINITY, scale, ierr))
    PetscCallA(MatMult(whole%matrix, x(1), y(1), ierr))
    PetscCallA(VecAXPY(y(1), -1.0_dp, reference_y(1), ierr))
    PetscCallA(VecNorm(y(1), NORM_INFINITY, single, ierr))
    single = single / scale
    call check(suite, single <= 1.0e-12_dp, label // ': single product = direct, relative ' // str(single))
    call whole%apply_many(x, y)
    worst = 0.0_dp
    do j = 1, 7
      PetscCallA(VecAXPY(y(j), -1.0_dp, reference_y(j), ierr))
      PetscCallA(VecNorm(y(j), NORM_INFINITY, difference, ierr))
      worst = max(worst, difference / scale)
    end do
    call check(suite, worst <= 1.0e-12_dp, label // ': seven products at once = direct, relative ' // str(worst))
    if (suite%rank == 0) write (*, '(a)') label // ': relative differences ' // str(single) // ', ' // str(worst)
    do j = 1, 7
      PetscCallA(VecDestroy(x(j), ierr))
      PetscCallA(VecDestroy(reference_y(j), ierr))
      PetscCallA(VecDestroy(y(j), ierr))
    end do
  end subroutine compare_products
end program test_replicated_operator
