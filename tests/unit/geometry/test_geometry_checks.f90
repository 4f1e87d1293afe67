!> Tests src/geometry/geometry_checks.f90; also src/geometry/body_frame.f90 (frames of a box
!> and a pyramid), beads_within of src/geometry/spatial_index.f90 (against every pair) and
!> block_range of src/common/parallel.F90.
!> CTest: test_geometry_np1 and test_geometry_np2 (the program keeps the test's name, test_geometry).
!> Geometry checks and the body frame on small bead sets whose answers follow by hand.
program test_geometry
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t
  use beadmob_bead_model, only: bead_model_t
  use beadmob_geometry_checks, only: check_bead_model, default_overlap_tolerance
  use beadmob_body_frame, only: body_frame_t, compute_body_frame
  use beadmob_parallel, only: run_context_t, make_run_context, block_range
  use beadmob_spatial_index, only: spatial_index_t, build_spatial_index, beads_within
  use beadmob_testing
  use mpi, only: MPI_COMM_WORLD
  implicit none
  type(test_suite_t) :: suite
  real(dp), parameter :: ieee_nan_bits = transfer(int(z'7FF8000000000000', i8), 1.0_dp)

  suite = start_tests('test_geometry')
  call test_overlap_detection()
  call test_non_finite_and_empty()
  call test_box_frame()
  call test_wedge_frame()
  call test_block_range()
  call test_beads_within()
  call finish_tests(suite)

contains

  function model_of(centres) result(model)
    real(dp), intent(in) :: centres(:, :)
    type(bead_model_t) :: model
    model%shape_name = 'test'
    model%source = 'test beads'
    model%centres = centres
  end function model_of

  !> Touching beads (distance exactly d) are fine; closer than d(1 - 1e-6) overlap.
  subroutine test_overlap_detection()
    type(error_t) :: err
    type(bead_model_t) :: model
    model = model_of(reshape([0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 1.0_dp, 0.0_dp], [3, 3]))
    call check_bead_model(model, default_overlap_tolerance, err)
    call check(suite, .not. err%failed, 'touching beads are not an overlap')

    model = model_of(reshape([0.0_dp, 0.0_dp, 0.0_dp, 5.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.9999_dp, 0.0_dp], [3, 3]))
    call check_bead_model(model, default_overlap_tolerance, err)
    call check(suite, err%failed, 'beads 0.9999 d apart overlap')
    if (err%failed) call check(suite, index(err%message, 'bead 1 and bead 3') > 0, &
                               'overlap message names beads 1 and 3: ' // err%message)

    ! Far from the origin (1e6 d) the same test must hold: the index works in local coordinates.
    model = model_of(1.0e6_dp + reshape([0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 2.0_dp, 0.0_dp, 0.0_dp], &
                                        [3, 3]))
    err = error_t()
    call check_bead_model(model, default_overlap_tolerance, err)
    call check(suite, .not. err%failed, 'touching chain at 1e6 d is not an overlap')
  end subroutine test_overlap_detection

  subroutine test_non_finite_and_empty()
    type(error_t) :: err
    type(bead_model_t) :: model
    real(dp), allocatable :: none(:, :)
    model = model_of(reshape([0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, ieee_nan_bits, 0.0_dp], [3, 2]))
    call check_bead_model(model, default_overlap_tolerance, err)
    call check(suite, err%failed, 'NaN coordinate is rejected')
    if (err%failed) call check(suite, index(err%message, 'bead 2 has a non-finite coordinate y') > 0, &
                               'NaN message names bead 2 and y: ' // err%message)
    allocate (none(3, 0))
    model = model_of(none)
    err = error_t()
    call check_bead_model(model, default_overlap_tolerance, err)
    call check(suite, err%failed .and. index(err%message, 'empty') > 0, 'an empty model is rejected')
  end subroutine test_non_finite_and_empty

  !> A 2 x 3 x 4 box: centroid (0.5, 1, 1.5), three mirror planes; x along the larger of
  !> the x and y sizes (here the coordinate y axis), z stays z, y = z cross x = -x.
  subroutine test_box_frame()
    type(error_t) :: err
    type(body_frame_t) :: frame
    real(dp), allocatable :: centres(:, :)
    integer :: i, j, k, n
    allocate (centres(3, 24))
    n = 0
    do k = 0, 3
      do j = 0, 2
        do i = 0, 1
          n = n + 1
          centres(:, n) = [real(i, dp), real(j, dp), real(k, dp)]
        end do
      end do
    end do
    call compute_body_frame(centres, frame, err)
    call check(suite, .not. err%failed, 'box frame computed')
    call check(suite, all(abs(frame%centre_of_mass - [0.5_dp, 1.0_dp, 1.5_dp]) < 1e-14_dp), 'box centre of mass')
    call check(suite, all(abs(frame%axes(:, 1) - [0.0_dp, 1.0_dp, 0.0_dp]) < 1e-14_dp), 'box x axis = coordinate y')
    call check(suite, all(abs(frame%axes(:, 2) - [-1.0_dp, 0.0_dp, 0.0_dp]) < 1e-14_dp), 'box y axis = -x')
    call check(suite, all(abs(frame%axes(:, 3) - [0.0_dp, 0.0_dp, 1.0_dp]) < 1e-14_dp), 'box z axis = z')
    call check(suite, all(abs(frame%extent - [3.0_dp, 2.0_dp, 4.0_dp]) < 1e-14_dp), 'box extents 3, 2, 4')
    call check(suite, all(frame%mirror_plane), 'box has three mirror planes')
    call check(suite, .not. frame%paper_class, 'box is not of the paper class (three mirror planes)')
  end subroutine test_box_frame

  !> A square pyramid (3 x 3 base at z = 0, one bead on top): mirror planes x and y, none in z.
  !> Rotated so that its apex points along +x, the frame's z follows the apex direction.
  subroutine test_wedge_frame()
    type(error_t) :: err
    type(body_frame_t) :: frame
    real(dp) :: centres(3, 10), rotated(3, 10)
    integer :: i, j, n
    n = 0
    do j = -1, 1
      do i = -1, 1
        n = n + 1
        centres(:, n) = [real(i, dp), real(j, dp), 0.0_dp]
      end do
    end do
    centres(:, 10) = [0.0_dp, 0.0_dp, 1.0_dp]
    call compute_body_frame(centres, frame, err)
    call check(suite, frame%paper_class, 'pyramid is of the paper class')
    call check(suite, all(frame%mirror_plane .eqv. [.true., .true., .false.]), 'pyramid mirror planes x, y only')
    call check_close(suite, frame%centre_of_mass(3), 0.1_dp, 1e-14_dp, 'pyramid centre of mass z = 1/10')
    call check(suite, abs(abs(frame%axes(3, 3)) - 1.0_dp) < 1e-14_dp, 'pyramid z axis is the coordinate z')

    ! Rotation (x, y, z) -> (z, y, -x) plus a far translation: apex now along +x.
    rotated(1, :) = centres(3, :) + 1.0e6_dp
    rotated(2, :) = centres(2, :) - 3.0e5_dp
    rotated(3, :) = -centres(1, :) + 7.0_dp
    call compute_body_frame(rotated, frame, err)
    call check(suite, frame%paper_class, 'rotated pyramid is of the paper class')
    call check(suite, abs(abs(frame%axes(1, 3)) - 1.0_dp) < 1e-14_dp, 'rotated pyramid z axis along coordinate x')
    call check_close(suite, frame%centre_of_mass(1), 1.0e6_dp + 0.1_dp, 1e-15_dp, 'rotated centre of mass x')
    call check(suite, all(abs(frame%extent - [3.0_dp, 3.0_dp, 2.0_dp]) < 1e-9_dp), 'rotated extents 3, 3, 2')
  end subroutine test_wedge_frame

  !> The block partition covers 1..n once, in rank order.
  subroutine test_block_range()
    type(run_context_t) :: ctx
    integer(i8) :: first, count, n, expected_first
    integer :: r
    ctx = make_run_context(MPI_COMM_WORLD)
    ctx%n_ranks = 3   ! the partition itself, for 3 ranks whatever the actual count
    do n = 0, 7
      expected_first = 1
      do r = 0, ctx%n_ranks - 1
        ctx%rank = r
        call block_range(ctx, n, first, count)
        call check(suite, first == expected_first, 'block of rank ' // char(48 + r) // ' starts after the previous')
        call check(suite, abs(count - n / 3) <= 1, 'blocks differ by at most one item')
        expected_first = first + count
      end do
      call check(suite, expected_first == n + 1, 'blocks cover all items')
    end do
  end subroutine test_block_range

  !> beads_within against the distance to every bead: lattice beads (centres on cell borders)
  !> and a random cloud, query points on and off the beads, radii below, at and above a cell.
  subroutine test_beads_within()
    type(error_t) :: err
    type(spatial_index_t) :: index
    real(dp) :: centres(3, 400), point(3), radius
    real(dp), parameter :: radii(5) = [1.0e-6_dp, 0.5_dp, 1.0_dp, 1.7_dp, 3.2_dp]
    integer(i8), allocatable :: found(:)
    integer(i8) :: n_found, b
    integer :: set, q, r, i, mismatches
    logical :: expected(400), got(400)
    mismatches = 0
    do set = 1, 2
      if (set == 1) then
        do i = 1, 400   ! a 10 x 8 x 5 block of the unit lattice, shifted off the origin
          centres(:, i) = [real(mod(i - 1, 10), dp), real(mod((i - 1) / 10, 8), dp), real((i - 1) / 80, dp)] - 3.0_dp
        end do
      else
        call random_number(centres)
        centres = 7.0_dp * centres - 2.0_dp
      end if
      call build_spatial_index(centres, index, err)
      do q = 1, 60
        if (q <= 30) then
          point = centres(:, 13 * q)
        else
          call random_number(point)
          point = 9.0_dp * point - 3.0_dp
        end if
        do r = 1, size(radii)
          radius = radii(r)
          expected = norm2(centres - spread(point, 2, 400), dim=1) < radius
          call beads_within(index, centres, point, radius, found, n_found)
          got = .false.
          do b = 1, n_found
            got(found(b)) = .true.
          end do
          if (any(expected .neqv. got) .or. n_found /= count(got)) mismatches = mismatches + 1
        end do
      end do
    end do
    call check(suite, .not. err%failed .and. mismatches == 0, 'beads_within finds exactly the beads closer than the ' // &
               'radius (600 queries against every bead)')
  end subroutine test_beads_within

end program test_geometry
