!> Tests src/multipole/dense_friction.f90 (through the helper tests/unit/support/two_sphere_modes.f90)
!> against src/lubrication/two_sphere_exact.f90, which it covers too.
!> CTest: test_two_sphere_convergence_np1 and test_two_sphere_convergence_np2 (the program keeps the test's name, test_two_sphere_convergence).
!> Two spheres at centre distances 2.5a, 3a, 4a, 6a: the multipole friction converges with the
!> order L to the exact values. References: Stimson & Jeffery (1926) for both spheres translating
!> along the line of centres (XA_sym), Maude (1961) / Brenner (1961) for approach (XA_anti),
!> Jeffery (1915) for counter-rotation about the axis (XC_anti): series in bispherical
!> coordinates (src/lubrication/two_sphere_exact.f90); the other seven functions against the
!> method itself at L = 30 (theory.md T8: rigid-sphere functions at these distances change by
!> < 1e-12 from L = 24 to 30, checked below). Also the contact limit of Stimson-Jeffery against the
!> literature value 0.645 (Stimson & Jeffery 1926; Happel & Brenner 1965, sec. 6.3).
program test_two_sphere_convergence
  use beadmob_kinds, only: dp
  use beadmob_testing
  use beadmob_errors, only: error_t
  use beadmob_strings, only: str
  use beadmob_multipole_basis, only: bead_radius
  use beadmob_two_sphere_exact, only: stimson_jeffery, stimson_jeffery_contact, maude_approach, jeffery_counter_rotation
  use beadmob_two_sphere_modes, only: two_sphere_functions, function_names, n_functions
  implicit none
  type(test_suite_t) :: suite
  type(error_t) :: err
  real(dp), parameter :: distances(4) = [2.5_dp, 3.0_dp, 4.0_dp, 6.0_dp]   ! units of a
  real(dp) :: r, exact(n_functions), approx(n_functions), previous(n_functions)
  integer :: m, f

  suite = start_tests('test_two_sphere_convergence')
  call check(suite, abs(stimson_jeffery_contact(bead_radius) - 0.645_dp) < 5.0e-4_dp, &
             'Stimson-Jeffery contact limit = 0.645 (literature)')
  ! Far apart both series tend to the single sphere: 1 - 3a/(2r) + ... (method of reflections).
  call check(suite, abs(stimson_jeffery(100.0_dp, bead_radius) - 1.0_dp / (1.0_dp + 1.5_dp * bead_radius / 100.0_dp)) &
             < 1.0e-4_dp, 'Stimson-Jeffery far field ~ 1/(1 + 3a/(2r))')
  do m = 1, size(distances)
    r = distances(m) * bead_radius
    call two_sphere_functions(r, 30, 28, exact, err)
    call two_sphere_functions(r, 24, 22, previous, err)
    call check(suite, maxval(abs(exact - previous)) < 1.0e-10_dp, 'r = ' // str(distances(m)) // &
               'a: L = 24 -> 30 changes every function by < 1e-10 (reference converged)')
    call check(suite, abs(exact(1) - stimson_jeffery(r, bead_radius)) < 1.0e-10_dp, &
               'r = ' // str(distances(m)) // 'a: L = 30 = Stimson-Jeffery series')
    exact(1) = stimson_jeffery(r, bead_radius)
    exact(2) = maude_approach(r, bead_radius)
    exact(4) = jeffery_counter_rotation(r, bead_radius)
    call two_sphere_functions(r, 16, 14, approx, err)
    call check(suite, .not. err%failed, 'dense solves succeeded')
    do f = 1, n_functions
      call check(suite, abs(approx(f) - exact(f)) < 1.0e-6_dp, 'r = ' // str(distances(m)) // 'a, L = 16: ' // &
                 trim(function_names(f)) // ' within 1e-6 of the exact value')
    end do
  end do
  call finish_tests(suite)
end program test_two_sphere_convergence
