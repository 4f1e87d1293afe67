!> operator_check: the FFT operator (src/operators/fft_operator.F90) against the direct operator
!> (bead_operator.F90) on a real bead model. Reads a beadmob input file, builds the
!> model and the basis (L, L2 from &hydrodynamics, else L = 2, L2 = 0), both operators, applies
!> both to 3 random vectors and prints the max-norm relative difference of each product and the
!> set-up and median product wall times (max over ranks). Exits with status 1 when a difference
!> exceeds 1e-12 (or on any error). Run by bench/operator_check/operator_check.sh.
!> Usage: [mpirun -n P] operator_check INPUT.nml [-repeats R] [-fft_planner measure|estimate] [-tolerance T]
!> (R rounds of the 3 products, default 1; T default 1e-12)
program operator_check
#include "petsc/finclude/petscmat.h"
  use petscmat
  use, intrinsic :: iso_fortran_env, only: error_unit
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t, make_run_context, agree_on_error, broadcast_text, block_range
  use beadmob_input_config, only: run_config_t, parse_input_text
  use beadmob_bead_model, only: bead_model_t
  use beadmob_shape_catalog, only: build_bead_model
  use beadmob_geometry_checks, only: check_bead_model
  use beadmob_run, only: read_input_file
  use beadmob_multipole_basis, only: multipole_basis_t, make_multipole_basis
  use beadmob_bead_operator, only: bead_operator_t, create_bead_operator, destroy_bead_operator
  use beadmob_fft_operator, only: fft_operator_t, create_fft_operator, destroy_fft_operator
  use beadmob_command_line, only: read_command_line
  use beadmob_job_plan, only: choose_operator, operator_spans
  use beadmob_job_estimate, only: job_estimate_t, estimate_job
  use beadmob_friction_settings, only: friction_settings_t
  use beadmob_random_vectors, only: fill_random
  implicit none

  integer, parameter :: n_vectors = 3
  real(dp) :: tolerance = 1.0e-12_dp
  PetscErrorCode :: ierr
  type(run_context_t) :: ctx
  type(error_t) :: err
  type(run_config_t) :: config
  type(bead_model_t) :: model
  type(multipole_basis_t) :: basis
  type(bead_operator_t), target :: direct
  type(fft_operator_t), target :: fast
  Mat :: direct_matrix, fft_matrix
  Vec :: x(n_vectors), y_direct(n_vectors), y_fft(n_vectors), work
  PetscBool :: found
  PetscInt :: repeats_option
  PetscReal :: tolerance_option
  integer(i8) :: first, count, n_beads
  integer :: order, potential_order, repeats, round, v, padded(3)
  real(dp) :: start, direct_setup, fft_setup, reference, difference(n_vectors), model_ratio
  type(friction_settings_t) :: auto_settings
  real(dp), allocatable :: direct_times(:), fft_times(:)
  character(len=4096) :: input_path
  character(len=:), allocatable :: text
  character(len=16) :: chosen
  logical :: direct_made, fft_made

  PetscCallA(PetscInitialize(ierr))
  ctx = make_run_context(PETSC_COMM_WORLD)
  direct_made = .false.
  fft_made = .false.

  ! The input file first, PETSc options after it (as for beadmob).
  input_path = ''
  if (command_argument_count() >= 1) call get_command_argument(1, input_path)
  if (len_trim(input_path) == 0 .or. input_path(1:1) == '-') then
    call raise(err, 'usage: operator_check INPUT.nml [-repeats R] [-fft_planner measure|estimate] [-tolerance T]')
    call finish()
  end if
  repeats = 1
  PetscCallA(PetscOptionsGetInt(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-repeats', repeats_option, found, ierr))
  if (found) repeats = max(1, int(repeats_option))
  ! -tolerance: only to exercise the failure exit (default 1e-12, the check's bound).
  PetscCallA(PetscOptionsGetReal(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-tolerance', tolerance_option, found, ierr))
  if (found) tolerance = tolerance_option

  ! The model exactly as beadmob builds it: rank 0 reads, every rank parses the same text.
  text = ''
  if (ctx%rank == 0) call read_input_file(trim(input_path), text, err)
  call agree_on_error(ctx, err)
  if (err%failed) call finish()
  call broadcast_text(ctx, text)
  call parse_input_text(text, trim(input_path), config, err)
  ! -fft_planner exactly as beadmob reads it ('auto' by default: without a table cache, as here,
  ! FFTW's estimated plans, as a job makes them; friction_job.F90).
  if (.not. err%failed) call read_command_line(config, err)
  if (err%failed) call finish()
  associate (planner => config%hydrodynamics%fft_planner)
    if (planner /= 'measure' .and. planner /= 'estimate' .and. planner /= 'auto') &
      call raise(err, "-fft_planner must be 'measure', 'estimate' or 'auto', got '" // trim(planner) // "'")
  end associate
  if (err%failed) call finish()
  call build_bead_model(ctx, config%shape, model, err)
  call agree_on_error(ctx, err)
  if (err%failed) call finish()
  call check_bead_model(model, config%overlap_tolerance, err)
  if (err%failed) call finish()

  order = 2
  potential_order = 0
  if (config%hydrodynamics%enabled) then
    order = config%hydrodynamics%multipole_order
    potential_order = config%hydrodynamics%potential_order
  end if
  basis = make_multipole_basis(order, potential_order)
  n_beads = size(model%centres, 2, kind=i8)
  call block_range(ctx, n_beads, first, count)

  ! Set-up times include each operator's own block table (no table cache: both pay for it).
  start = synchronised_time()
  call create_bead_operator(ctx%comm, basis, model%centres, first, count, direct, direct_matrix, err)
  call agree_on_error(ctx, err)
  if (err%failed) call finish()
  direct_made = .true.
  direct_setup = elapsed_max(start)

  fast%measure_plans = config%hydrodynamics%fft_planner == 'measure'
  start = synchronised_time()
  call create_fft_operator(ctx%comm, basis, model%centres, first, count, fast, fft_matrix, err)
  call agree_on_error(ctx, err)
  if (err%failed) call finish()
  fft_made = .true.
  fft_setup = elapsed_max(start)
  ! The padded box in lattice axes x, y, z (the operator stores it in FFT dimension order).
  padded(fast%axes) = fast%box

  do v = 1, n_vectors
    PetscCallA(MatCreateVecs(direct_matrix, x(v), y_direct(v), ierr))
    PetscCallA(VecDuplicate(x(v), y_fft(v), ierr))
    call fill_random(x(v), v, 20240501_i8)
  end do
  PetscCallA(VecDuplicate(x(1), work, ierr))

  ! Alternating products: both operators see the same load of the shared machine.
  allocate (direct_times(repeats * n_vectors), fft_times(repeats * n_vectors))
  do round = 1, repeats
    do v = 1, n_vectors
      start = synchronised_time()
      PetscCallA(MatMult(direct_matrix, x(v), y_direct(v), ierr))
      direct_times((round - 1) * n_vectors + v) = elapsed_max(start)
      start = synchronised_time()
      PetscCallA(MatMult(fft_matrix, x(v), y_fft(v), ierr))
      fft_times((round - 1) * n_vectors + v) = elapsed_max(start)
    end do
  end do

  do v = 1, n_vectors
    PetscCallA(VecNorm(y_direct(v), NORM_INFINITY, reference, ierr))
    PetscCallA(VecWAXPY(work, -1.0_dp, y_direct(v), y_fft(v), ierr))
    PetscCallA(VecNorm(work, NORM_INFINITY, difference(v), ierr))
    difference(v) = difference(v) / max(reference, tiny(1.0_dp))
  end do

  ! The cost model that choose_operator (job_plan.f90) compares, for comparison with the timings:
  ! its product times of both operators on all the model's beads (whole-box FFT products, as here),
  ! and the operator it picks for the job.
  model_ratio = product_seconds('direct') / product_seconds('fft')
  auto_settings = config%hydrodynamics
  auto_settings%operator_name = 'auto'
  call choose_operator(auto_settings, model%centres, ctx%n_ranks, 6, .false., chosen, err)

  if (ctx%rank == 0) call report()
  ! Written so that a NaN product fails too.
  if (any(.not. (difference <= tolerance))) &
    call raise(err, 'FFT and direct products differ by ' // str(maxval(difference)) // &
               ' relative (max-norm), more than ' // str(tolerance))

  do v = 1, n_vectors
    PetscCallA(VecDestroy(x(v), ierr))
    PetscCallA(VecDestroy(y_direct(v), ierr))
    PetscCallA(VecDestroy(y_fft(v), ierr))
  end do
  PetscCallA(VecDestroy(work, ierr))
  call finish()

contains

  !> One product's seconds by the dry run's cost model (job_estimate.f90), six vectors batched.
  real(dp) function product_seconds(operator_name)
    character(len=*), intent(in) :: operator_name
    type(job_estimate_t) :: e
    e = estimate_job(n_beads, n_beads, operator_spans(model%centres, operator_name, config%hydrodynamics), .true., &
                     order, potential_order, operator_name, ctx%n_ranks, 6, .false., 1.0_dp, .false.)
    product_seconds = e%seconds_solve
  end function product_seconds

  subroutine report()
    character(len=*), parameter :: fmt_time = '(a, f9.4, a, f9.4, a)'
    write (*, '(a)') 'operator_check: ' // trim(input_path) // ', shape ' // model%shape_name
    write (*, '(a)') '  beads N:              ' // str(n_beads)
    write (*, '(a)') '  basis:                L = ' // str(order) // ', L2 = ' // str(potential_order) // ', ' // &
      str(basis%size) // ' unknowns per bead'
    write (*, '(a)') '  ranks:                ' // str(ctx%n_ranks)
    write (*, '(a)') '  padded FFT box:       ' // str(padded(1)) // ' x ' // str(padded(2)) // ' x ' // &
      str(padded(3)) // ' (FFTW planner ' // trim(config%hydrodynamics%fft_planner) // ')'
    do v = 1, n_vectors
      write (*, '(a, es10.3)') '  vector ' // str(v) // ': max|y_fft - y_direct| / max|y_direct| =', difference(v)
    end do
    write (*, fmt_time) '  set-up (s):           direct ', direct_setup, ', FFT ', fft_setup, &
      ' (each with its own block table)'
    write (*, fmt_time) '  product (s, median):  direct ', median(direct_times), ', FFT ', median(fft_times), &
      ' (' // str(size(direct_times)) // ' products each)'
    write (*, '(a, f8.2)') '  ratio direct/FFT:     ', median(direct_times) / median(fft_times)
    write (*, '(a, f8.2, a)') '  cost model:           direct/FFT product ', model_ratio, &
      ', auto chooses ' // trim(chosen)
    ! One line for bench/operator_check/operator_check.sh.
    write (*, '(a, *(g0))') 'summary shape=', model%shape_name, ' n=', n_beads, ' box=', padded(1), 'x', padded(2), &
      'x', padded(3), ' ranks=', ctx%n_ranks, ' max_difference=', maxval(difference), ' direct_product=', &
      median(direct_times), ' fft_product=', median(fft_times), ' direct_setup=', direct_setup, ' fft_setup=', &
      fft_setup, ' model_ratio=', model_ratio, ' auto=', trim(chosen)
  end subroutine report

  !> Destroys what exists, finalises PETSc and stops (status 1 on error, message from rank 0).
  subroutine finish()
    if (fft_made) call destroy_fft_operator(fast, fft_matrix)
    if (direct_made) call destroy_bead_operator(direct, direct_matrix)
    if (err%failed .and. ctx%rank == 0) write (error_unit, '(a)') 'operator_check: error: ' // err%message
    PetscCallA(PetscFinalize(ierr))
    if (err%failed) stop 1, quiet=.true.
    stop
  end subroutine finish

  !> MPI_Wtime after a barrier: every rank starts the clock together.
  real(dp) function synchronised_time()
    PetscErrorCode :: ierr_local
    call MPI_Barrier(ctx%comm, ierr_local)
    synchronised_time = MPI_Wtime()
  end function synchronised_time

  !> Seconds since `since`, the largest over the ranks (the slowest rank sets the pace).
  real(dp) function elapsed_max(since)
    real(dp), intent(in) :: since
    real(dp) :: local
    PetscErrorCode :: ierr_local
    local = MPI_Wtime() - since
    call MPI_Allreduce(local, elapsed_max, 1, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr_local)
  end function elapsed_max

  pure real(dp) function median(values)
    real(dp), intent(in) :: values(:)
    real(dp) :: sorted(size(values)), swap
    integer :: i, j, n
    sorted = values
    n = size(sorted)
    do i = 2, n
      swap = sorted(i)
      j = i - 1
      do while (j >= 1)
        if (sorted(j) <= swap) exit
        sorted(j + 1) = sorted(j)
        j = j - 1
      end do
      sorted(j + 1) = swap
    end do
    if (mod(n, 2) == 1) then
      median = sorted((n + 1) / 2)
    else
      median = 0.5_dp * (sorted(n / 2) + sorted(n / 2 + 1))
    end if
  end function median
end program operator_check
