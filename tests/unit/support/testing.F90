!> A small assertion module for beadmob's Fortran test programs (pFUnit is not available).
!> Each test program: call start_tests('name'), then check_*(...), then call finish_tests()
!> (programs that initialise PETSc call PetscFinalize after finish_tests).
!> Failures are counted on every rank and summed, so a test fails if any rank fails.
module beadmob_testing
  use mpi
  use, intrinsic :: iso_fortran_env, only: error_unit
  use beadmob_kinds, only: dp, i8
  use beadmob_strings, only: str
  implicit none
  private
  public :: test_suite_t, start_tests, finish_tests, check, check_close, check_equal

  type :: test_suite_t
    character(len=:), allocatable :: name
    integer :: n_checks = 0
    integer :: n_failed = 0
    integer :: rank = 0
    integer :: n_ranks = 1
    !> MPI was started here (not by PETSc), so finish_tests ends it.
    logical :: owns_mpi = .false.
  end type test_suite_t

  interface check_equal
    module procedure check_equal_int, check_equal_int8, check_equal_text
  end interface check_equal

contains

  function start_tests(name) result(suite)
    character(len=*), intent(in) :: name
    type(test_suite_t) :: suite
    integer :: ierr
    logical :: already
    call MPI_Initialized(already, ierr)
    if (.not. already) call MPI_Init(ierr)
    suite%owns_mpi = .not. already
    suite%name = name
    call MPI_Comm_rank(MPI_COMM_WORLD, suite%rank, ierr)
    call MPI_Comm_size(MPI_COMM_WORLD, suite%n_ranks, ierr)
  end function start_tests

  subroutine check(suite, condition, description)
    type(test_suite_t), intent(inout) :: suite
    logical, intent(in) :: condition
    character(len=*), intent(in) :: description
    suite%n_checks = suite%n_checks + 1
    if (condition) return
    suite%n_failed = suite%n_failed + 1
    write (error_unit, '(a)') 'FAILED [rank ' // str(suite%rank) // '] ' // description
  end subroutine check

  !> |actual - expected| <= tolerance * max(|expected|, tiny): a relative check.
  subroutine check_close(suite, actual, expected, tolerance, description)
    type(test_suite_t), intent(inout) :: suite
    real(dp), intent(in) :: actual, expected, tolerance
    character(len=*), intent(in) :: description
    call check(suite, abs(actual - expected) <= tolerance * max(abs(expected), tiny(1.0_dp)), &
               description // ': got ' // str(actual) // ', expected ' // str(expected))
  end subroutine check_close

  subroutine check_equal_int(suite, actual, expected, description)
    type(test_suite_t), intent(inout) :: suite
    integer, intent(in) :: actual, expected
    character(len=*), intent(in) :: description
    call check(suite, actual == expected, description // ': got ' // str(actual) // ', expected ' // str(expected))
  end subroutine check_equal_int

  subroutine check_equal_int8(suite, actual, expected, description)
    type(test_suite_t), intent(inout) :: suite
    integer(i8), intent(in) :: actual, expected
    character(len=*), intent(in) :: description
    call check(suite, actual == expected, description // ': got ' // str(actual) // ', expected ' // str(expected))
  end subroutine check_equal_int8

  subroutine check_equal_text(suite, actual, expected, description)
    type(test_suite_t), intent(inout) :: suite
    character(len=*), intent(in) :: actual, expected
    character(len=*), intent(in) :: description
    call check(suite, actual == expected, description // ": got '" // actual // "', expected '" // expected // "'")
  end subroutine check_equal_text

  subroutine finish_tests(suite)
    type(test_suite_t), intent(inout) :: suite
    integer :: total_failed, ierr
    call MPI_Allreduce(suite%n_failed, total_failed, 1, MPI_INTEGER, MPI_SUM, MPI_COMM_WORLD, ierr)
    if (suite%rank == 0) write (*, '(a)') suite%name // ': ' // str(suite%n_checks) // ' checks per rank, ' // &
      str(total_failed) // ' failed on ' // str(suite%n_ranks) // ' rank(s)'
    if (suite%n_checks == 0 .and. suite%rank == 0) write (error_unit, '(a)') 'FAILED: the test made no checks'
    if (suite%owns_mpi) call MPI_Finalize(ierr)
    if (total_failed > 0 .or. suite%n_checks == 0) error stop 1
  end subroutine finish_tests
end module beadmob_testing
