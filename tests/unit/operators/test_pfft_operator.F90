!> Tests src/operators/pfft_operator.F90; also src/multipole/axial_table.f90 and
!> src/multipole/harmonic_rotation.f90 (items 1 and 2 below), and the friction job off the lattice.
!> CTest: test_offlattice_np1 and test_offlattice_np2 (the program keeps the test's name, test_offlattice).
!> Off-lattice bead models (theory.md T15, T16):
!>  1. Pair blocks from the axial table turned to the pair (axial_table.f90) equal the direct
!>     quadrature of the Galerkin integral (pair_blocks.f90, an independent evaluation) at random
!>     distances and directions to 1e-12 of the block's largest entry, L = 1 .. 5 (measured 2e-15).
!>  2. The rotations O^n of the real harmonics are orthogonal and compose: O(Q1 Q2) = O(Q1) O(Q2).
!>  3. The precorrected-FFT operator (pfft_operator.F90): on lattice beads its interpolation is
!>     exact and its product equals the direct operator's to 1e-12; on jittered beads, at the
!>     default stencil (4 points) and near radius (3 d), it equals the direct product to 3e-2 of
!>     the product's max-norm for a random x (measured 7.6e-3 on 80 beads; a random x is all
!>     high multipoles, which interpolate worst; the friction is far closer, item 4) and is symmetric;
!>     seven products at once (apply_many) equal the single products to rounding (1e-13).
!>  4. A lattice body turned by a rotation that is no lattice symmetry: the friction of the turned
!>     beads (pfft operator) is R zeta R^T of the lattice run (FFT operator), R = diag(Q, Q), the
!>     Galerkin method being exactly covariant; the pfft far field leaves 4.9e-4 on this small
!>     slender body (2 x 2 x 8 and a foot; measured), checked to 1e-3 (2000-bead models: 2e-4 at
!>     most, bench/offlattice/offlattice.md).
program test_offlattice
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
  use beadmob_pair_blocks, only: pair_block
  use beadmob_axial_table, only: axial_table_t, make_axial_table, rotated_block
  use beadmob_harmonic_rotation, only: rotation_rule_t, make_rotation_rule, degree_rotations, rotation_to_direction, &
                                       direction_rotations
  use beadmob_bead_operator, only: bead_operator_t, create_bead_operator, destroy_bead_operator
  use beadmob_pfft_operator, only: pfft_operator_t, create_pfft_operator, destroy_pfft_operator
  use beadmob_friction_job, only: friction_settings_t, friction_result_t, friction_of_model
  implicit none
  type(test_suite_t) :: suite
  type(run_context_t) :: ctx
  PetscErrorCode :: ierr
  integer :: order

  PetscCallA(PetscInitialize(ierr))
  suite = start_tests('test_offlattice')
  ctx = make_run_context(PETSC_COMM_WORLD)

  do order = 1, 5
    call check_axial_blocks(order)
  end do
  call check_rotations(5)
  call compare_products(lattice_box([5, 4, 3]), 2, 1.0e-12_dp, 'lattice box 5 x 4 x 3')
  ! L = 3 brings the sigma = 2 family (degree 1): the correction's lower triangles follow from the
  ! inversion parities of all three families (C = 0 to rounding on the lattice only if they are right)
  call compare_products(lattice_box([4, 3, 3]), 3, 1.0e-12_dp, 'lattice box 4 x 3 x 3')
  call compare_products(jittered([5, 4, 4]), 2, 3.0e-2_dp, 'jittered 5 x 4 x 4 cluster')
  call check_turned_body()

  call finish_tests(suite)
  PetscCallA(PetscFinalize(ierr))

contains

  subroutine check_axial_blocks(order)
    integer, intent(in) :: order
    type(multipole_basis_t) :: basis
    type(axial_table_t) :: table
    real(dp), allocatable :: quadrature(:, :), turned(:, :)
    real(dp) :: d(3), worst
    integer :: k
    basis = make_multipole_basis(order, max(order - 2, 0))
    call make_axial_table(basis, table)
    allocate (quadrature(basis%size, basis%size), turned(basis%size, basis%size))
    worst = 0.0_dp
    do k = 1, 8
      ! a direction and a distance in [1, 13) d from a fixed sequence; k = 1: touching on the x axis
      d = [hash_uniform(int(3 * k, i8)), hash_uniform(int(3 * k + 1, i8)), hash_uniform(int(3 * k + 2, i8))] - 0.5_dp
      d = d / norm2(d) * (1.0_dp + 12.0_dp * hash_uniform(int(100 + k, i8))**2)
      if (k == 1) d = [1.0_dp, 0.0_dp, 0.0_dp]
      call pair_block(basis, d, quadrature)
      call rotated_block(table, d, turned)
      worst = max(worst, maxval(abs(turned - quadrature)) / maxval(abs(quadrature)))
    end do
    call check(suite, worst <= 1.0e-12_dp, 'L = ' // str(order) // ': axial table turned to the pair = quadrature, ' // &
               'worst relative difference ' // str(worst))
    if (suite%rank == 0) write (*, '(a)') 'L = ' // str(order) // ': axial table against quadrature ' // str(worst)
  end subroutine check_axial_blocks

  subroutine check_rotations(order)
    integer, intent(in) :: order
    type(rotation_rule_t) :: rule
    real(dp) :: q1(3, 3), q2(3, 3), o1(2 * order + 1, 2 * order + 1, order), o2(2 * order + 1, 2 * order + 1, order), &
                o12(2 * order + 1, 2 * order + 1, order), worst_orthogonal, worst_product, identity(2 * order + 1, 2 * order + 1)
    integer :: n, m, k
    real(dp), parameter :: directions(3, 9) = reshape([1.0_dp, 2.0_dp, 3.0_dp, -0.3_dp, 0.1_dp, -1.0_dp, &
      0.0_dp, 0.0_dp, 2.0_dp, 0.0_dp, 0.0_dp, -1.5_dp, 1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, -1.0_dp, 0.0_dp, &
      -2.0_dp, -1.0_dp, 0.5_dp, 1.0e-9_dp, 0.0_dp, 1.0_dp, 3.0_dp, -4.0_dp, -0.25_dp], [3, 9])
    rule = make_rotation_rule(order)
    q1 = rotation_to_direction([1.0_dp, 2.0_dp, 3.0_dp])
    q2 = rotation_to_direction([-0.3_dp, 0.1_dp, -1.0_dp])
    call degree_rotations(rule, q1, o1)
    call degree_rotations(rule, q2, o2)
    call degree_rotations(rule, matmul(q1, q2), o12)
    worst_orthogonal = 0.0_dp
    worst_product = 0.0_dp
    do n = 1, order
      m = 2 * n + 1
      identity = 0.0_dp
      do k = 1, m
        identity(k, k) = 1.0_dp
      end do
      worst_orthogonal = max(worst_orthogonal, maxval(abs(matmul(o1(1:m, 1:m, n), transpose(o1(1:m, 1:m, n))) - &
                                                          identity(1:m, 1:m))))
      ! T_{Q1 Q2} = T_Q1 T_Q2
      worst_product = max(worst_product, maxval(abs(o12(1:m, 1:m, n) - matmul(o1(1:m, 1:m, n), o2(1:m, 1:m, n)))))
    end do
    call check(suite, worst_orthogonal <= 1.0e-13_dp, 'harmonic rotations orthogonal to ' // str(worst_orthogonal))
    call check(suite, worst_product <= 1.0e-13_dp, 'harmonic rotations compose, to ' // str(worst_product))
    ! The factorised rotation to a direction (R_z(phi) R_y(theta), closed-form R_z factors) against
    ! the harmonics' quadrature of the same rotation: general directions, both poles, the axes.
    call check(suite, rule%factorised, 'the rotations about z have the cos/sin pair form')
    worst_product = 0.0_dp
    do k = 1, size(directions, 2)
      call degree_rotations(rule, rotation_to_direction(directions(:, k)), o1)
      call direction_rotations(rule, directions(:, k), o2)
      worst_product = max(worst_product, maxval(abs(o1 - o2)))
    end do
    call check(suite, worst_product <= 1.0e-13_dp, 'factorised rotations to a direction = quadrature, to ' // &
               str(worst_product))
  end subroutine check_rotations

  !> pfft product against the direct product for a random x, and <u, A v> = <v, A u>.
  subroutine compare_products(centres, order, tolerance, name)
    real(dp), intent(in) :: centres(:, :), tolerance
    integer, intent(in) :: order
    character(len=*), intent(in) :: name
    type(multipole_basis_t) :: basis
    type(bead_operator_t), target :: direct
    type(pfft_operator_t), target :: fast
    type(error_t) :: err
    Mat :: direct_matrix, pfft_matrix
    Vec :: x, u, y_direct, y_fast, au
    integer(i8) :: first, count
    real(dp) :: difference, reference, uav, vau, scale, worst
    character(len=:), allocatable :: label
    label = name // ', ' // str(size(centres, 2)) // ' beads, L = ' // str(order)
    basis = make_multipole_basis(order, order - 2)
    call block_range(ctx, size(centres, 2, kind=i8), first, count)
    call create_bead_operator(ctx%comm, basis, centres, first, count, direct, direct_matrix, err)
    if (.not. err%failed) call create_pfft_operator(ctx%comm, basis, centres, first, count, fast, pfft_matrix, err, .false.)
    call check(suite, .not. err%failed, label // ': operators created')
    if (err%failed) return
    PetscCallA(MatCreateVecs(direct_matrix, x, y_direct, ierr))
    PetscCallA(VecDuplicate(x, u, ierr))
    PetscCallA(VecDuplicate(x, y_fast, ierr))
    PetscCallA(VecDuplicate(x, au, ierr))
    call fill_random(x, 1)
    call fill_random(u, 2)
    PetscCallA(MatMult(direct_matrix, x, y_direct, ierr))
    PetscCallA(MatMult(pfft_matrix, x, y_fast, ierr))
    PetscCallA(VecNorm(y_direct, NORM_INFINITY, reference, ierr))
    PetscCallA(VecAXPY(y_fast, -1.0_dp, y_direct, ierr))
    PetscCallA(VecNorm(y_fast, NORM_INFINITY, difference, ierr))
    call check(suite, difference <= tolerance * reference, label // ': pfft product = direct product, relative ' // &
               'max-norm difference ' // str(difference / reference) // ' (tolerance ' // str(tolerance) // ')')
    if (suite%rank == 0) write (*, '(a)') label // ': pfft product against direct, relative ' // str(difference / reference)
    PetscCallA(MatMult(pfft_matrix, x, y_fast, ierr))
    PetscCallA(MatMult(pfft_matrix, u, au, ierr))
    PetscCallA(VecDot(u, y_fast, uav, ierr))
    PetscCallA(VecDot(x, au, vau, ierr))
    PetscCallA(VecNorm(y_fast, NORM_2, scale, ierr))
    PetscCallA(VecNorm(u, NORM_2, reference, ierr))
    call check(suite, abs(uav - vau) <= 1.0e-12_dp * scale * reference, label // ': pfft operator symmetric')
    ! Seven products at once (apply_many: the grid's batches and one pass over C for all), each the
    ! single product to rounding.
    worst = batch_difference(fast, x, u, y_fast, au, scale)
    call check(suite, worst <= 1.0e-13_dp, label // ': batched products = single products, relative ' // str(worst))
    PetscCallA(VecDestroy(x, ierr))
    PetscCallA(VecDestroy(u, ierr))
    PetscCallA(VecDestroy(y_direct, ierr))
    PetscCallA(VecDestroy(y_fast, ierr))
    PetscCallA(VecDestroy(au, ierr))
    call destroy_pfft_operator(fast, pfft_matrix)
    call destroy_bead_operator(direct, direct_matrix)
  end subroutine compare_products

  !> A 2 x 2 x 8 rod with a foot (no symmetry but the identity after the turn), on the lattice
  !> with the FFT operator and turned by Q (30 degrees about (1, 2, 3)) with the pfft operator.
  subroutine check_turned_body()
    real(dp), allocatable :: body(:, :), turned(:, :)
    real(dp) :: q(3, 3), r(6, 6), axis(3), angle, centre(3), expected(6, 6), difference
    type(friction_settings_t) :: settings
    type(friction_result_t) :: lattice_result, turned_result
    type(error_t) :: err
    integer :: i
    body = lattice_box([2, 2, 8])
    body = reshape([body, 2.0_dp, 0.0_dp, 0.0_dp, 3.0_dp, 0.0_dp, 0.0_dp], [3, size(body, 2) + 2])
    axis = [1.0_dp, 2.0_dp, 3.0_dp] / sqrt(14.0_dp)
    angle = acos(-1.0_dp) / 6.0_dp
    ! Rodrigues: Q = cos I + sin [axis]x + (1 - cos) axis axis^T
    q = (1.0_dp - cos(angle)) * spread(axis, 2, 3) * spread(axis, 1, 3)
    do i = 1, 3
      q(i, i) = q(i, i) + cos(angle)
    end do
    q(1, 2) = q(1, 2) - sin(angle) * axis(3); q(2, 1) = q(2, 1) + sin(angle) * axis(3)
    q(1, 3) = q(1, 3) + sin(angle) * axis(2); q(3, 1) = q(3, 1) - sin(angle) * axis(2)
    q(2, 3) = q(2, 3) - sin(angle) * axis(1); q(3, 2) = q(3, 2) + sin(angle) * axis(1)
    centre = sum(body, dim=2) / size(body, 2)
    turned = matmul(q, body - spread(centre, 2, size(body, 2)))
    settings%lubrication = .false.
    settings%shell_layers = 0   ! the full model on the lattice, as off it
    settings%krylov_rtol = 1.0e-6_dp   ! the variational friction's solver error ~1e-12 (theory.md T5)
    settings%use_symmetry = .false.
    settings%operator_name = 'fft'
    call friction_of_model(ctx, settings, body, centre, lattice_result, err)
    call check(suite, .not. err%failed, 'turned body: lattice run')
    settings%operator_name = 'pfft'
    ! the default near radius kept: the tolerance 1e-6 would raise it until every pair is exact
    ! (theory.md T16, "The accuracy a job asks for"), and the far field is what this checks
    settings%pfft_near_radius_given = .true.
    call friction_of_model(ctx, settings, turned, [0.0_dp, 0.0_dp, 0.0_dp], turned_result, err)
    call check(suite, .not. err%failed, 'turned body: pfft run')
    if (err%failed) return
    r = 0.0_dp
    r(1:3, 1:3) = q
    r(4:6, 4:6) = q
    expected = matmul(r, matmul(lattice_result%multipole_friction, transpose(r)))
    difference = maxval(abs(turned_result%multipole_friction - expected)) / maxval(abs(expected))
    if (suite%rank == 0) write (*, '(a)') 'turned body: relative difference ' // str(difference)
    call check(suite, difference <= 1.0e-3_dp, 'turned ' // str(size(body, 2)) // '-bead body: pfft friction = ' // &
               'R zeta R^T of the lattice run, relative difference ' // str(difference))
  end subroutine check_turned_body

  function lattice_box(counts) result(beads)
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
  end function lattice_box

  !> The box at spacing 1.1 d with shifts of up to 0.04 d per coordinate (no two beads closer than 1.02 d).
  function jittered(counts) result(beads)
    integer, intent(in) :: counts(3)
    real(dp), allocatable :: beads(:, :)
    integer :: i
    beads = 1.1_dp * lattice_box(counts)
    do i = 1, size(beads, 2)
      beads(:, i) = beads(:, i) + 0.08_dp * ([hash_uniform(int(7 * i, i8)), hash_uniform(int(7 * i + 1, i8)), &
                                              hash_uniform(int(7 * i + 2, i8))] - 0.5_dp)
    end do
  end function jittered


end program test_offlattice
