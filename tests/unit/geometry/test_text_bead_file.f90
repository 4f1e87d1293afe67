!> Tests src/geometry/text_bead_file.f90; also src/geometry/hdf5_bead_file.f90 (read back from a
!> result file written by src/output/result_file.f90).
!> CTest: test_bead_files_np1 and test_bead_files_np2 (the program keeps the test's name, test_bead_files).
!> Bead files: text parsing with line numbers, and the HDF5 round trip through a result file
!> written collectively (on 2 ranks each rank writes its own block of beads).
program test_bead_files
  use mpi, only: MPI_COMM_WORLD, MPI_Barrier
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t
  use beadmob_parallel, only: run_context_t, make_run_context
  use beadmob_input_config, only: run_config_t, parse_input_text
  use beadmob_bead_model, only: bead_model_t
  use beadmob_body_frame, only: body_frame_t, compute_body_frame
  use beadmob_text_bead_file, only: read_text_bead_file
  use beadmob_hdf5_bead_file, only: read_hdf5_bead_file, is_hdf5_file
  use beadmob_result_file, only: write_result_file
  use beadmob_testing
  implicit none
  type(test_suite_t) :: suite
  type(run_context_t) :: ctx

  suite = start_tests('test_bead_files')
  ctx = make_run_context(MPI_COMM_WORLD)
  call test_text_file()
  call test_hdf5_round_trip()
  call finish_tests(suite)

contains

  subroutine write_text(path, lines)
    character(len=*), intent(in) :: path, lines(:)
    integer :: unit, i
    open (newunit=unit, file=path, status='replace', action='write')
    do i = 1, size(lines)
      write (unit, '(a)') trim(lines(i))
    end do
    close (unit)
  end subroutine write_text

  subroutine test_text_file()
    type(error_t) :: err
    real(dp), allocatable :: centres(:, :)
    integer, allocatable :: lines(:)
    character(len=:), allocatable :: path
    path = 'text_beads_rank' // achar(48 + ctx%rank) // '.txt'
    call write_text(path, [character(len=40) :: '# header', '1 2 3', '', '  4.5,-6,7e1  # comment', &
                           '8' // achar(9) // '9 10'])
    call read_text_bead_file(path, centres, lines, err)
    call check(suite, .not. err%failed, 'text bead file reads')
    call check_equal(suite, size(centres, 2), 3, 'three beads read')
    call check(suite, all(centres(:, 2) == [4.5_dp, -6.0_dp, 70.0_dp]), 'commas, exponents, trailing comment')
    call check(suite, all(centres(:, 3) == [8.0_dp, 9.0_dp, 10.0_dp]), 'tab separated')
    call check(suite, all(lines == [2, 4, 5]), 'source line numbers kept')
    call check(suite, .not. is_hdf5_file(path), 'a text file is not taken for HDF5')

    call write_text(path, [character(len=40) :: '1 2 3', '1 2 3 4'])
    call read_text_bead_file(path, centres, lines, err)
    call check(suite, err%failed, 'four numbers on a line rejected')
    if (err%failed) call check(suite, index(err%message, path // ' line 2: expected 3 numbers "x y z", found 4') > 0, &
                               'message names file, line and count: ' // err%message)
  end subroutine test_text_file

  subroutine test_hdf5_round_trip()
    type(error_t) :: err
    type(run_config_t) :: config
    type(bead_model_t) :: model
    type(body_frame_t) :: frame
    real(dp), allocatable :: read_back(:, :)
    integer :: i, ierr

    call parse_input_text("&run output = 'round_trip.h5' /" // new_line('a') // "&shape name = 'bead_file' /", &
                          'test', config, err)
    model%shape_name = 'bead_file'
    model%source = 'test'
    model%reference_length = 7.0_dp
    allocate (model%parameters(0))
    allocate (model%centres(3, 7))
    do i = 1, 7
      model%centres(:, i) = [real(i, dp), 0.5_dp * i, -real(i, dp)**2]
    end do
    call compute_body_frame(model%centres, frame, err)
    call write_result_file(ctx, config, model, frame, err)
    call check(suite, .not. err%failed, 'result file written collectively')
    call MPI_Barrier(ctx%comm, ierr)
    call check(suite, is_hdf5_file('round_trip.h5'), 'result file is HDF5')
    call read_hdf5_bead_file('round_trip.h5', '/geometry/positions', read_back, err)
    call check(suite, .not. err%failed, 'positions read back')
    if (.not. err%failed) call check(suite, all(read_back == model%centres), 'positions round trip bit for bit')
    call read_hdf5_bead_file('round_trip.h5', '/no/such/dataset', read_back, err)
    call check(suite, err%failed .and. index(err%message, "no dataset '/no/such/dataset'") > 0, &
               'missing dataset named in the message')
  end subroutine test_hdf5_round_trip
end program test_bead_files
