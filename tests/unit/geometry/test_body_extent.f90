!> Tests src/geometry/body_extent.f90 (and body_frame.f90's spread_along, a mesh's extent). CTest: test_body_extent_np1 and test_body_extent_np2.
!> The closed-form extents (support functions) of the spheroid, the box by box_size, the
!> cylinder and the torus along random unit axes against a different method: the spread of the
!> projections of their surfaces sampled on a parametric grid of n x n points. The sample's spread
!> lies below the exact extent and converges to it like (pi / n)^2 (a smooth extreme point missed
!> by at most half a grid step): within 1e-4 of the body's size at n = 360, and never above it.
!> The sphere's is 2 R; a box of bead counts (box_beads) and the paper's shapes have none; a
!> mesh's is its vertices' spread.
program test_body_extent
  use beadmob_kinds, only: dp
  use beadmob_testing, only: test_suite_t, start_tests, finish_tests, check, check_close
  use beadmob_input_config, only: shape_config_t
  use beadmob_body_extent, only: continuous_extent
  use beadmob_body_frame, only: spread_along
  implicit none
  real(dp), parameter :: pi = acos(-1.0_dp)
  integer, parameter :: n = 360, n_axes = 12
  type(test_suite_t) :: suite
  type(shape_config_t) :: c
  real(dp) :: axis(3), extent, low, high
  real(dp) :: cube(3, 8)
  logical :: known
  integer :: k, i

  suite = start_tests('test_body_extent')
  call random_seed(put=[(20261129 + i, i = 1, 64)])
  do k = 1, n_axes
    axis = random_axis()

    c = shape_config_t(name='spheroid', semi_axes=[1.3_dp, 0.6_dp, 2.1_dp])
    call continuous_extent(c, axis, extent, known)
    call sampled(c, axis, low, high)
    call within(c%name, extent, known, high - low, 2.0_dp * 2.1_dp)

    c = shape_config_t(name='box', box_size=[0.5_dp, 3.0_dp, 1.7_dp])
    call continuous_extent(c, axis, extent, known)
    call sampled(c, axis, low, high)
    call within(c%name, extent, known, high - low, 3.0_dp)

    c = shape_config_t(name='cylinder', radius=0.4_dp, length=2.5_dp)
    call continuous_extent(c, axis, extent, known)
    call sampled(c, axis, low, high)
    call within(c%name, extent, known, high - low, 2.5_dp)

    c = shape_config_t(name='torus', major_radius=1.5_dp, minor_radius=0.35_dp)
    call continuous_extent(c, axis, extent, known)
    call sampled(c, axis, low, high)
    call within(c%name, extent, known, high - low, 3.7_dp)

    c = shape_config_t(name='sphere', radius=0.8_dp)
    call continuous_extent(c, axis, extent, known)
    call check(suite, known .and. abs(extent - 1.6_dp) <= 1e-15_dp, 'sphere: extent 2 R along any axis')
  end do

  c = shape_config_t(name='box', box_beads=[3, 4, 5])
  call continuous_extent(c, [1.0_dp, 0.0_dp, 0.0_dp], extent, known)
  call check(suite, .not. known, 'a box of bead counts has no body extent')
  c = shape_config_t(name='cone')
  call continuous_extent(c, [0.0_dp, 0.0_dp, 1.0_dp], extent, known)
  call check(suite, .not. known, 'the paper''s cone: none here (its reference model''s size is used)')

  ! A unit cube's corners: along a body diagonal its extent is sqrt(3), along an edge 1.
  do i = 1, 8
    cube(:, i) = [real(mod(i - 1, 2), dp), real(mod((i - 1) / 2, 2), dp), real((i - 1) / 4, dp)] + 1000.0_dp
  end do
  call check_close(suite, spread_along(cube, [1.0_dp, 1.0_dp, 1.0_dp] / sqrt(3.0_dp)), sqrt(3.0_dp), &
                   1e-12_dp, 'spread_along: a cube far off, along its diagonal')
  call check_close(suite, spread_along(cube, [0.0_dp, 1.0_dp, 0.0_dp]), 1.0_dp, 1e-12_dp, &
                   'spread_along: a cube far off, along an edge')
  call finish_tests(suite)

contains

  !> The closed form is known, no smaller than the sample's spread, and within 1e-4 of the size of it.
  subroutine within(name, extent, known, spread, size)
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: extent, spread, size
    logical, intent(in) :: known
    call check(suite, known .and. spread <= extent + 1e-12_dp * size .and. extent - spread <= 1e-4_dp * size, &
               trim(name) // ': closed-form extent against its sampled surface')
  end subroutine within

  function random_axis() result(e)
    real(dp) :: e(3), u(3)
    do
      call random_number(u)
      e = 2.0_dp * u - 1.0_dp
      if (norm2(e) > 0.1_dp .and. norm2(e) <= 1.0_dp) exit
    end do
    e = e / norm2(e)
  end function random_axis

  !> The lowest and highest projection on `axis` of shape c's surface on an n x n parametric grid
  !> (the box: each face's grid; the cylinder: its mantle and rims).
  subroutine sampled(c, axis, low, high)
    type(shape_config_t), intent(in) :: c
    real(dp), intent(in) :: axis(3)
    real(dp), intent(out) :: low, high
    real(dp) :: u, v, p(3), half(3)
    integer :: i, j, face, sign
    low = huge(1.0_dp)
    high = -huge(1.0_dp)
    do i = 0, n
      do j = 0, n - 1
        u = pi * i / n            ! polar angle, or a face coordinate in [0, 1] below
        v = 2.0_dp * pi * j / n   ! azimuth
        select case (trim(c%name))
        case ('spheroid')
          call take(axis, c%semi_axes * [sin(u) * cos(v), sin(u) * sin(v), cos(u)], low, high)
        case ('torus')
          ! u runs round the tube here (twice pi over the grid), v round the centre circle
          call take(axis, [(c%major_radius + c%minor_radius * cos(2.0_dp * u)) * cos(v), &
                           (c%major_radius + c%minor_radius * cos(2.0_dp * u)) * sin(v), &
                           c%minor_radius * sin(2.0_dp * u)], low, high)
        case ('cylinder')
          call take(axis, [c%radius * cos(v), c%radius * sin(v), c%length * (real(i, dp) / n - 0.5_dp)], low, high)
        case ('box')
          half = c%box_size / 2.0_dp
          do face = 1, 3
            do sign = -1, 1, 2
              ! the face normal to axis `face`: its two other coordinates on the grid
              p = half * cshift([2.0_dp * i / n - 1.0_dp, 2.0_dp * j / (n - 1) - 1.0_dp, 0.0_dp], -face)
              p(face) = sign * half(face)
              call take(axis, p, low, high)
            end do
          end do
        end select
      end do
    end do
  end subroutine sampled

  !> One surface point's projection taken into [low, high].
  subroutine take(axis, point, low, high)
    real(dp), intent(in) :: axis(3), point(3)
    real(dp), intent(inout) :: low, high
    low = min(low, dot_product(axis, point))
    high = max(high, dot_product(axis, point))
  end subroutine take
end program test_body_extent
