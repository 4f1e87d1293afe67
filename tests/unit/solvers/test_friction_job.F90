!> Tests src/solvers/friction_job.F90 (friction_of_model) and what it drives: the operators,
!> the block table, the rigid-body solve, lubrication, src/multipole/dense_friction.f90 and
!> src/hydro/mobility.f90.
!> CTest: test_multipole_friction_np1 and test_multipole_friction_np2 (the program keeps the test's name, test_multipole_friction).
!> The distributed multipole friction (operator, block table, six CG solves, lubrication) on small
!> bead sets, against independent references:
!>  - one sphere: Stokes 6 pi eta a and 8 pi eta a^3 at every order L (exact);
!>  - L = 1 without lubrication: the rigid-body friction K^T M^-1 K with M the Rotne-Prager-
!>    Yamakawa grand mobility in closed form (tests/unit/support/rpy_reference.f90), and the free-sphere
!>    friction = M^-1 (theory.md T7), two and three spheres in general position;
!>  - the distributed Krylov solve = a dense Cholesky solve of the same Galerkin system;
!>  - touching doublet with lubrication: axial drag per sphere = Stimson & Jeffery (1926) contact
!>    value 0.6451 (Happel & Brenner 1965, sec. 6.3);
!>  - symmetry and invariance: zeta symmetric, a cube isotropic without translation-rotation
!>    coupling, a 90-degree rotation permutes zeta, a z mirror flips mu42 and mu51, translation
!>    changes nothing (exact properties of Stokes flow);
!>  - centre of mobility: the coupling about it is symmetric, it moves with the body, and for a
!>    body with two mirror planes it lies on their intersection line (symmetry).
program test_multipole_friction
#include "petsc/finclude/petscksp.h"
  use petscksp
  use beadmob_kinds, only: dp
  use beadmob_testing
  use beadmob_errors, only: error_t
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t, make_run_context
  use beadmob_rpy_reference, only: rpy_self_block, rpy_pair_block, bead_radius
  use beadmob_friction_job, only: friction_settings_t, friction_result_t, friction_of_model
  use beadmob_multipole_basis, only: multipole_basis_t, make_multipole_basis
  use beadmob_dense_friction, only: dense_friction, rigid_motions
  use beadmob_mobility, only: mobility_result_t, compute_mobility
  implicit none
  type(test_suite_t) :: suite
  type(run_context_t) :: ctx
  PetscErrorCode :: ierr
  real(dp), parameter :: pi = acos(-1.0_dp)
  real(dp) :: friction(6, 6), expected(6, 6)
  real(dp) :: three(3, 3), pair(3, 2), one(3, 1)
  integer :: k, order

  PetscCallA(PetscInitialize(ierr))
  ! Tight Krylov tolerance: the comparisons below are at 1e-10.
  PetscCallA(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-ksp_rtol', '1e-13', ierr))
  suite = start_tests('test_multipole_friction')
  ctx = make_run_context(PETSC_COMM_WORLD)

  one = 0.0_dp
  do order = 1, 6
    friction = friction_of(one, order, .false.)
    do k = 1, 3
      call check_close(suite, friction(k, k), 6.0_dp * pi * bead_radius, 1.0e-12_dp, &
                       'one sphere, L = ' // str(order) // ': 6 pi eta a')
      call check_close(suite, friction(k + 3, k + 3), 8.0_dp * pi * bead_radius**3, 1.0e-12_dp, &
                       'one sphere, L = ' // str(order) // ': 8 pi eta a^3')
    end do
  end do

  three = reshape([0.0_dp, 0.0_dp, 0.0_dp, 1.2_dp, 0.3_dp, -0.1_dp, 0.4_dp, 1.5_dp, 0.7_dp], [3, 3])
  pair = reshape([0.0_dp, 0.0_dp, 0.0_dp, 0.9_dp, 1.3_dp, -0.4_dp], [3, 2])
  friction = friction_of(three, 1, .false.)
  expected = rpy_rigid_friction(three, sum(three, dim=2) / 3)
  call check(suite, max_relative(friction, expected) < 1.0e-10_dp, 'three spheres, L = 1: zeta = K^T M_RPY^-1 K')
  friction = friction_of(pair, 1, .false.)
  expected = rpy_rigid_friction(pair, sum(pair, dim=2) / 2)
  call check(suite, max_relative(friction, expected) < 1.0e-10_dp, 'two spheres, L = 1: zeta = K^T M_RPY^-1 K')
  call check_free_spheres_rpy(pair)
  call check_free_spheres_rpy(three)

  ! Distributed CG = dense Cholesky of the same system (L = 3, touching and separated beads).
  block
    real(dp) :: beads(3, 4)
    type(multipole_basis_t) :: basis
    type(error_t) :: err
    beads = reshape([0, 0, 0, 1, 0, 0, 1, 1, 0, 1, 1, 2], [3, 4]) * 1.0_dp
    friction = friction_of(beads, 3, .false.)
    basis = make_multipole_basis(3, 1)
    call dense_friction(basis, beads, rigid_motions(beads, sum(beads, dim=2) / 4), expected, err)
    call check(suite, .not. err%failed .and. max_relative(friction, expected) < 1.0e-10_dp, &
               'four beads, L = 3: distributed Krylov solve = dense Cholesky solve')
  end block

  ! Touching doublet along x with lubrication: axial drag per sphere / (6 pi eta a).
  pair = reshape([0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp], [3, 2])
  friction = friction_of(pair, 2, .true.)
  call check(suite, abs(friction(1, 1) / (2 * 6 * pi * bead_radius) - 0.6451_dp) < 1.0e-3_dp, &
             'touching doublet, L = 2 with lubrication: Stimson-Jeffery 0.6451 to 1e-3')
  friction = friction_of(pair, 4, .true.)
  call check(suite, abs(friction(1, 1) / (2 * 6 * pi * bead_radius) - 0.6451_dp) < 1.0e-4_dp, &
             'touching doublet, L = 4 with lubrication: Stimson-Jeffery 0.6451 to 1e-4')
  friction = friction_of(pair, 4, .false.)
  call check(suite, abs(friction(1, 1) / (2 * 6 * pi * bead_radius) - 0.6451_dp) < 1.0e-3_dp, &
             'touching doublet, L = 4 without lubrication: within 1e-3 of Stimson-Jeffery')

  call check_symmetries()
  call check_centre_of_mobility()

  call finish_tests(suite)
  PetscCallA(PetscFinalize(ierr))

contains

  function friction_of(centres, order, lubrication) result(friction)
    real(dp), intent(in) :: centres(:, :)
    integer, intent(in) :: order
    logical, intent(in) :: lubrication
    real(dp) :: friction(6, 6)
    type(friction_settings_t) :: settings
    type(friction_result_t) :: result
    type(error_t) :: err
    settings%multipole_order = order
    settings%potential_order = max(order - 2, 0)
    settings%shell_layers = 0   ! the full model (the library, like the program, would pick a shell)
    settings%lubrication = lubrication
    call friction_of_model(ctx, settings, centres, sum(centres, dim=2) / size(centres, 2), result, err)
    call check(suite, .not. err%failed, 'friction computed')
    call check(suite, all(result%solves%converged_reason > 0), 'all six solves converged')
    call check(suite, all(result%solves%true_relative_residual < 1.0e-11_dp), 'true residuals below 1e-11')
    friction = result%friction
    call check(suite, max_relative(friction, transpose(friction)) < 1.0e-11_dp, 'friction symmetric')
  end function friction_of

  pure real(dp) function max_relative(actual, reference)
    real(dp), intent(in) :: actual(:, :), reference(:, :)
    max_relative = maxval(abs(actual - reference)) / maxval(abs(reference))
  end function max_relative

  function rpy_grand_mobility(centres) result(mobility)
    real(dp), intent(in) :: centres(:, :)
    real(dp) :: mobility(6 * size(centres, 2), 6 * size(centres, 2)), block(6, 6)
    integer :: i, j
    do i = 1, size(centres, 2)
      do j = 1, size(centres, 2)
        if (i == j) then
          call rpy_self_block(block)
        else
          call rpy_pair_block(centres(:, i) - centres(:, j), block)
        end if
        mobility(6 * i - 5:6 * i, 6 * j - 5:6 * j) = block
      end do
    end do
  end function rpy_grand_mobility

  !> K^T M^-1 K by a dense LU solve.
  function rpy_rigid_friction(centres, reference) result(friction)
    real(dp), intent(in) :: centres(:, :), reference(3)
    real(dp) :: friction(6, 6)
    real(dp), allocatable :: mobility(:, :), motions(:, :), forces(:, :)
    integer, allocatable :: pivots(:)
    integer :: n, info
    n = 6 * size(centres, 2)
    mobility = rpy_grand_mobility(centres)
    motions = rigid_motions(centres, reference)
    forces = motions
    allocate (pivots(n))
    call dgesv(n, 6, mobility, n, pivots, forces, n, info)
    friction = matmul(transpose(motions), forces)
  end function rpy_rigid_friction

  !> Free spheres at L = 1: the 6N x 6N friction is the inverse RPY grand mobility.
  subroutine check_free_spheres_rpy(centres)
    real(dp), intent(in) :: centres(:, :)
    real(dp), allocatable :: free(:, :), identity(:, :), product(:, :)
    type(multipole_basis_t) :: basis
    type(error_t) :: err
    integer :: n, i
    n = 6 * size(centres, 2)
    allocate (identity(n, n), free(n, n))
    identity = 0.0_dp
    do i = 1, n
      identity(i, i) = 1.0_dp
    end do
    basis = make_multipole_basis(1, 0)
    call dense_friction(basis, centres, identity, free, err)
    product = matmul(free, rpy_grand_mobility(centres))
    call check(suite, maxval(abs(product - identity)) < 1.0e-10_dp, &
               str(size(centres, 2)) // ' free spheres, L = 1: zeta M_RPY = identity to 1e-10')
  end subroutine check_free_spheres_rpy

  subroutine check_symmetries()
    real(dp) :: cube(3, 27), shape(3, 6), moved(3, 6), turned(6, 6), rotation(6, 6), mobility(6, 6), mirror(6, 6)
    integer :: i, j, k, n
    n = 0
    do k = 0, 2
      do j = 0, 2
        do i = 0, 2
          n = n + 1
          cube(:, n) = [i, j, k]
        end do
      end do
    end do
    mobility = inverse6(friction_of(cube, 2, .true.))
    call check(suite, abs(mobility(1, 1) - mobility(2, 2)) < 1.0e-10_dp * mobility(1, 1) .and. &
               abs(mobility(1, 1) - mobility(3, 3)) < 1.0e-10_dp * mobility(1, 1), 'cube: isotropic mu_tt')
    call check(suite, maxval(abs(mobility(4:6, 1:3))) < 1.0e-10_dp * mobility(1, 1), 'cube: mu_rt = 0')

    ! An asymmetric body: no mirror plane, all couplings present.
    shape = reshape([0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1], [3, 6]) * 1.0_dp
    turned = friction_of(shape, 2, .true.)
    ! 90 degrees about z: (x, y, z) -> (-y, x, z) for vectors and pseudo-vectors alike.
    rotation = 0.0_dp
    do k = 0, 1
      rotation(3 * k + 1, 3 * k + 2) = -1.0_dp
      rotation(3 * k + 2, 3 * k + 1) = 1.0_dp
      rotation(3 * k + 3, 3 * k + 3) = 1.0_dp
    end do
    moved = matmul(rotation(1:3, 1:3), shape)
    call check(suite, max_relative(friction_of(moved, 2, .true.), matmul(rotation, matmul(turned, transpose(rotation)))) &
               < 1.0e-10_dp, 'rotating the body by 90 degrees rotates zeta')
    ! z mirror: velocities flip z, angular velocities (pseudo-vectors) flip x and y.
    moved = shape
    moved(3, :) = -moved(3, :)
    mirror = 0.0_dp
    do k = 1, 6
      mirror(k, k) = merge(-1.0_dp, 1.0_dp, k == 3 .or. k == 4 .or. k == 5)
    end do
    mobility = inverse6(friction_of(moved, 2, .true.))
    turned = inverse6(turned)
    call check(suite, max_relative(mobility, matmul(mirror, matmul(turned, mirror))) < 1.0e-10_dp, &
               'mirroring z transforms the mobility as a reflection')
    call check(suite, abs(mobility(4, 2) + turned(4, 2)) < 1.0e-10_dp * abs(turned(4, 2)) .and. &
               abs(mobility(5, 1) + turned(5, 1)) < 1.0e-10_dp * abs(turned(5, 1)), 'mirroring z flips mu42 and mu51')
    moved = shape + spread([100.0_dp, -50.0_dp, 7.0_dp], 2, 6)
    call check(suite, max_relative(friction_of(moved, 2, .true.), inverse6(turned)) < 1.0e-10_dp, &
               'translating the body changes nothing (about the centre of mass)')
  end subroutine check_symmetries

  subroutine check_centre_of_mobility()
    real(dp) :: shape(3, 6), pyramid(3, 6), identity(3, 3), coupling(3, 3), moved(3, 6), shift(3)
    type(mobility_result_t) :: result, result_moved
    type(error_t) :: err
    integer :: k
    identity = 0.0_dp
    do k = 1, 3
      identity(k, k) = 1.0_dp
    end do
    shape = reshape([0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1], [3, 6]) * 1.0_dp
    call compute_mobility(friction_of(shape, 2, .false.), sum(shape, dim=2) / 6, identity, 1.0_dp, result, err)
    coupling = result%mobility_at_centre(4:6, 1:3)
    call check(suite, .not. err%failed .and. maxval(abs(coupling - transpose(coupling))) < 1.0e-12_dp * &
               maxval(abs(result%mobility)), 'coupling symmetric about the centre of mobility')
    shift = [3.0_dp, -2.0_dp, 5.0_dp]
    moved = shape + spread(shift, 2, 6)
    call compute_mobility(friction_of(moved, 2, .false.), sum(moved, dim=2) / 6, identity, 1.0_dp, result_moved, err)
    call check(suite, maxval(abs(result_moved%centre_of_mobility - result%centre_of_mobility - shift)) < 1.0e-9_dp, &
               'the centre of mobility moves with the body')
    ! Mirror planes x = 0 and y = 0: a plus-shaped layer of five beads with one bead on top.
    pyramid = reshape([-1, 0, 0, 1, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1], [3, 6]) * 1.0_dp
    call compute_mobility(friction_of(pyramid, 2, .false.), sum(pyramid, dim=2) / 6, identity, 1.0_dp, result, err)
    call check(suite, maxval(abs(result%centre_of_mobility(1:2))) < 1.0e-10_dp, &
               'two mirror planes: the centre of mobility lies on their common axis')
  end subroutine check_centre_of_mobility

  function inverse6(matrix) result(inverse)
    real(dp), intent(in) :: matrix(6, 6)
    real(dp) :: inverse(6, 6), work(6, 6)
    integer :: pivots(6), info, k
    work = matrix
    inverse = 0.0_dp
    do k = 1, 6
      inverse(k, k) = 1.0_dp
    end do
    call dgesv(6, 6, work, 6, pivots, inverse, 6, info)
  end function inverse6
end program test_multipole_friction
