!> Tests src/operators/fft_operator.F90 against src/operators/bead_operator.F90.
!> CTest: test_fft_operator_np1 and test_fft_operator_np2 (the program keeps the test's name, test_fft_operator).
!> The FFT lattice operator (src/operators/fft_operator.F90) against the direct operator
!> (bead_operator.F90) built from the same block table: for random x the two products agree to
!> 1e-12 relative (max-norm of the difference / max-norm of the direct product) on a small cone, a
!> box, a random compact subset of a 6 x 5 x 4 box (fixed seed; also in reversed bead order), a flat
!> plate, a line and one bead, at L = 1, 2, 3 with L2 = max(L - 2, 0), and at L = 2, L2 = 1 (odd
!> block size) on the random set. Exact up to rounding because the padded circular convolution
!> equals the linear one (n >= 2 span + 1 per axis). Also: off-lattice beads are refused with a
!> message, the FFT operator is symmetric (<u, A v> = <v, A u>), as CG needs, and seven products
!> at once (apply_many, batched) equal the single products to rounding, for the FFT and the
!> direct operator.
!> Mirror classes (theory.md T4): the symmetric sets (cone, box, plate, line, bead) run their
!> products by class; a general x is split into its four classes, and the test also checks the
!> whole-box products on the cone (use_mirrors off). For vectors of one class, made here from x
!> by the mirrors of the lattice (x_c = average over the bead set's mirror group of
!> chi_c(g) D_g x(g r), D_g from the direct operator's lattice symmetries), the operator takes the
!> one-class path (classes_of finds one class) and its product equals the direct one to 1e-12;
!> several classes batched at once equal their single products. The sets cover a centre on a
!> site and between two sites (3 and 2, 4 beads across) and a single plane (plate: one bead
!> across, where every odd field is zero), with the small axes' passes as matrix products (the
!> default) and as FFTW's r2r transforms.
program test_fft_operator
#include "petsc/finclude/petscmat.h"
  use petscmat
  use beadmob_kinds, only: dp, i8
  use beadmob_testing
  use beadmob_random_vectors, only: fill_random, hash_uniform
  use beadmob_batch_products, only: batch_difference
  use beadmob_errors, only: error_t
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t, make_run_context, block_range
  use beadmob_multipole_basis, only: multipole_basis_t, make_multipole_basis
  use beadmob_bead_operator, only: bead_operator_t, create_bead_operator, destroy_bead_operator
  use beadmob_fft_operator, only: fft_operator_t, create_fft_operator, destroy_fft_operator, fft_size
  use beadmob_mirror_classes, only: classes_of
  use beadmob_multipole_operator, only: multipole_operator_t
  implicit none
  type(test_suite_t) :: suite
  type(run_context_t) :: ctx
  PetscErrorCode :: ierr
  real(dp), allocatable :: cone(:, :), box(:, :), random_set(:, :), plate(:, :), line(:, :), ring(:, :)
  real(dp) :: one(3, 1)
  integer :: order

  PetscCallA(PetscInitialize(ierr))
  suite = start_tests('test_fft_operator')
  ctx = make_run_context(PETSC_COMM_WORLD)

  call check_equal(suite, fft_size(1), 1, 'fft_size(1)')
  call check_equal(suite, fft_size(11), 12, 'fft_size(11)')
  call check_equal(suite, fft_size(93), 96, 'fft_size(93)')
  ! The next power of two where it is at most 5 % above the smooth size: 128 <= 1.05 x 125,
  ! 256 <= 1.05 x 245, not 128 > 1.05 x 120 nor 256 > 1.05 x 243.
  call check_equal(suite, fft_size(121), 128, 'fft_size(121)')
  call check_equal(suite, fft_size(245), 256, 'fft_size(245)')
  call check_equal(suite, fft_size(117), 120, 'fft_size(117)')
  call check_equal(suite, fft_size(241), 243, 'fft_size(241)')

  ! Shifted off the origin, with a non-integer corner: only the lattice spacing matters.
  cone = small_cone()
  cone = cone + spread([10.25_dp, -3.5_dp, 7.0_dp], 2, size(cone, 2))
  box = box_beads([3, 2, 4])
  random_set = random_subset([6, 5, 4], 0.55_dp)
  plate = box_beads([5, 4, 1])
  line = box_beads([1, 1, 6])
  ring = open_ring()
  one = 0.0_dp
  call check(suite, size(cone, 2) > 20 .and. size(random_set, 2) > 30, 'test bead sets are not trivial')

  do order = 1, 3
    call compare(cone, order, max(order - 2, 0), 'small cone')
    call compare(box, order, max(order - 2, 0), '3 x 2 x 4 box')
    call compare(random_set, order, max(order - 2, 0), 'random subset of a 6 x 5 x 4 box')
  end do
  call compare(random_set, 2, 1, 'random subset of a 6 x 5 x 4 box (L2 = 1)')
  ! Bead order unrelated to the slabs: each rank's beads scatter to every slab.
  call compare(random_set(:, size(random_set, 2):1:-1), 2, 0, 'random subset, reversed order')
  call compare(plate, 2, 0, 'flat 5 x 4 plate')
  call compare(cone, 2, 0, 'small cone (whole box)', mirrors=.false.)
  call compare_classes(cone, 2, 'small cone', [.true., .true., .false.])
  call compare_classes(box, 2, '3 x 2 x 4 box', [.true., .true., .true.])
  call compare_classes(box, 1, '3 x 2 x 4 box', [.true., .true., .true.])
  call compare_classes(plate, 2, 'flat 5 x 4 plate', [.true., .true., .true.])
  ! Rows whose beads start off the mirror plane, rows without beads: the dense passes on the
  ! stretch between a row's first and last bead (mirror_transform.f90, mark_bead_sites).
  call compare_classes(ring, 2, 'open ring', [.true., .true., .false.])
  call compare_companion(cone, 'small cone', .true.)
  call compare_companion(cone, 'small cone (whole box)', .false.)
  call compare_companion(box, '3 x 2 x 4 box', .true.)
  ! FFTW's r2r passes instead of the matrix products of small axes.
  call compare_classes(cone, 2, 'small cone (r2r passes)', [.true., .true., .false.], dense_limit=0)
  call compare_classes(box, 2, '3 x 2 x 4 box (r2r passes)', [.true., .true., .true.], dense_limit=0)
  call compare_classes(plate, 2, 'flat 5 x 4 plate (r2r passes)', [.true., .true., .true.], dense_limit=0)
  ! The ring's fast axis (y: 4 slots) by matrix products on the stretches, its middle axis (x: 10
  ! slots) by r2r transforms, which read and write whole rows.
  call compare_classes(ring, 2, 'open ring (fast axis matrix products, middle r2r)', [.true., .true., .false.], &
                       dense_limit=5)
  call compare(line, 2, 0, 'line of 6 beads')
  call compare(one, 2, 0, 'one bead')

  call check_off_lattice_refused()

  call finish_tests(suite)
  PetscCallA(PetscFinalize(ierr))

contains

  !> FFT product == direct product for a random x, and <u, A_fft v> = <v, A_fft u>.
  subroutine compare(centres, order, potential_order, name, mirrors)
    real(dp), intent(in) :: centres(:, :)
    integer, intent(in) :: order, potential_order
    character(len=*), intent(in) :: name
    logical, intent(in), optional :: mirrors
    type(multipole_basis_t) :: basis
    type(bead_operator_t), target :: direct
    type(fft_operator_t), target :: fast
    type(error_t) :: err
    Mat :: direct_matrix, fft_matrix
    Vec :: x, u, y_direct, y_fft, au, du
    integer(i8) :: first, count
    real(dp) :: difference, reference, uav, vau, scale, worst
    character(len=:), allocatable :: label

    label = name // ', L = ' // str(order) // ', L2 = ' // str(potential_order) // ', ' // str(size(centres, 2)) // ' beads'
    basis = make_multipole_basis(order, potential_order)
    call block_range(ctx, size(centres, 2, kind=i8), first, count)
    call create_bead_operator(ctx%comm, basis, centres, first, count, direct, direct_matrix, err)
    call check(suite, .not. err%failed, label // ': direct operator created')
    if (present(mirrors)) fast%use_mirrors = mirrors
    call create_fft_operator(ctx%comm, basis, centres, first, count, fast, fft_matrix, err)
    call check(suite, .not. err%failed, label // ': FFT operator created')
    if (err%failed) then
      write (*, '(a)') err%message
      call destroy_bead_operator(direct, direct_matrix)
      return
    end if
    call check(suite, all(fast%self_block == direct%self_block), label // ': same self block')
    if (present(mirrors)) call check(suite, fast%mirrored .eqv. mirrors, label // ': mirror classes as asked')

    PetscCallA(MatCreateVecs(direct_matrix, x, y_direct, ierr))
    PetscCallA(VecDuplicate(x, u, ierr))
    PetscCallA(VecDuplicate(x, y_fft, ierr))
    PetscCallA(VecDuplicate(x, au, ierr))
    call fill_random(x, 1)
    call fill_random(u, 2)
    PetscCallA(MatMult(direct_matrix, x, y_direct, ierr))
    PetscCallA(MatMult(fft_matrix, x, y_fft, ierr))
    ! Twice: the operator's buffers must be fully reset between products.
    PetscCallA(MatMult(fft_matrix, x, y_fft, ierr))
    PetscCallA(VecNorm(y_direct, NORM_INFINITY, reference, ierr))
    PetscCallA(VecAXPY(y_fft, -1.0_dp, y_direct, ierr))
    PetscCallA(VecNorm(y_fft, NORM_INFINITY, difference, ierr))
    call check(suite, difference <= 1.0e-12_dp * reference, label // ': FFT product = direct product, relative ' // &
               'max-norm difference ' // str(difference / reference))
    if (suite%rank == 0) write (*, '(a)') label // ': relative difference ' // str(difference / reference)

    ! Symmetry: <u, A x> = <x, A u> (A x is y_direct's FFT twin; recompute it).
    PetscCallA(MatMult(fft_matrix, x, y_fft, ierr))
    PetscCallA(MatMult(fft_matrix, u, au, ierr))
    PetscCallA(VecDot(u, y_fft, uav, ierr))
    PetscCallA(VecDot(x, au, vau, ierr))
    PetscCallA(VecNorm(y_fft, NORM_2, scale, ierr))
    PetscCallA(VecNorm(u, NORM_2, reference, ierr))
    call check(suite, abs(uav - vau) <= 1.0e-12_dp * scale * reference, label // ': FFT operator symmetric')

    ! Seven products at once (more than one batch of max_copies): each the single product, to
    ! rounding (the same arithmetic per vector, the kernel streamed once per batch).
    worst = batch_difference(fast, x, u, y_fft, au, scale)
    call check(suite, worst <= 1.0e-13_dp, label // ': batched products = single products, relative ' // str(worst))
    ! The direct operator's batch likewise (each block read once for all vectors).
    PetscCallA(VecDuplicate(x, du, ierr))
    PetscCallA(MatMult(direct_matrix, u, du, ierr))
    worst = batch_difference(direct, x, u, y_direct, du, scale)
    call check(suite, worst <= 1.0e-13_dp, label // ': direct batched products = single products, relative ' // str(worst))

    PetscCallA(VecDestroy(x, ierr))
    PetscCallA(VecDestroy(u, ierr))
    PetscCallA(VecDestroy(du, ierr))
    PetscCallA(VecDestroy(y_direct, ierr))
    PetscCallA(VecDestroy(y_fft, ierr))
    PetscCallA(VecDestroy(au, ierr))
    call destroy_fft_operator(fast, fft_matrix)
    call destroy_bead_operator(direct, direct_matrix)
  end subroutine compare

  !> Products of vectors of one mirror class (and several classes batched) against the direct
  !> operator; `mirrors`: the lattice axes along which the set is its own mirror image.
  subroutine compare_classes(centres, order, name, mirrors, dense_limit)
    real(dp), intent(in) :: centres(:, :)
    integer, intent(in) :: order
    character(len=*), intent(in) :: name
    logical, intent(in) :: mirrors(3)
    integer, intent(in), optional :: dense_limit
    type(multipole_basis_t) :: basis
    type(bead_operator_t), target :: direct
    type(fft_operator_t), target :: fast
    type(error_t) :: err
    Mat :: direct_matrix, fft_matrix
    Vec :: x, whole, pure(4), y_direct, y_fft, batched(4)
    VecScatter :: to_all
    PetscScalar, pointer :: all_x(:), local(:)
    integer(i8) :: first, n_mine
    integer :: nb, n_beads, c, g, a, i, b, image, l(3), span(3), signs(3), classes(4), n, group, n_pure
    integer, allocatable :: lattice(:, :)
    real(dp) :: difference, reference, worst
    real(dp), allocatable :: factor(:)
    character(len=:), allocatable :: label
    logical :: one_class

    basis = make_multipole_basis(order, max(order - 2, 0))
    nb = basis%size
    allocate (factor(nb))
    n_beads = size(centres, 2)
    label = name // ' by class, L = ' // str(order)
    call block_range(ctx, int(n_beads, i8), first, n_mine)
    call create_bead_operator(ctx%comm, basis, centres, first, n_mine, direct, direct_matrix, err)
    if (present(dense_limit)) fast%dense_pass_limit = dense_limit
    call create_fft_operator(ctx%comm, basis, centres, first, n_mine, fast, fft_matrix, err)
    call check(suite, .not. err%failed .and. fast%mirrored, label // ': products by mirror class')
    if (err%failed) return
    allocate (lattice(3, n_beads))
    lattice = nint(centres - spread(minval(centres, dim=2), 2, n_beads))
    span = maxval(lattice, dim=2)
    PetscCallA(MatCreateVecs(direct_matrix, x, y_direct, ierr))
    PetscCallA(VecDuplicate(x, y_fft, ierr))
    call fill_random(x, 3)
    PetscCallA(VecScatterCreateToAll(x, to_all, whole, ierr))
    PetscCallA(VecScatterBegin(to_all, x, whole, INSERT_VALUES, SCATTER_FORWARD, ierr))
    PetscCallA(VecScatterEnd(to_all, x, whole, INSERT_VALUES, SCATTER_FORWARD, ierr))
    one_class = .true.
    worst = 0.0_dp
    n_pure = 0
    do c = 1, 4
      ! Class signs along the mirrored lattice axes (the others +1: a class of the larger group).
      signs = [merge(1, -1, mod(c - 1, 2) == 0), merge(1, -1, c <= 2), 1]
      if (.not. mirrors(3)) signs(3) = 1
      n_pure = n_pure + 1
      PetscCallA(VecDuplicate(x, pure(n_pure), ierr))
      PetscCallA(VecGetArrayReadF90(whole, all_x, ierr))
      PetscCallA(VecGetArrayF90(pure(n_pure), local, ierr))
      local = 0.0_dp
      do i = 1, int(n_mine)
        b = int(first) + i - 1
        ! The mirror group: every subset of the mirrored axes.
        do group = 0, 7
          if (any([(btest(group, a - 1) .and. .not. mirrors(a), a = 1, 3)])) cycle
          l = lattice(:, b)
          factor(1:nb) = 1.0_dp
          do a = 1, 3
            if (.not. btest(group, a - 1)) cycle
            l(a) = span(a) - l(a)
            factor(1:nb) = factor(1:nb) * signs(a) * [(direct%table%transforms(g, g, 1 + 2**(a - 1)), g = 1, nb)]
          end do
          image = 0
          do g = 1, n_beads
            if (all(lattice(:, g) == l)) image = g
          end do
          local((i - 1) * nb + 1:i * nb) = local((i - 1) * nb + 1:i * nb) + factor(1:nb) * &
                                                                            all_x((image - 1) * nb + 1:image * nb)
        end do
      end do
      local = local / 2**count(mirrors)
      PetscCallA(VecRestoreArrayF90(pure(n_pure), local, ierr))
      PetscCallA(VecRestoreArrayReadF90(whole, all_x, ierr))
      call classes_of(fast%classes, pure(n_pure), classes, n)
      one_class = one_class .and. n == 1
      PetscCallA(MatMult(direct_matrix, pure(n_pure), y_direct, ierr))
      PetscCallA(MatMult(fft_matrix, pure(n_pure), y_fft, ierr))
      PetscCallA(VecNorm(y_direct, NORM_INFINITY, reference, ierr))
      PetscCallA(VecAXPY(y_fft, -1.0_dp, y_direct, ierr))
      PetscCallA(VecNorm(y_fft, NORM_INFINITY, difference, ierr))
      worst = max(worst, difference / reference)
    end do
    call check(suite, one_class, label // ': a vector of one class is found to be in one class')
    call check(suite, worst <= 1.0e-12_dp, label // ': FFT product = direct product for each class, relative ' // &
               'max-norm difference ' // str(worst))
    if (suite%rank == 0) write (*, '(a)') label // ': relative difference ' // str(worst)
    ! All four classes at once, each its single product.
    do c = 1, 4
      PetscCallA(VecDuplicate(x, batched(c), ierr))
    end do
    call fast%apply_many(pure, batched)
    worst = 0.0_dp
    do c = 1, 4
      PetscCallA(MatMult(fft_matrix, pure(c), y_fft, ierr))
      PetscCallA(VecNorm(y_fft, NORM_INFINITY, reference, ierr))
      PetscCallA(VecAXPY(batched(c), -1.0_dp, y_fft, ierr))
      PetscCallA(VecNorm(batched(c), NORM_INFINITY, difference, ierr))
      worst = max(worst, difference / reference)
      PetscCallA(VecDestroy(batched(c), ierr))
      PetscCallA(VecDestroy(pure(c), ierr))
    end do
    call check(suite, worst <= 1.0e-13_dp, label // ': four classes batched = single products, relative ' // str(worst))
    PetscCallA(VecScatterDestroy(to_all, ierr))
    PetscCallA(VecDestroy(whole, ierr))
    PetscCallA(VecDestroy(x, ierr))
    PetscCallA(VecDestroy(y_direct, ierr))
    PetscCallA(VecDestroy(y_fft, ierr))
    call destroy_fft_operator(fast, fft_matrix)
    call destroy_bead_operator(direct, direct_matrix)
  end subroutine compare_classes

  !> The companion of order L - 1 (create_companion, sub-blocks of the kernel read in place)
  !> against the direct operator's companion, at L = 2, by class and on the whole box.
  subroutine compare_companion(centres, name, mirrors)
    real(dp), intent(in) :: centres(:, :)
    character(len=*), intent(in) :: name
    logical, intent(in) :: mirrors
    type(multipole_basis_t) :: basis, low
    type(bead_operator_t), target :: direct
    type(fft_operator_t), target :: fast
    class(multipole_operator_t), allocatable, target :: direct_low, fast_low
    type(error_t) :: err
    Mat :: direct_matrix, fft_matrix
    Vec :: x, y_direct, y_fft
    integer(i8) :: first, n_mine
    integer, allocatable :: unknowns(:)
    integer :: a, b
    real(dp) :: difference, reference
    character(len=:), allocatable :: label

    label = name // ', companion of order 1'
    basis = make_multipole_basis(2, 0)
    low = make_multipole_basis(1, 0)
    allocate (unknowns(low%size))
    do a = 1, low%size
      do b = 1, basis%size
        if (basis%degree(b) == low%degree(a) .and. basis%family(b) == low%family(a) .and. &
            basis%harmonic(b) == low%harmonic(a)) unknowns(a) = b
      end do
    end do
    call block_range(ctx, size(centres, 2, kind=i8), first, n_mine)
    call create_bead_operator(ctx%comm, basis, centres, first, n_mine, direct, direct_matrix, err)
    fast%use_mirrors = mirrors
    call create_fft_operator(ctx%comm, basis, centres, first, n_mine, fast, fft_matrix, err, keep_lattice=.true.)
    call check(suite, .not. err%failed .and. (fast%mirrored .eqv. mirrors), label // ': operators created')
    if (err%failed) return
    fast%matrix = fft_matrix
    direct%matrix = direct_matrix
    call direct%create_companion(ctx%comm, unknowns, direct_low, err)
    call fast%create_companion(ctx%comm, unknowns, fast_low, err)
    call check(suite, .not. err%failed, label // ': companions created')
    if (err%failed) return
    PetscCallA(MatCreateVecs(direct_low%matrix, x, y_direct, ierr))
    PetscCallA(VecDuplicate(x, y_fft, ierr))
    call fill_random(x, 5)
    PetscCallA(MatMult(direct_low%matrix, x, y_direct, ierr))
    PetscCallA(MatMult(fast_low%matrix, x, y_fft, ierr))
    PetscCallA(VecNorm(y_direct, NORM_INFINITY, reference, ierr))
    PetscCallA(VecAXPY(y_fft, -1.0_dp, y_direct, ierr))
    PetscCallA(VecNorm(y_fft, NORM_INFINITY, difference, ierr))
    call check(suite, difference <= 1.0e-12_dp * reference, label // ': FFT product = direct product, relative ' // &
               str(difference / reference))
    if (suite%rank == 0) write (*, '(a)') label // ': relative difference ' // str(difference / reference)
    PetscCallA(VecDestroy(x, ierr))
    PetscCallA(VecDestroy(y_direct, ierr))
    PetscCallA(VecDestroy(y_fft, ierr))
    call fast_low%destroy()
    call direct_low%destroy()
    call destroy_fft_operator(fast, fft_matrix)
    call destroy_bead_operator(direct, direct_matrix)
  end subroutine compare_companion

  subroutine check_off_lattice_refused()
    type(multipole_basis_t) :: basis
    type(fft_operator_t), target :: fast
    type(error_t) :: err
    Mat :: matrix
    real(dp) :: beads(3, 3)
    integer(i8) :: first, count
    beads = reshape([0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 1.3_dp, 0.0_dp], [3, 3])
    basis = make_multipole_basis(1, 0)
    call block_range(ctx, 3_i8, first, count)
    call create_fft_operator(ctx%comm, basis, beads, first, count, fast, matrix, err)
    call check(suite, err%failed, 'off-lattice beads refused')
    if (err%failed) call check(suite, index(err%message, 'bead 3') > 0 .and. index(err%message, 'lattice') > 0, &
                               'off-lattice message names the bead and the lattice: ' // err%message)
  end subroutine check_off_lattice_refused



  !> Lattice points of a cone: base radius 3 at z = 0, apex at z = 6.
  function small_cone() result(beads)
    real(dp), allocatable :: beads(:, :)
    integer :: x, y, z, n
    real(dp) :: buffer(3, 7 * 7 * 7)
    n = 0
    do z = 0, 6
      do y = -3, 3
        do x = -3, 3
          if (sqrt(real(x * x + y * y, dp)) <= 3.0_dp * (6 - z) / 6.0_dp + 1.0e-9_dp) then
            n = n + 1
            buffer(:, n) = [x, y, z]
          end if
        end do
      end do
    end do
    beads = buffer(:, 1:n)
  end function small_cone

  !> A ring in the x-z plane (2.4 <= |(x, z)| <= 4.5), three layers thick in y where
  !> |(x, z)| <= 3.5 and one elsewhere, open at the top (z >= 3, |x| <= 1): mirror symmetric in x
  !> and y only; its hole and thin rim leave rows with beads away from the mirror planes and rows
  !> with none.
  function open_ring() result(beads)
    real(dp), allocatable :: beads(:, :)
    integer :: x, y, z, n
    real(dp) :: buffer(3, 9 * 3 * 9), r
    n = 0
    do z = -4, 4
      do y = -1, 1
        do x = -4, 4
          r = sqrt(real(x * x + z * z, dp))
          if (r < 2.4_dp .or. r > 4.5_dp .or. (z >= 3 .and. abs(x) <= 1)) cycle
          if (y /= 0 .and. r > 3.5_dp) cycle
          n = n + 1
          buffer(:, n) = [x, y, z]
        end do
      end do
    end do
    beads = buffer(:, 1:n)
  end function open_ring

  function box_beads(counts) result(beads)
    integer, intent(in) :: counts(3)
    real(dp), allocatable :: beads(:, :)
    integer :: x, y, z, n
    allocate (beads(3, product(counts)))
    n = 0
    do z = 0, counts(3) - 1
      do y = 0, counts(2) - 1
        do x = 0, counts(1) - 1
          n = n + 1
          beads(:, n) = [x, y, z]
        end do
      end do
    end do
  end function box_beads

  !> Each site of the box kept with the given probability (fixed seed), the two opposite
  !> corners always, so the span is the whole box.
  function random_subset(counts, probability) result(beads)
    integer, intent(in) :: counts(3)
    real(dp), intent(in) :: probability
    real(dp), allocatable :: beads(:, :), sites(:, :)
    logical, allocatable :: keep(:)
    integer :: k
    allocate (sites, source=box_beads(counts))
    allocate (keep(size(sites, 2)))
    do k = 1, size(sites, 2)
      keep(k) = hash_uniform(int(k, i8) + 424242_i8) < probability
    end do
    keep(1) = .true.
    keep(size(sites, 2)) = .true.
    beads = sites(:, pack([(k, k=1, size(sites, 2))], keep))
  end function random_subset
end program test_fft_operator
