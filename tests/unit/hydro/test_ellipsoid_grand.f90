!> Tests the ellipsoid's grand resistance in a linear flow (src/hydro/ellipsoid_friction.f90,
!> docs/theory.md T19) and the free-body response (src/hydro/flow_response.f90).
!> CTest: test_ellipsoid_grand_np1 and test_ellipsoid_grand_np2.
!> References: a sphere's stresslet (20/3) pi a^3 (Einstein 1906; Batchelor 1970, eq. 5.8) and no
!> rotation; a 1.6 : 1 : 0.7 and a 10 : 1 : 0.1 ellipsoid against scripts/beadmob_post/ellipsoid.py
!> (its beta integrals by Carlson's duplication, an independent evaluation of the ones this code
!> integrates by quadrature; that module's own tests check it against Kim & Karrila's spheroid
!> resistance functions and Simha's intrinsic viscosity); covariance under a turn of the axes.
program test_ellipsoid_grand
  use beadmob_kinds, only: dp
  use beadmob_testing, only: test_suite_t, start_tests, finish_tests, check, check_close
  use beadmob_ellipsoid_friction, only: ellipsoid_grand_resistance
  use beadmob_flow_response, only: free_body_response
  use beadmob_linear_flow, only: strain_rotation
  implicit none
  real(dp), parameter :: pi = acos(-1.0_dp)
  real(dp), parameter :: identity(3, 3) = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
                                                   1.0_dp], [3, 3])
  ! scripts/beadmob_post/ellipsoid.py, ellipsoid_flow([1.6, 1.0, 0.7]) and ([10, 1, 0.1]): diag(T), T(4, 5)
  real(dp), parameter :: triaxial_stresslet(5) = [27.57729070088327_dp, 20.504309265929667_dp, 19.888740110379416_dp, &
                                                  31.141840231669825_dp, 22.887981855578865_dp]
  real(dp), parameter :: triaxial_coupling = -4.322077368750633_dp
  real(dp), parameter :: triaxial_rotation(3) = [0.30985578051994783_dp, -0.47990525805119794_dp, 0.24202983785579812_dp]
  real(dp), parameter :: flat_stresslet(5) = [94.17905947116601_dp, 9.25542095031936_dp, 10.04143127974948_dp, &
                                              1002.9742195167516_dp, 361.8595122100319_dp]
  real(dp), parameter :: flat_coupling = -544.3349247720043_dp
  type(test_suite_t) :: suite
  real(dp) :: grand(11, 11), turned(11, 11), velocity(6, 5), stresslet(5, 5), q(3, 3), turn(11, 11), angle
  logical :: ok
  integer :: k

  suite = start_tests('test_ellipsoid_grand')
  grand = ellipsoid_grand_resistance([0.5_dp, 0.5_dp, 0.5_dp], identity)
  call free_body_response(grand, velocity, stresslet, ok)
  call check(suite, ok, 'sphere: friction positive definite')
  do k = 1, 5
    call check_close(suite, stresslet(k, k), 20.0_dp / 3.0_dp * pi * 0.125_dp, 1.0e-12_dp, 'sphere: 20/3 pi a^3')
  end do
  call check(suite, maxval(abs(velocity)) < 1.0e-14_dp, 'sphere: moves with the flow')
  call check(suite, maxval(abs(grand(4:6, 7:))) < 1.0e-12_dp, 'sphere: no torque when held in a strain')

  grand = ellipsoid_grand_resistance([1.6_dp, 1.0_dp, 0.7_dp], identity)
  call free_body_response(grand, velocity, stresslet, ok)
  do k = 1, 5
    call check_close(suite, stresslet(k, k), triaxial_stresslet(k), 1.0e-11_dp, '1.6:1:0.7 stresslet diagonal')
  end do
  call check_close(suite, stresslet(4, 5), triaxial_coupling, 1.0e-11_dp, '1.6:1:0.7 stresslet E_4 E_5')
  call check_close(suite, velocity(6, 1), triaxial_rotation(1), 1.0e-13_dp, 'Jeffery: Omega_z per E_1')
  call check_close(suite, velocity(5, 2), triaxial_rotation(2), 1.0e-13_dp, 'Jeffery: Omega_y per E_2')
  call check_close(suite, velocity(4, 3), triaxial_rotation(3), 1.0e-13_dp, 'Jeffery: Omega_x per E_3')
  call check(suite, maxval(abs(velocity(1:3, :))) < 1.0e-14_dp, 'ellipsoid: no translation relative to the flow')
  call check(suite, maxval(abs(grand - transpose(grand))) < 1.0e-12_dp * maxval(abs(grand)), 'grand symmetric')

  grand = ellipsoid_grand_resistance([10.0_dp, 1.0_dp, 0.1_dp], identity)
  call free_body_response(grand, velocity, stresslet, ok)
  do k = 1, 5
    call check_close(suite, stresslet(k, k), flat_stresslet(k), 1.0e-10_dp, '10:1:0.1 stresslet diagonal')
  end do
  call check_close(suite, stresslet(4, 5), flat_coupling, 1.0e-10_dp, '10:1:0.1 stresslet E_4 E_5')

  ! Turned axes: G' = R G R^T with R = diag(Q, Q, D(Q)).
  angle = 0.7_dp
  q = reshape([cos(angle), sin(angle), 0.0_dp, -sin(angle), cos(angle), 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], [3, 3])
  q = matmul(q, reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, cos(1.1_dp), sin(1.1_dp), 0.0_dp, -sin(1.1_dp), &
                         cos(1.1_dp)], [3, 3]))
  grand = ellipsoid_grand_resistance([1.6_dp, 1.0_dp, 0.7_dp], identity)
  turned = ellipsoid_grand_resistance([1.6_dp, 1.0_dp, 0.7_dp], q)
  turn = 0.0_dp
  turn(1:3, 1:3) = q
  turn(4:6, 4:6) = q
  turn(7:, 7:) = strain_rotation(q)
  call check(suite, maxval(abs(turned - matmul(turn, matmul(grand, transpose(turn))))) < 1.0e-12_dp * maxval(abs(grand)), &
             'turned axes: R G R^T')
  ! The same axes with one reversed (an improper matrix) are the same ellipsoid: the same G.
  q(:, 2) = -q(:, 2)
  call check(suite, maxval(abs(ellipsoid_grand_resistance([1.6_dp, 1.0_dp, 0.7_dp], q) - turned)) < &
             1.0e-12_dp * maxval(abs(grand)), 'an axis reversed: the same ellipsoid')
  call finish_tests(suite)
end program test_ellipsoid_grand
