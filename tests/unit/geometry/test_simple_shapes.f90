!> Tests src/geometry/simple_shapes.f90.
!> CTest: test_simple_shapes_np1 and test_simple_shapes_np2 (the program keeps the test's name, test_simple_shapes).
!> The validation shapes have the bead counts that follow from their definitions.
program test_simple_shapes
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t
  use beadmob_simple_shapes, only: build_single_bead, build_bead_pair, build_chain, build_filled_sphere, &
                                   build_spheroid, build_box, build_torus, build_solid_box, build_cylinder
  use beadmob_testing
  implicit none
  type(test_suite_t) :: suite
  type(error_t) :: err
  real(dp), allocatable :: centres(:, :)
  ! Lattice points of Z^3 in a ball of radius n = 0..5: OEIS A000605 (1, 7, 33, 123, 257, 515).
  integer, parameter :: ball_counts(0:5) = [1, 7, 33, 123, 257, 515]
  integer :: n

  suite = start_tests('test_simple_shapes')

  call build_single_bead(centres, err)
  call check_equal(suite, size(centres, 2), 1, 'single bead')
  call check(suite, all(centres(:, 1) == 0.0_dp), 'single bead at the origin')

  call build_bead_pair(2.5_dp, centres, err)
  call check_equal(suite, size(centres, 2), 2, 'bead pair')
  call check_close(suite, norm2(centres(:, 2) - centres(:, 1)), 2.5_dp, 1e-15_dp, 'pair separation')

  call build_chain(1000, centres, err)
  call check_equal(suite, size(centres, 2), 1000, 'chain of 1000')
  call check_close(suite, maxval(centres(1, :)) - minval(centres(1, :)), 999.0_dp, 0.0_dp, 'chain span 999 d')

  do n = 1, 5
    call build_filled_sphere(real(n, dp), centres, err)
    call check_equal(suite, size(centres, 2), ball_counts(n), 'filled sphere of radius ' // achar(48 + n))
  end do

  call build_spheroid([2.0_dp, 2.0_dp, 2.0_dp], centres, err)
  call check_equal(suite, size(centres, 2), 33, 'spheroid with equal semi-axes 2 = ball of radius 2')
  ! x^2/4 + y^2 + z^2 <= 1: 5 points at x = 0, one each at x = +-1 and x = +-2.
  call build_spheroid([2.0_dp, 1.0_dp, 1.0_dp], centres, err)
  call check_equal(suite, size(centres, 2), 9, 'prolate spheroid (2, 1, 1)')

  call build_box(3, 4, 5, centres, err)
  call check_equal(suite, size(centres, 2), 60, 'box 3 x 4 x 5')
  ! Sides 3, 4, 5 centred on a node: |x| <= 1.5, |y| <= 2, |z| <= 2.5 hold 3 x 5 x 5 nodes; on the
  ! lattice shifted by 0.25 on every axis, 3 x 4 x 5 points (x in -0.75 ... 1.25, y in -1.75 ... 1.25).
  call build_solid_box([3.0_dp, 4.0_dp, 5.0_dp], centres, err)
  call check_equal(suite, size(centres, 2), 75, 'box of sides 3, 4, 5')
  call build_solid_box([3.0_dp, 4.0_dp, 5.0_dp], centres, err, [0.25_dp, 0.25_dp, 0.25_dp])
  call check_equal(suite, size(centres, 2), 60, 'box of sides 3, 4, 5 on the lattice shifted by 0.25')
  call check(suite, abs(minval(centres(2, :)) + 1.75_dp) < 1e-15_dp, 'shifted box: its points are node + 0.25')
  ! Cylinder radius 2, length 4: N(2) = 13 disk points (Gauss circle) in each of 5 layers.
  call build_cylinder(2.0_dp, 4.0_dp, centres, err)
  call check_equal(suite, size(centres, 2), 65, 'cylinder (2, 4)')

  ! Torus R = 3, r = 1: in z = 0 the 49 - 9 = 40 points with 4 <= x^2 + y^2 <= 16 (Gauss circle
  ! counts N(4) = 49, N(sqrt 3) = 9); in z = +-1 the 4 points each with x^2 + y^2 = 9.
  call build_torus(3.0_dp, 1.0_dp, centres, err)
  call check_equal(suite, size(centres, 2), 48, 'torus (3, 1)')
  call check(suite, .not. err%failed, 'no error for valid simple shapes')

  call build_chain(0, centres, err)
  call check(suite, err%failed, 'chain of 0 beads rejected')
  err = error_t()
  call build_filled_sphere(-2.5_dp, centres, err)
  call check(suite, err%failed .and. index(err%message, 'radius') > 0, 'negative radius rejected, named')
  err = error_t()
  call build_bead_pair(0.5_dp, centres, err)
  call check(suite, err%failed, 'overlapping pair (separation 0.5) rejected')
  err = error_t()
  call build_box(3, -1, 2, centres, err)
  call check(suite, err%failed, 'box with a negative size rejected')
  err = error_t()
  call build_torus(3.0_dp, -1.0_dp, centres, err)
  call check(suite, err%failed, 'torus with a negative minor radius rejected')
  call finish_tests(suite)
end program test_simple_shapes
