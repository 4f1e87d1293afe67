!> beadmob: Stokes mobility of rigid bead models.
!> Usage: beadmob [options] [input.nml] [options]   (mpirun -n P beadmob ... for P ranks)
program beadmob
#include "petsc/finclude/petscsys.h"
  use petscsys
  use, intrinsic :: iso_fortran_env, only: error_unit
  use beadmob_errors, only: error_t
  use beadmob_parallel, only: run_context_t, make_run_context
  use beadmob_build_info, only: program_version, git_hash
  use beadmob_run, only: run_beadmob
  use beadmob_command_line, only: print_usage, check_command_line, find_input_argument
  implicit none
  PetscErrorCode :: ierr
  type(run_context_t) :: ctx
  type(error_t) :: err
  character(len=64) :: first_argument
  character(len=:), allocatable :: input_path

  first_argument = ''
  if (command_argument_count() >= 1) call get_command_argument(1, first_argument)
  if (first_argument == '--help' .or. first_argument == '-h') then
    call print_usage()
    stop
  else if (first_argument == '--version') then
    write (*, '(a)') 'beadmob ' // program_version // ' (' // git_hash // ')'
    stop
  end if

  PetscCallA(PetscInitialize(ierr))
  call accept_long_options()
  ctx = make_run_context(PETSC_COMM_WORLD)
  ! The same arguments on every rank: the same verdict everywhere.
  call check_command_line(err)
  if (.not. err%failed) call find_input_argument(input_path, err)
  if (.not. err%failed) call run_beadmob(ctx, input_path, err)

  if (err%failed .and. ctx%rank == 0) write (error_unit, '(a)') 'beadmob: error: ' // err%message
  PetscCallA(PetscFinalize(ierr))
  if (err%failed) stop 1, quiet=.true.

contains

  !> --accuracy X and --accuracy=X (the GNU spelling) mean PETSc's -accuracy X, which PETSc
  !> itself would not see; --estimate means -estimate (the dry run).
  subroutine accept_long_options()
    character(len=256) :: argument, value
    integer :: k, equals
    do k = 1, command_argument_count()
      call get_command_argument(k, argument)
      if (argument == '--estimate') then
        PetscCallA(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-estimate', PETSC_NULL_CHARACTER, ierr))
        call mark_used(trim(argument))
      end if
      if (argument(1:10) /= '--accuracy') cycle
      call mark_used(trim(argument))
      equals = index(argument, '=')
      value = ''
      if (equals > 0) then
        value = argument(equals + 1:)
      else if (k < command_argument_count()) then
        call get_command_argument(k + 1, value)
      end if
      PetscCallA(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-accuracy', trim(value), ierr))
    end do
  end subroutine accept_long_options

  !> PETSc keeps a long option under its own name too: read it, so that it counts as used.
  subroutine mark_used(name)
    character(len=*), intent(in) :: name
    PetscBool :: found
    PetscCallA(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, name, found, ierr))
  end subroutine mark_used

end program beadmob
