!> beadmob's command line: its own options in one table (name, argument, kind, help), from which
!> the options are read into the run's settings (read_command_line, one place), the usage text is
!> written and a misspelt beadmob option is refused before anything runs; after a run, the options
!> that nothing used (PETSc's or beadmob's) are named in a warning.
module beadmob_command_line
#include "petsc/finclude/petscsys.h"
  use petscsys
  use, intrinsic :: iso_c_binding, only: c_ptr, c_int, c_int64_t, c_char, c_null_ptr, c_f_pointer, c_associated
  use, intrinsic :: iso_fortran_env, only: error_unit, output_unit
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: lower_case
  use beadmob_input_config, only: run_config_t
  use beadmob_friction_settings, only: friction_settings_t
  implicit none
  private
  public :: print_usage, check_command_line, read_command_line, warn_unused_options, find_input_argument

#if defined(PETSC_USE_64BIT_INDICES)
  integer, parameter :: c_petsc_int = c_int64_t
#else
  integer, parameter :: c_petsc_int = c_int
#endif

  !> What an option's value is: none (a switch), a word, a real or an integer number.
  integer, parameter :: switch = 0, word = 1, real_number = 2, integer_number = 3

  type :: option_t
    character(len=20) :: name       ! without the leading '-'
    character(len=22) :: argument   ! '' for a switch
    integer :: kind                 ! switch, word, real_number or integer_number
    character(len=160) :: help
  end type option_t

  !> Every option beadmob reads; store_option says where each one goes.
  type(option_t), parameter :: options(22) = [ &
    option_t('operator', 'direct|fft|pfft|auto', word, 'the bead operator (default auto: the faster one for the job)'), &
    option_t('pfft_near_radius', 'R', real_number, 'off-lattice far field: pairs within R (d) exact (default 3)'), &
    option_t('pfft_stencil', 'S', integer_number, 'off-lattice far field: interpolation on S^3 grid points (default 4)'), &
    option_t('operator_error_rows', 'K', integer_number, 'off-lattice far field: its error measured on K exact rows ' // &
             '(default: all rows up to a budget, docs/theory.md T16)'), &
    option_t('fft_planner', 'auto|measure|estimate', word, 'FFTW plans: measured (faster products), estimated ' // &
             '(reproducible) or auto (default: measured when remembered with a table cache)'), &
    option_t('fft_whole_box', '', switch, 'FFT products on the whole padded box, not by mirror class of a ' // &
             'symmetric bead set (a comparison)'), &
    option_t('replicate_products', 'yes|no', word, 'the operator whole on every rank, a batch of products ' // &
             'dealt out to the ranks (default no; for small boxes on many ranks)'), &
    option_t('solve_apart', '', switch, 'solve the motions one KSPSolve after another (KSP monitors apply) ' // &
             'instead of together'), &
    option_t('solve_undeflated', '', switch, 'solve the motions together without their coarse space (the ' // &
             'preconditioned right-hand sides, deflation_space.F90; a comparison)'), &
    option_t('near_field_radius', 'R', real_number, 'pairs within R (d) in the preconditioning matrix (default 0)'), &
    option_t('near_field_cluster', 'C', integer_number, 'and pairs within the same C x C x C cube of lattice cells'), &
    option_t('geometry_only', '', switch, 'build and check the bead model, skip &hydrodynamics'), &
    option_t('estimate', '', switch, 'dry run (also --estimate): bead count, unknowns, FFT box, memory per rank ' // &
             'and expected time of the job, nothing built'), &
    option_t('estimate_ranks', 'P', integer_number, 'the estimate for P ranks (default: the ranks of the run)'), &
    option_t('quiet', '', switch, 'no progress lines (also &run progress = .false.)'), &
    option_t('memory_limit', 'G', real_number, 'GiB a rank may use (default: what the node has available, shared ' // &
             'by its ranks); a job estimated above it is refused'), &
    option_t('accuracy', 'E', word, '(or --accuracy E) the cheapest settings that the benchmark data say reach a ' // &
             'relative error E of the mobility coefficients (bench/accuracy/accuracy.md)'), &
    option_t('stop_after_solves', 'K', integer_number, 'stop with an error once K solves (a continuum job: K ' // &
             'samples) are saved (a test of checkpoint and resume)'), &
    option_t('fill_samples', 'K', integer_number, 'a continuum job''s fill_budget buys exactly K control ' // &
             'samples, whatever the time (a test of its choices)'), &
    option_t('slow_samples', 'F', real_number, 'a continuum job''s samples after its pilot count F times ' // &
             'their time, as on a machine slowed down F times (a test of the budget''s checks)'), &
    option_t('keep_checkpoint', '', switch, 'a continuum job keeps its checkpoint of samples when it ' // &
             'finishes: rerun, it extrapolates them again without solving (a newer build''s estimate)'), &
    option_t('hdf5_error_stack', '', switch, 'print HDF5''s own error stack on a failed HDF5 call (debugging)')]
  !> Options written with two dashes that beadmob takes (--help, -h and --version are read first).
  character(len=*), parameter :: long_options(2) = [character(len=8) :: 'estimate', 'accuracy']

  interface
    integer(c_int) function petsc_options_left_get(petsc_options, n, names, values) &
        bind(c, name='PetscOptionsLeftGet')
      import :: c_int, c_ptr, c_petsc_int
      type(c_ptr), value :: petsc_options
      integer(c_petsc_int), intent(out) :: n
      type(c_ptr), intent(out) :: names
      type(c_ptr), value :: values
    end function petsc_options_left_get
    integer(c_int) function petsc_options_left_restore(petsc_options, n, names, values) &
        bind(c, name='PetscOptionsLeftRestore')
      import :: c_int, c_ptr, c_petsc_int
      type(c_ptr), value :: petsc_options
      integer(c_petsc_int), intent(inout) :: n
      type(c_ptr), intent(inout) :: names
      type(c_ptr), value :: values
    end function petsc_options_left_restore
    pure integer(c_int) function c_strlen(text) bind(c, name='strlen')
      import :: c_int, c_ptr
      type(c_ptr), value :: text
    end function c_strlen
  end interface

contains

  subroutine print_usage()
    integer :: k
    write (*, '(a)') 'usage: beadmob [options] [INPUT.nml] [options]', &
      '       mpirun -n P beadmob [options] [INPUT.nml] [options]', &
      '', &
      'Builds the bead model described by INPUT.nml (Fortran namelists &run, &shape and, for the', &
      'friction and mobility, &hydrodynamics; see README.md) and writes the result file named by', &
      '&run output. Without INPUT.nml: the built-in default job, the paper''s cone and its mobility', &
      'at multipole order 2, written to beadmob_result.h5.', &
      '', &
      'Options of beadmob (before or after INPUT.nml; a misspelt one is refused):'
    do k = 1, size(options)
      call print_option(options(k))
    end do
    write (*, '(a)') 'PETSc options (-log_view, -ksp_type, -ksp_rtol, -pc_type, ...) are passed to PETSc; an option', &
      'that nothing used is named in a warning at the end of the run.'
  end subroutine print_usage

  !> '  -name ARG' in a column of 30, the help wrapped beside it.
  subroutine print_option(option)
    type(option_t), intent(in) :: option
    integer, parameter :: column = 31, width = 100
    character(len=:), allocatable :: head, rest
    integer :: cut
    head = '  -' // trim(option%name)
    if (len_trim(option%argument) > 0) head = head // ' ' // trim(option%argument)
    rest = trim(option%help)
    if (len(head) >= column - 1) then
      write (*, '(a)') head
      head = ''
    end if
    do while (len(rest) > 0)
      cut = len(rest)
      if (cut > width - column) cut = index(rest(1:width - column + 1), ' ', back=.true.) - 1
      write (*, '(a)') head // repeat(' ', column - 1 - len(head)) // rest(1:cut)
      head = ''
      rest = adjustl(rest(cut + 1:))
      rest = trim(rest)
    end do
  end subroutine print_option

  !> Collective (the same arguments on every rank). The input file named on the command line
  !> ('' for none): the one argument that is neither an option nor an option's value, wherever it
  !> stands. beadmob's options take a value by their table (`switch` none); a PETSc option takes
  !> the next word as its value unless that word ends in .nml or names an existing file (then it
  !> is the input, and PETSc's record of it as the option's value is undone). Two such words are
  !> an error naming both, before anything runs.
  subroutine find_input_argument(path, err)
    character(len=:), allocatable, intent(out) :: path
    type(error_t), intent(inout) :: err
    character(len=4096) :: argument
    character(len=:), allocatable :: previous_option
    logical :: takes_value, value_given
    integer :: k
    PetscErrorCode :: ierr
    path = ''
    previous_option = ''
    takes_value = .false.
    do k = 1, command_argument_count()
      call get_command_argument(k, argument)
      if (is_option(argument)) then
        call option_value_rule(trim(argument), takes_value, value_given)
        if (value_given) takes_value = .false.
        previous_option = option_name(trim(argument))
        cycle
      end if
      if (takes_value) then
        takes_value = .false.
        if (.not. is_petsc_option(previous_option)) cycle
        if (.not. looks_like_input(trim(argument))) cycle
        ! A PETSc option followed by the input file: PETSc took the file for its value.
        PetscCallA(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-' // previous_option, PETSC_NULL_CHARACTER, ierr))
      end if
      if (len(path) > 0) then
        call raise(err, "two input files on the command line (or a stray word), '" // path // "' and '" // &
                   trim(argument) // "': beadmob takes one input file; every other argument is an option or an " // &
                   "option's value")
        return
      end if
      path = trim(argument)
    end do

  contains

    !> Whether `option` (without dashes) is PETSc's, i.e. not in beadmob's table.
    logical function is_petsc_option(option)
      character(len=*), intent(in) :: option
      is_petsc_option = .not. (any(options%name == option) .or. any(long_options == option))
    end function is_petsc_option

    logical function looks_like_input(word)
      character(len=*), intent(in) :: word
      logical :: exists
      integer :: n_word
      n_word = len(word)
      looks_like_input = .false.
      if (n_word > 4) looks_like_input = lower_case(word(n_word - 3:)) == '.nml'
      if (.not. looks_like_input) then
        inquire (file=word, exist=exists)
        looks_like_input = exists
      end if
    end function looks_like_input
  end subroutine find_input_argument

  !> An option is an argument that starts with '-' and is not a negative number.
  pure logical function is_option(argument)
    character(len=*), intent(in) :: argument
    is_option = .false.
    if (len_trim(argument) < 2) return
    if (argument(1:1) /= '-') return
    is_option = verify(argument(2:2), '0123456789.') /= 0
  end function is_option

  !> The option's name without its dashes and without an '=value' part.
  pure function option_name(argument) result(name)
    character(len=*), intent(in) :: argument
    character(len=:), allocatable :: name
    name = argument(merge(3, 2, argument(2:2) == '-'):)
    if (index(name, '=') > 0) name = name(1:index(name, '=') - 1)
  end function option_name

  !> Whether the option `argument` takes the next argument as its value (beadmob's by their table;
  !> any other, PETSc's, may) and whether it carries its value itself (--accuracy=E).
  pure subroutine option_value_rule(argument, takes_value, value_given)
    character(len=*), intent(in) :: argument
    logical, intent(out) :: takes_value, value_given
    character(len=:), allocatable :: name
    integer :: k
    name = option_name(argument)
    value_given = index(argument, '=') > 0
    takes_value = .true.
    do k = 1, size(options)
      if (options(k)%name == name) takes_value = options(k)%kind /= switch
    end do
  end subroutine option_value_rule


  !> Every argument that is an option but not one of beadmob's is PETSc's, unless it is so close
  !> to one of beadmob's that it is a misspelling of it: then an error that names both, before
  !> anything runs (a misspelt PETSc option is caught by warn_unused_options at the end).
  subroutine check_command_line(err)
    type(error_t), intent(inout) :: err
    character(len=256) :: argument
    character(len=:), allocatable :: name
    integer :: k, nearest
    do k = 1, command_argument_count()
      call get_command_argument(k, argument)
      if (.not. is_option(argument)) cycle
      name = option_name(trim(argument))
      if (argument(2:2) == '-' .and. any(long_options == name)) cycle
      if (argument(2:2) /= '-' .and. any(options%name == name)) cycle
      nearest = nearest_option(name)
      if (nearest > 0) then
        call raise(err, "unknown option '" // trim(argument) // "': did you mean -" // trim(options(nearest)%name) // &
                   '? (beadmob --help lists the options)')
        return
      end if
    end do
  end subroutine check_command_line

  !> Every option of the table that is given, into `config` (store_option); PETSc's -ksp_rtol is
  !> noted too (it overrides the Krylov tolerance an accuracy target would choose). The same
  !> arguments on every rank: the same settings or error everywhere.
  subroutine read_command_line(config, err)
    type(run_config_t), intent(inout) :: config
    type(error_t), intent(inout) :: err
    character(len=256) :: value
    PetscBool :: found
    PetscErrorCode :: ierr
    PetscReal :: rtol
    integer :: k
    ! &run progress = .false. or -quiet silence the progress lines.
    config%hydrodynamics%progress = config%progress
    do k = 1, size(options)
      value = ''
      PetscCallA(PetscOptionsGetString(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-' // trim(options(k)%name), value, found, ierr))
      if (.not. found) cycle
      call store_option(options(k), trim(adjustl(value)), config, err)
      if (err%failed) return
    end do
    PetscCallA(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-ksp_rtol', found, ierr))
    config%hydrodynamics%krylov_rtol_on_command_line = found
    if (found) then
      PetscCallA(PetscOptionsGetReal(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-ksp_rtol', rtol, found, ierr))
      if (found) config%hydrodynamics%ksp_rtol_value = rtol
    end if
  end subroutine read_command_line

  !> The value of one given option, checked against its kind, where it belongs.
  subroutine store_option(option, value, config, err)
    type(option_t), intent(in) :: option
    character(len=*), intent(in) :: value
    type(run_config_t), intent(inout) :: config
    type(error_t), intent(inout) :: err
    real(dp) :: number
    integer :: whole, status
    number = 0.0_dp
    whole = 0
    status = 0
    select case (option%kind)
    case (real_number)
      if (.not. reads_as_real(value, number)) status = 1
    case (integer_number)
      read (value, *, iostat=status) whole
      if (verify(value, '0123456789+-') > 0) status = 1
    end select
    if (option%kind /= switch .and. option%kind /= word .and. (status /= 0 .or. len(value) == 0)) then
      if (option%kind == integer_number) then
        call raise(err, '-' // trim(option%name) // " needs a whole number, got '" // value // "'")
      else
        call raise(err, '-' // trim(option%name) // " needs a number, got '" // value // "'")
      end if
      return
    end if
    associate (job => config%hydrodynamics)
      select case (option%name)
      case ('operator')
        job%operator_name = value
      case ('pfft_near_radius')
        job%pfft_near_radius = number
        job%pfft_near_radius_given = .true.
      case ('pfft_stencil')
        job%pfft_stencil = whole
      case ('operator_error_rows')
        job%operator_error_rows = whole
        if (whole < 1) call raise(err, '-operator_error_rows must be at least 1, got ' // value)
      case ('fft_planner')
        job%fft_planner = value
      case ('fft_whole_box')
        job%fft_mirror_classes = .false.
      case ('replicate_products')
        job%replicate_products = value
      case ('solve_apart')
        job%solve_apart = .true.
      case ('solve_undeflated')
        job%deflation = .false.
      case ('near_field_radius')
        job%near_field_radius = number
      case ('near_field_cluster')
        job%near_field_cluster = whole
      case ('geometry_only')
        config%geometry_only = .true.
      case ('estimate')
        config%dry_run = .true.
      case ('estimate_ranks')
        config%estimate_ranks = whole
        if (whole < 1) call raise(err, '-estimate_ranks must be at least 1, got ' // value)
      case ('quiet')
        job%progress = .false.
      case ('memory_limit')
        config%memory_limit_gib = number
        if (.not. number > 0.0_dp) call raise(err, '-memory_limit must be a positive number of GiB per rank, got ' // value)
      case ('accuracy')
        call store_accuracy_target(value, job, err)
      case ('stop_after_solves')
        job%stop_after_solves = merge(whole, -1, whole >= 1)   ! the plan refuses -1
      case ('fill_samples')
        config%fill_samples = whole
        if (whole < 1) call raise(err, '-fill_samples must be at least 1, got ' // value)
      case ('slow_samples')
        config%slow_samples = number
        if (.not. number >= 1.0_dp) call raise(err, '-slow_samples must be at least 1, got ' // value)
      case ('keep_checkpoint')
        config%keep_checkpoint = .true.
      case ('hdf5_error_stack')
        config%hdf5_error_stack = .true.
      case default
        call raise(err, "internal: the option -" // trim(option%name) // " is in the table but stored nowhere")
      end select
    end associate
  end subroutine store_option

  !> -accuracy E: a relative error in (0, 1) (0 would read as "no target"); it replaces the input's.
  subroutine store_accuracy_target(value, job, err)
    character(len=*), intent(in) :: value
    type(friction_settings_t), intent(inout) :: job
    type(error_t), intent(inout) :: err
    real(dp) :: target
    if (.not. reads_as_real(value, target)) then
      call raise(err, "-accuracy needs a relative error between 0 and 1 (e.g. 1e-2), got '" // value // "'")
    else if (.not. (target > 0.0_dp .and. target < 1.0_dp)) then
      call raise(err, '-accuracy must be a relative error between 0 and 1 (e.g. 1e-2), got ' // value)
    else
      job%accuracy = target
      job%accuracy_on_command_line = .true.
    end if
  end subroutine store_accuracy_target

  !> Whether `text` is a real number (digits, point, exponent and signs only: list-directed input
  !> alone would also take 'T' or '1,2'), and its value.
  logical function reads_as_real(text, value)
    character(len=*), intent(in) :: text
    real(dp), intent(out) :: value
    integer :: status
    value = 0.0_dp
    read (text, *, iostat=status) value
    reads_as_real = status == 0 .and. len(text) > 0 .and. verify(text, '0123456789.eEdD+-') == 0
  end function reads_as_real

  !> The beadmob option that `name` is a misspelling of (0: none): at most one edit (a letter
  !> added, dropped, changed, or two swapped) for names up to 6 letters, two beyond.
  integer function nearest_option(name)
    character(len=*), intent(in) :: name
    integer :: k, distance, best
    nearest_option = 0
    best = huge(1)
    do k = 1, size(options)
      distance = edit_distance(name, trim(options(k)%name))
      if (distance < best) then
        best = distance
        nearest_option = k
      end if
    end do
    if (best > merge(1, 2, len(name) <= 6)) nearest_option = 0
  end function nearest_option

  !> Optimal string alignment distance (Levenshtein with adjacent transpositions), '-' and '_'
  !> counted as the same letter.
  pure integer function edit_distance(a, b)
    character(len=*), intent(in) :: a, b
    integer :: d(0:len(a), 0:len(b)), i, j, cost
    do i = 0, len(a)
      d(i, 0) = i
    end do
    do j = 0, len(b)
      d(0, j) = j
    end do
    do i = 1, len(a)
      do j = 1, len(b)
        cost = merge(0, 1, same_letter(a(i:i), b(j:j)))
        d(i, j) = min(d(i - 1, j) + 1, d(i, j - 1) + 1, d(i - 1, j - 1) + cost)
        if (i > 1 .and. j > 1) then
          if (same_letter(a(i:i), b(j - 1:j - 1)) .and. same_letter(a(i - 1:i - 1), b(j:j))) &
            d(i, j) = min(d(i, j), d(max(i - 2, 0), max(j - 2, 0)) + 1)
        end if
      end do
    end do
    edit_distance = d(len(a), len(b))
  end function edit_distance

  pure logical function same_letter(x, y)
    character, intent(in) :: x, y
    same_letter = x == y .or. (scan(x, '-_') > 0 .and. scan(y, '-_') > 0)
  end function same_letter

  !> Call on one rank at the end of a completed run: one warning line for every option in PETSc's
  !> table that nothing read (PETSc's options-left mechanism), e.g. a misspelt -ksp_tyep.
  subroutine warn_unused_options()
    type(c_ptr) :: names
    type(c_ptr), pointer :: name_list(:)
    integer(c_petsc_int) :: n
    integer :: k
    if (petsc_options_left_get(c_null_ptr, n, names, c_null_ptr) /= 0) return
    flush (output_unit)   ! after the run's summary, where a terminal shows both streams
    if (n > 0 .and. c_associated(names)) then
      call c_f_pointer(names, name_list, [n])
      do k = 1, int(n)
        write (error_unit, '(a)') "beadmob: warning: option '-" // c_text(name_list(k)) // &
          "' was given but nothing used it (misspelt? not for this job?)"
      end do
    end if
    if (petsc_options_left_restore(c_null_ptr, n, names, c_null_ptr) /= 0) return
  contains
    function c_text(pointer) result(value)
      type(c_ptr), intent(in) :: pointer
      character(len=:), allocatable :: value
      character(kind=c_char), pointer :: chars(:)
      integer :: length, i
      length = c_strlen(pointer)
      call c_f_pointer(pointer, chars, [length])
      allocate (character(len=length) :: value)
      do i = 1, length
        value(i:i) = chars(i)
      end do
    end function c_text
  end subroutine warn_unused_options
end module beadmob_command_line
