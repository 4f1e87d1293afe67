!> Tests src/geometry/body_moments.f90 (with the offsets of src/geometry/simple_shapes.f90).
!> CTest: test_body_moments_np1 and test_body_moments_np2.
!> The mean over sub-lattice offsets of a lattice ellipsoid's volume and second moments is the
!> continuous ellipsoid's (V = 4 pi abc / 3, moment a^2 / 5 per volume on each axis: exact
!> integrals), so the equivalent ellipsoid of the averaged moments is the ellipsoid itself;
!> the offsets are the continuum job's (offset_sequence: the Halton sequence in bases 2, 3, 5).
program test_body_moments
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t
  use beadmob_testing, only: test_suite_t, start_tests, finish_tests, check, check_close
  use beadmob_simple_shapes, only: build_spheroid
  use beadmob_lattice_fill, only: offset_sequence
  use beadmob_body_moments, only: body_moments_t, moments_of_beads, equivalent_ellipsoid
  implicit none
  real(dp), parameter :: pi = acos(-1.0_dp), semi_axes(3) = [9.0_dp, 6.0_dp, 4.5_dp], d = 0.5_dp
  integer, parameter :: fills = 64
  type(test_suite_t) :: suite
  type(error_t) :: err
  type(body_moments_t) :: one, mean
  real(dp), allocatable :: centres(:, :)
  real(dp) :: offset(3), axes_found(3, 3), semi_found(3)
  integer :: k

  suite = start_tests('test_body_moments')
  do k = 1, fills
    offset = offset_sequence(k)
    call build_spheroid(semi_axes / d, centres, err, offset)
    one = moments_of_beads(centres, d)
    mean%volume = mean%volume + one%volume / fills
    mean%first = mean%first + one%first / fills
    mean%second = mean%second + one%second / fills
  end do
  call check(suite, .not. err%failed, 'offset fills build')
  call check_close(suite, mean%volume, 4.0_dp * pi * product(semi_axes) / 3.0_dp, 2.0e-3_dp, 'mean volume = 4 pi abc / 3')
  call check(suite, maxval(abs(mean%centroid())) < 2.0e-3_dp * semi_axes(3), 'mean centroid at the centre')
  call equivalent_ellipsoid(mean, 0.0_dp, semi_found, axes_found, err)
  call check(suite, .not. err%failed, 'equivalent ellipsoid found')
  ! dsyev: eigenvalues ascending, so the semi-axes come smallest first on the axes z, y, x.
  call check(suite, maxval(abs(semi_found - semi_axes(3:1:-1)) / semi_axes(3:1:-1)) < 2.0e-3_dp, &
             'equivalent ellipsoid of the mean moments: the semi-axes')
  call check(suite, abs(abs(axes_found(3, 1)) - 1.0_dp) < 1.0e-6_dp .and. abs(abs(axes_found(1, 3)) - 1.0_dp) < 1.0e-6_dp, &
             'equivalent ellipsoid: its axes')
  one = body_moments_t()
  call equivalent_ellipsoid(one, 0.0_dp, semi_found, axes_found, err)
  call check(suite, err%failed, 'no volume: refused')
  call finish_tests(suite)
end program test_body_moments
