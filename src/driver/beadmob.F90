!> beadmob: Stokes mobility of rigid bead models.
!> Usage: beadmob [input.nml] [PETSc options]   (mpirun -n P beadmob ... for P ranks)
program beadmob
#include "petsc/finclude/petscsys.h"
  use petscsys
  use, intrinsic :: iso_fortran_env, only: error_unit
  use beadmob_errors, only: error_t
  use beadmob_parallel, only: run_context_t, make_run_context
  use beadmob_build_info, only: program_version, git_hash
  use beadmob_run, only: run_beadmob
  implicit none
  PetscErrorCode :: ierr
  type(run_context_t) :: ctx
  type(error_t) :: err
  character(len=4096) :: input_path
  character(len=64) :: first_argument

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
  ! The input file, when given, is the first argument (after --estimate); PETSc options follow.
  input_path = ''
  if (command_argument_count() >= 1) then
    call get_command_argument(1, input_path)
    if (input_path == '--estimate' .and. command_argument_count() >= 2) call get_command_argument(2, input_path)
    if (input_path(1:1) == '-') input_path = ''
  end if

  call run_beadmob(ctx, trim(input_path), err)

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
      end if
      if (argument(1:10) /= '--accuracy') cycle
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

  subroutine print_usage()
    write (*, '(a)') 'usage: beadmob [--estimate] [INPUT.nml] [PETSc options]', &
      '       mpirun -n P beadmob [INPUT.nml] [PETSc options]', &
      '', &
      'Builds the bead model described by INPUT.nml (Fortran namelists &run, &shape and, for the', &
      'friction and mobility, &hydrodynamics; see README.md) and writes the result file named by', &
      '&run output. Without INPUT.nml: the built-in default job, the paper''s cone and its mobility', &
      'at multipole order 2, written to beadmob_result.h5.', &
      '', &
      'Options of beadmob (after INPUT.nml):', &
      '  -operator direct|fft|pfft|auto  the bead operator (default auto: the faster one for the job)', &
      '  -pfft_near_radius R, -pfft_stencil S  off-lattice far field: exact pairs within R (d,', &
      '                              default 3), interpolation on S^3 grid points (default 4)', &
      '  -fft_planner measure|estimate  FFTW plans: measured (default, faster) or reproducible', &
      '  -near_field_radius R        pairs within R (d) in the preconditioning matrix (default 0)', &
      '  -near_field_cluster C       and pairs within the same C x C x C cube of lattice cells', &
      '  -geometry_only              build and check the bead model, skip &hydrodynamics', &
      '  --estimate (or -estimate)   dry run: bead count, unknowns, FFT box, memory per rank and', &
      '                              expected time of the job, nothing built (beadmob --estimate IN.nml)', &
      '  -estimate_ranks P           the estimate for P ranks (default: the ranks of the run)', &
      '  -quiet                      no progress lines (also &run progress = .false.)', &
      '  -memory_limit G             GiB a rank may use (default: what the node has available,', &
      '                              shared by its ranks); a job estimated above it is refused', &
      '  -accuracy E (or --accuracy E)  the cheapest settings that the benchmark data say reach a', &
      '                              relative error E of the mobility coefficients (bench/accuracy.md)', &
      'PETSc options (-log_view, -ksp_type, -ksp_rtol, -pc_type, ...) are passed to PETSc.'
  end subroutine print_usage
end program beadmob
