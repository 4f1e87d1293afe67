!> Tests src/hydro/friction_diagnostics.f90.
!> CTest: test_friction_diagnostics_np1 and test_friction_diagnostics_np2 (the program keeps the test's name, test_friction_diagnostics).
!> The friction diagnostics (src/hydro/friction_diagnostics.f90) on matrices with known answers:
!> a rotated diagonal (eigenvalues and condition number exact), an indefinite, an ill-conditioned,
!> an asymmetric, a zero and a non-finite matrix. Each must be flagged (or not) as documented in
!> docs/stress_tests.md, without a floating-point trap (Debug builds trap on invalid operations).
program test_friction_diagnostics
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf
  use beadmob_kinds, only: dp
  use beadmob_testing, only: test_suite_t, start_tests, finish_tests, check, check_close
  use beadmob_friction_diagnostics, only: friction_diagnostics_t, diagnose_friction, friction_warning, &
                                          condition_threshold, asymmetry_threshold
  implicit none
  type(test_suite_t) :: suite
  type(friction_diagnostics_t) :: diag
  real(dp) :: q(6, 6), zeta(6, 6), values(6)
  character(len=:), allocatable :: text

  suite = start_tests('test_friction_diagnostics')
  q = orthogonal()
  values = [1.0_dp, 2.0_dp, 3.0_dp, 4.0_dp, 5.0_dp, 6.0_dp]

  ! SPD with eigenvalues 1..6: condition number 6, nothing flagged.
  diag = diagnose_friction(with_eigenvalues(values))
  call check(suite, diag%finite .and. diag%positive_definite .and. diag%symmetric .and. diag%well_conditioned, &
             'SPD matrix: finite, positive definite, symmetric, well conditioned')
  call check(suite, maxval(abs(diag%eigenvalues - values)) < 1.0e-12_dp, 'SPD matrix: eigenvalues 1..6')
  call check_close(suite, diag%condition_number, 6.0_dp, 1.0e-12_dp, 'SPD matrix: condition number')
  call check(suite, diag%asymmetry < 1.0e-15_dp, 'SPD matrix: asymmetry at rounding')
  call check(suite, len(friction_warning(diag, 'zeta')) == 0, 'SPD matrix: no warning')

  ! One negative eigenvalue: not positive definite, warned.
  values(1) = -1.0e-3_dp
  diag = diagnose_friction(with_eigenvalues(values))
  call check(suite, .not. diag%positive_definite, 'indefinite matrix: flagged not positive definite')
  call check_close(suite, diag%eigenvalues(1), -1.0e-3_dp, 1.0e-9_dp, 'indefinite matrix: smallest eigenvalue')
  call check_close(suite, diag%condition_number, 6.0e3_dp, 1.0e-9_dp, 'indefinite matrix: max|l| / min|l|')
  text = friction_warning(diag, 'zeta')
  call check(suite, index(text, 'zeta is not positive definite (smallest eigenvalue -1.000E-03)') == 1, &
             'indefinite matrix: warning text, got "' // text // '"')

  ! Condition number 6e13 > 1e12: flagged, still positive definite.
  values(1) = 1.0e-13_dp
  diag = diagnose_friction(with_eigenvalues(values))
  call check(suite, diag%positive_definite .and. .not. diag%well_conditioned, &
             'ill-conditioned matrix: positive definite, flagged ill-conditioned')
  call check(suite, diag%condition_number > condition_threshold, 'ill-conditioned matrix: condition number > 1e12')
  call check(suite, index(friction_warning(diag, 'zeta'), 'ill-conditioned (condition number') > 0, &
             'ill-conditioned matrix: warning')

  ! An antisymmetric part of 1e-6 relative: flagged asymmetric, the asymmetry measured exactly.
  zeta = with_eigenvalues([1.0_dp, 2.0_dp, 3.0_dp, 4.0_dp, 5.0_dp, 6.0_dp])
  zeta(1, 2) = zeta(1, 2) + 1.0e-6_dp
  zeta(2, 1) = zeta(2, 1) - 1.0e-6_dp
  diag = diagnose_friction(zeta)
  call check(suite, .not. diag%symmetric .and. diag%positive_definite, 'asymmetric matrix: flagged, still SPD part')
  call check_close(suite, diag%asymmetry, 2.0e-6_dp * sqrt(2.0_dp) / norm2(zeta), 1.0e-6_dp, 'asymmetric matrix: asymmetry')
  call check(suite, diag%asymmetry > asymmetry_threshold, 'asymmetric matrix: above the threshold')
  call check(suite, index(friction_warning(diag, 'zeta'), 'is not symmetric') > 0, 'asymmetric matrix: warning')

  ! Two problems at once: one line naming both.
  values = [-1.0_dp, 2.0_dp, 3.0_dp, 4.0_dp, 5.0_dp, 6.0e13_dp]
  text = friction_warning(diagnose_friction(with_eigenvalues(values)), 'zeta')
  call check(suite, index(text, 'not positive definite') > 0 .and. index(text, ' and is ill-conditioned') > 0, &
             'two problems in one line, got "' // text // '"')

  ! Zero matrix: singular, condition number huge, no division by zero.
  zeta = 0.0_dp
  diag = diagnose_friction(zeta)
  call check(suite, diag%finite .and. .not. diag%positive_definite .and. diag%condition_number == huge(1.0_dp), &
             'zero matrix: finite, not positive definite, condition number huge')

  ! Non-finite entries: flagged, nothing computed from them.
  zeta = with_eigenvalues([1.0_dp, 2.0_dp, 3.0_dp, 4.0_dp, 5.0_dp, 6.0_dp])
  zeta(3, 4) = ieee_value(1.0_dp, ieee_quiet_nan)
  diag = diagnose_friction(zeta)
  call check(suite, .not. diag%finite .and. .not. diag%positive_definite .and. .not. diag%well_conditioned, &
             'NaN entry: flagged not finite, not positive definite, not well conditioned')
  call check(suite, index(friction_warning(diag, 'zeta'), 'zeta has non-finite entries') == 1, 'NaN entry: warning')
  zeta(3, 4) = ieee_value(1.0_dp, ieee_positive_inf)
  diag = diagnose_friction(zeta)
  call check(suite, .not. diag%finite, 'infinite entry: flagged not finite')

  call finish_tests(suite)

contains

  !> Q diag(values) Q^T.
  function with_eigenvalues(values) result(matrix)
    real(dp), intent(in) :: values(6)
    real(dp) :: matrix(6, 6)
    integer :: k
    matrix = 0.0_dp
    do k = 1, 6
      matrix = matrix + values(k) * spread(q(:, k), 2, 6) * spread(q(:, k), 1, 6)
    end do
    matrix = 0.5_dp * (matrix + transpose(matrix))   ! exactly symmetric
  end function with_eigenvalues

  !> A fixed orthogonal matrix: Householder reflection I - 2 v v^T / v.v.
  function orthogonal() result(matrix)
    real(dp) :: matrix(6, 6), v(6)
    integer :: k
    v = [1.0_dp, -2.0_dp, 0.5_dp, 3.0_dp, -1.5_dp, 2.5_dp]
    matrix = -2.0_dp * spread(v, 2, 6) * spread(v, 1, 6) / dot_product(v, v)
    do k = 1, 6
      matrix(k, k) = matrix(k, k) + 1.0_dp
    end do
  end function orthogonal
end program test_friction_diagnostics
