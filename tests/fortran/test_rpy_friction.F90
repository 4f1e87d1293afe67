!> Rigid-body friction through the distributed MATSHELL operator and the six KSP solves, with
!> the Rotne-Prager-Yamakawa blocks (multipole order L = 1, no lubrication).
!> References: one sphere, Stokes drag 6 pi eta a and rotational friction 8 pi eta a^3;
!> a touching doublet translating along its axis, closed form from the RPY blocks by hand:
!> each sphere moves with U = F [1/(6 pi eta a) + (1 - 2a^2/(3r^2))/(4 pi eta r)], r = 2a,
!> so zeta_axial = 2 F / U = 96 pi eta a / 13; and for three beads in general position, a dense
!> LAPACK solve of the same grand mobility (checks the distributed operator and Krylov solve),
!> and, as an independent method, the Galerkin multipole prototype at order L = 1
!> (docs/prototype/multipole_reference.py, friction_rigid(centres, 1): surface quadrature of
!> the single-layer operator, no RPY formula used), whose 6x6 values are listed below.
program test_rpy_friction
#include "petsc/finclude/petscksp.h"
  use petscksp
  use beadmob_kinds, only: dp, i8
  use beadmob_testing
  use beadmob_parallel, only: run_context_t, make_run_context, block_range
  use beadmob_rpy_blocks, only: rpy_self_block, rpy_pair_block, bead_radius
  use beadmob_bead_operator, only: bead_operator_t, create_bead_operator, destroy_bead_operator
  use beadmob_rigid_body_solve, only: rigid_body_friction, solve_statistics_t
  use beadmob_vector_algebra, only: cross
  implicit none
  type(test_suite_t) :: suite
  type(run_context_t) :: ctx
  PetscErrorCode :: ierr
  real(dp), parameter :: pi = acos(-1.0_dp)
  real(dp) :: friction(6, 6), expected(6, 6)
  integer :: k

  PetscCallA(PetscInitialize(ierr))
  suite = start_tests('test_rpy_friction')
  ctx = make_run_context(PETSC_COMM_WORLD)

  friction = friction_of(reshape([0.0_dp, 0.0_dp, 0.0_dp], [3, 1]))
  do k = 1, 3
    call check_close(suite, friction(k, k), 6.0_dp * pi * bead_radius, 1.0e-12_dp, 'one sphere: 6 pi eta a')
    call check_close(suite, friction(k + 3, k + 3), 8.0_dp * pi * bead_radius**3, 1.0e-12_dp, 'one sphere: 8 pi eta a^3')
  end do

  friction = friction_of(reshape([0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp], [3, 2]))
  call check_close(suite, friction(1, 1), 96.0_dp * pi * bead_radius / 13.0_dp, 1.0e-9_dp, 'doublet: axial friction')
  call check(suite, abs(friction(1, 5)) < 1.0e-10_dp, 'doublet about its centre: no translation-rotation coupling')

  block
    real(dp) :: three(3, 3)
    three = reshape([0.0_dp, 0.0_dp, 0.0_dp, 1.2_dp, 0.3_dp, -0.1_dp, 0.4_dp, 1.5_dp, 0.7_dp], [3, 3])
    friction = friction_of(three)
    expected = dense_friction(three, sum(three, dim=2) / 3)
    call check(suite, maxval(abs(friction - expected)) < 1.0e-8_dp * maxval(abs(expected)), &
               'three beads: distributed solve = dense LAPACK solve')
    call check(suite, maxval(abs(friction - transpose(friction))) < 1.0e-8_dp * maxval(abs(friction)), &
               'three beads: friction symmetric')
    expected = reshape([ &
      1.696904738971645e+01_dp, -1.353103076337475e-01_dp, 3.070157248508995e-01_dp, &
      -1.040850832706352e-01_dp, 5.758435935589636e-01_dp, -1.048212998540418e+00_dp, &
      -1.353103076337475e-01_dp, 1.687671605565818e+01_dp, -9.431063171485984e-01_dp, &
      -3.582072414507014e-01_dp, 8.994052574754650e-02_dp, -2.966763024620849e-01_dp, &
      3.070157248508995e-01_dp, -9.431063171485984e-01_dp, 1.817274881400806e+01_dp, &
      5.655135865562126e-01_dp, 1.175626084579140e-01_dp, 1.414455752308919e-02_dp, &
      -1.040850832706352e-01_dp, -3.582072414507022e-01_dp, 5.655135865562126e-01_dp, &
      2.591062988502276e+01_dp, 1.216360887772689e-01_dp, 1.322146135732948e+00_dp, &
      5.758435935589633e-01_dp, 8.994052574754649e-02_dp, 1.175626084579150e-01_dp, &
      1.216360887772693e-01_dp, 2.056406632581279e+01_dp, -5.902812884559735e+00_dp, &
      -1.048212998540416e+00_dp, -2.966763024620840e-01_dp, 1.414455752308922e-02_dp, &
      1.322146135732948e+00_dp, -5.902812884559734e+00_dp, 2.840804588837071e+01_dp], [6, 6])
    call check(suite, maxval(abs(friction - expected)) < 1.0e-8_dp * maxval(abs(expected)), &
               'three beads: equal to the Galerkin multipole prototype at L = 1')
  end block

  call finish_tests(suite)
  PetscCallA(PetscFinalize(ierr))

contains

  function friction_of(centres) result(friction)
    real(dp), intent(in) :: centres(:, :)
    real(dp) :: friction(6, 6)
    type(bead_operator_t), target :: op
    type(solve_statistics_t) :: stats
    Mat :: matrix
    integer(i8) :: first, count
    call block_range(ctx, size(centres, 2, kind=i8), first, count)
    call create_bead_operator(ctx%comm, centres, first, count, 6, rpy_self_block, rpy_pair_block, op, matrix)
    call rigid_body_friction(ctx%comm, matrix, centres, first, count, sum(centres, dim=2) / size(centres, 2), &
                             friction, stats)
    call check(suite, all(stats%converged_reason > 0), 'all six solves converged')
    call check(suite, all(stats%true_relative_residual < 1.0e-9_dp), 'true residuals below 1e-9')
    call destroy_bead_operator(op, matrix)
  end function friction_of

  !> zeta = K^T M^-1 K with the dense grand mobility M and the rigid-motion matrix K.
  function dense_friction(centres, reference) result(friction)
    real(dp), intent(in) :: centres(:, :), reference(3)
    real(dp) :: friction(6, 6)
    real(dp), allocatable :: mobility(:, :), rigid(:, :), forces(:, :)
    real(dp) :: block(6, 6), unit(3)
    integer, allocatable :: pivots(:)
    integer :: n, i, j, m, info
    n = size(centres, 2)
    allocate (mobility(6 * n, 6 * n), rigid(6 * n, 6), pivots(6 * n))
    do i = 1, n
      do j = 1, n
        if (i == j) then
          call rpy_self_block(block)
        else
          call rpy_pair_block(centres(:, i) - centres(:, j), block)
        end if
        mobility(6 * i - 5:6 * i, 6 * j - 5:6 * j) = block
      end do
      do m = 1, 6
        rigid(6 * i - 5:6 * i, m) = 0.0_dp
        if (m <= 3) then
          rigid(6 * i - 6 + m, m) = 1.0_dp
        else
          unit = merge(1.0_dp, 0.0_dp, [1, 2, 3] == m - 3)
          rigid(6 * i - 5:6 * i - 3, m) = cross(unit, centres(:, i) - reference)
          rigid(6 * i - 3 + m - 3, m) = 1.0_dp
        end if
      end do
    end do
    forces = rigid
    call dgesv(6 * n, 6, mobility, 6 * n, pivots, forces, 6 * n, info)
    friction = matmul(transpose(rigid), forces)
  end function dense_friction
end program test_rpy_friction
