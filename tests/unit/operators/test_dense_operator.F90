!> Tests src/operators/dense_operator.F90, through the friction job (src/solvers/friction_job.F90).
!> CTest: test_dense_operator_np1 and test_dense_operator_np2 (the program keeps the test's name, test_dense_operator).
!> The dense operator (src/operators/dense_operator.F90, theory.md T17) against the Krylov path:
!> the same friction job with `dense` and with the direct operator solved by CG to a relative
!> tolerance of 1e-11 (an independent solve of the same Galerkin system: its blocks come from the
!> lattice table or the pair store, its solution from CG; the variational friction's solver error
!> is then ~1e-20). Bodies: a 3-bead chain at L = 6, a 2 x 2 x 2 lattice cube at L = 3 and four
!> jittered off-lattice beads at L = 4, each with the error bar's companion (order L - 1) too.
!> Checked: the order-L and the companion's friction agree within the runs' solver error bounds, the
!> dense solve's true residuals are below 1e-12, its converged reason positive. Run on 1 and 2
!> ranks (the dense matrix is split by bead rows), so the two rank counts agree through the
!> common reference.
program test_dense_operator
#include "petsc/finclude/petscsys.h"
  use petscsys
  use beadmob_kinds, only: dp
  use beadmob_testing
  use beadmob_errors, only: error_t
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t, make_run_context
  use beadmob_friction_job, only: friction_settings_t, friction_result_t, friction_of_model
  implicit none
  type(test_suite_t) :: suite
  type(run_context_t) :: ctx
  PetscErrorCode :: ierr
  real(dp) :: chain(3, 3), cube(3, 8), jittered(3, 4)
  integer :: i

  PetscCallA(PetscInitialize(ierr))
  suite = start_tests('test_dense_operator')
  ctx = make_run_context(PETSC_COMM_WORLD)
  chain = reshape([0, 0, 0, 1, 0, 0, 2, 0, 0], [3, 3]) * 1.0_dp
  do i = 1, 8
    cube(:, i) = [mod(i - 1, 2), mod((i - 1) / 2, 2), (i - 1) / 4] * 1.0_dp
  end do
  jittered = reshape([0.0_dp, 0.0_dp, 0.0_dp, 1.1_dp, 0.05_dp, 0.0_dp, 0.3_dp, 1.07_dp, 0.1_dp, 0.5_dp, 0.4_dp, 1.02_dp], &
                     [3, 4])
  call compare(chain, 6, '3-bead chain')
  call compare(cube, 3, '2 x 2 x 2 cube')
  call compare(jittered, 4, '4 jittered beads')
  call finish_tests(suite)
  PetscCallA(PetscFinalize(ierr))

contains

  subroutine compare(centres, order, name)
    real(dp), intent(in) :: centres(:, :)
    integer, intent(in) :: order
    character(len=*), intent(in) :: name
    type(friction_settings_t) :: settings
    type(friction_result_t) :: dense, krylov
    type(error_t) :: err
    real(dp) :: reference(3), difference, promise
    character(len=:), allocatable :: label
    label = name // ', L = ' // str(order)
    reference = sum(centres, dim=2) / size(centres, 2)
    settings%multipole_order = order
    settings%potential_order = max(order - 2, 0)
    settings%shell_layers = 0   ! the full model (the library, like the program, would pick a shell)
    settings%lubrication = .false.
    settings%error_estimate = .true.
    settings%krylov_rtol = 1.0e-11_dp
    settings%operator_name = 'dense'
    call friction_of_model(ctx, settings, centres, reference, dense, err)
    call check(suite, .not. err%failed, label // ': dense run')
    settings%operator_name = 'direct'
    call friction_of_model(ctx, settings, centres, reference, krylov, err)
    call check(suite, .not. err%failed, label // ': Krylov run')
    if (err%failed) return
    call check(suite, trim(dense%operator_name) == 'dense' .and. trim(krylov%operator_name) == 'direct', &
               label // ': the operators asked for')
    ! Each run within its stated solver error bound of the exact solve (theory.md T5), on the
    ! scale sqrt(zeta_mm zeta_nn) <= the largest entry: the two differ by at most the sum.
    promise = dense%solves%solver_error_bound + krylov%solves%solver_error_bound
    call check(suite, min(dense%solves%solver_error_bound, krylov%solves%solver_error_bound) > 0.0_dp, &
               label // ': both runs state a solver error bound')
    difference = maxval(abs(dense%multipole_friction - krylov%multipole_friction)) / maxval(abs(krylov%multipole_friction))
    call check(suite, difference <= promise, label // ': dense friction = Krylov friction, relative ' // &
               str(difference) // ' (promised ' // str(promise) // ')')
    promise = dense%companion_solves%solver_error_bound + krylov%companion_solves%solver_error_bound
    difference = maxval(abs(dense%companion_multipole_friction - krylov%companion_multipole_friction)) / &
                 maxval(abs(krylov%companion_multipole_friction))
    call check(suite, difference <= promise, label // ': companion (L - 1) friction, relative ' // str(difference) // &
               ' (promised ' // str(promise) // ')')
    call check(suite, maxval(dense%solves%true_relative_residual) <= 1.0e-12_dp, label // &
               ': dense true residuals ' // str(maxval(dense%solves%true_relative_residual)))
    call check(suite, all(dense%solves%converged_reason > 0), label // ': dense solves converged')
  end subroutine compare
end program test_dense_operator
