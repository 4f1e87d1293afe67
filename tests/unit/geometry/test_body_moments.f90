!> Tests src/geometry/body_moments.f90 (with the offsets of src/geometry/simple_shapes.f90).
!> CTest: test_body_moments_np1 and test_body_moments_np2.
!> The mean over sub-lattice offsets of a lattice ellipsoid's volume and second moments is the
!> continuous ellipsoid's (V = 4 pi abc / 3, moment a^2 / 5 per volume on each axis: exact
!> integrals), so the equivalent ellipsoid of the averaged moments is the ellipsoid itself;
!> the offsets are the continuum job's (offset_sequence: the Halton sequence in bases 2, 3, 5).
!> moments_of_polyhedron on a box of sides 2, 3, 5 given as 12 triangles, turned and moved far
!> off: volume 30, centroid the box's centre, central second moments per volume (s_i^2 / 12 on
!> the box's axes: the exact integrals), to rounding; moved to the origin (moments_about_origin),
!> its second moment V (central + c c^T) about the origin, c the box's centre.
!> The continuum job's lattice turns (turn_sequence): each a proper rotation (Q^T Q = 1, det 1) by
!> at most the angle asked (cos angle = (trace - 1) / 2), the 64 of a sequence all different and
!> reaching near that angle, for a small angle and for any (pi).
program test_body_moments
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t
  use beadmob_testing, only: test_suite_t, start_tests, finish_tests, check, check_close
  use beadmob_simple_shapes, only: build_spheroid
  use beadmob_lattice_fill, only: offset_sequence, turn_sequence
  use beadmob_vector_algebra, only: axis_angle_rotation
  use beadmob_body_moments, only: body_moments_t, moments_of_beads, moments_of_polyhedron, moments_about_origin, &
                                  equivalent_ellipsoid
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
  call check_box_polyhedron()
  call check_turns(15.0_dp * pi / 180.0_dp)
  call check_turns(pi)
  one = body_moments_t()
  call equivalent_ellipsoid(one, 0.0_dp, semi_found, axes_found, err)
  call check(suite, err%failed, 'no volume: refused')
  call finish_tests(suite)

contains

  subroutine check_box_polyhedron()
    real(dp), parameter :: sides(3) = [2.0_dp, 3.0_dp, 5.0_dp], shift(3) = [1000.3_dp, -2000.1_dp, 500.7_dp]
    ! The unit cube's corners (bit k of the index: coordinate k) and its faces, outward.
    integer, parameter :: faces(3, 12) = reshape([1, 3, 2, 2, 3, 4, 5, 6, 7, 6, 8, 7, 1, 2, 5, 2, 6, 5, &
                                                   3, 7, 4, 4, 7, 8, 1, 5, 3, 3, 5, 7, 2, 4, 6, 4, 8, 6], [3, 12])
    real(dp) :: corners(3, 8), turn(3, 3), central(3, 3), expected(3, 3), c(3)
    type(body_moments_t) :: box, moved
    integer :: i, k
    ! a turn about (1, 2, 2) / 3 by 0.7 rad (Rodrigues)
    turn = axis_angle_rotation([1.0_dp, 2.0_dp, 2.0_dp] / 3.0_dp, 0.7_dp)
    do i = 1, 8
      corners(:, i) = [(real(merge(1, 0, btest(i - 1, k - 1)), dp), k = 1, 3)] * sides
      corners(:, i) = matmul(turn, corners(:, i)) + shift
    end do
    box = moments_of_polyhedron(corners, faces, corners(:, 1))
    call check_close(suite, box%volume, product(sides), 1.0e-12_dp, 'polyhedron: the box''s volume')
    c = box%centroid() + corners(:, 1)
    call check(suite, maxval(abs(c - (matmul(turn, sides / 2.0_dp) + shift))) < 1.0e-9_dp, 'polyhedron: the box''s centroid')
    central = box%second / box%volume
    c = box%centroid()
    do k = 1, 3
      central(:, k) = central(:, k) - c * c(k)
    end do
    expected = 0.0_dp
    do k = 1, 3
      expected(k, k) = sides(k)**2 / 12.0_dp
    end do
    expected = matmul(turn, matmul(expected, transpose(turn)))
    call check(suite, maxval(abs(central - expected)) < 1.0e-11_dp, 'polyhedron: the box''s central second moments')
    moved = moments_about_origin(box, corners(:, 1))
    c = matmul(turn, sides / 2.0_dp) + shift
    call check(suite, maxval(abs(moved%centroid() - c)) < 1.0e-9_dp, 'polyhedron about the origin: the centroid')
    do k = 1, 3
      central(:, k) = product(sides) * (expected(:, k) + c * c(k))
    end do
    call check(suite, maxval(abs(moved%second - central)) < 1.0e-12_dp * maxval(abs(central)), &
               'polyhedron about the origin: the second moment V (central + c c^T)')
  end subroutine check_box_polyhedron

  subroutine check_turns(max_angle)
    real(dp), intent(in) :: max_angle
    real(dp) :: q(3, 3, fills), identity(3, 3), angles(fills), closest
    integer :: j, i
    identity = 0.0_dp
    do i = 1, 3
      identity(i, i) = 1.0_dp
    end do
    closest = huge(1.0_dp)
    do j = 1, fills
      q(:, :, j) = turn_sequence(j, max_angle)
      angles(j) = acos(max(-1.0_dp, min(1.0_dp, (q(1, 1, j) + q(2, 2, j) + q(3, 3, j) - 1.0_dp) / 2.0_dp)))
      do i = 1, j - 1
        closest = min(closest, maxval(abs(q(:, :, j) - q(:, :, i))))
      end do
    end do
    call check(suite, all([(maxval(abs(matmul(transpose(q(:, :, j)), q(:, :, j)) - identity)) < 1.0e-13_dp, j = 1, fills)]) &
               .and. all([(abs(determinant(q(:, :, j)) - 1.0_dp) < 1.0e-13_dp, j = 1, fills)]), &
               'turns: proper rotations')
    call check(suite, maxval(angles) <= max_angle * (1.0_dp + 1.0e-12_dp) .and. maxval(angles) > 0.85_dp * max_angle, &
               'turns: by at most the angle asked, and near it')
    call check(suite, closest > 1.0e-3_dp, 'turns: all different')
  end subroutine check_turns

  pure real(dp) function determinant(a)
    real(dp), intent(in) :: a(3, 3)
    determinant = a(1, 1) * (a(2, 2) * a(3, 3) - a(3, 2) * a(2, 3)) - a(1, 2) * (a(2, 1) * a(3, 3) - a(3, 1) * a(2, 3)) &
                  + a(1, 3) * (a(2, 1) * a(3, 2) - a(3, 1) * a(2, 2))
  end function determinant
end program test_body_moments
