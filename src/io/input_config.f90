!> The run description: a Fortran namelist file (the ecosystem's native, dependency-free
!> key = value format, as used by many simulation codes), groups &run and &shape.
!> Every rank parses the same broadcast text, so all ranks hold the same configuration
!> and fail on the same error.
module beadmob_input_config
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_job_defaults, only: default_estimate_order, unset_real, unset_int, is_set
  use beadmob_friction_settings, only: friction_settings_t
  implicit none
  private
  public :: default_estimate_order, run_config_t, shape_config_t, continuum_settings_t, parse_input_text, effective_input_text, is_set, unset_real, unset_int
  public :: default_output_path, built_in_source

  character(len=*), parameter :: default_output_path = 'beadmob_result.h5'
  !> The `source` of a run without an input file.
  character(len=*), parameter :: built_in_source = 'built-in default'
  character(len=*), parameter :: known_groups(4) = [character(len=14) :: 'run', 'shape', 'hydrodynamics', 'continuum']

  !> The &shape group: a shape name and the parameters that shape takes (others stay unset).
  type :: shape_config_t
    character(len=64) :: name = 'cone'
    character(len=1024) :: file = ''
    character(len=256) :: dataset = '/geometry/positions'
    real(dp) :: reference_length = unset_real
    ! Paper shapes (settlers paper, appendix "Bead model ...").
    real(dp) :: base_diameter = unset_real, height = unset_real
    real(dp) :: length = unset_real, middle_height = unset_real, width = unset_real
    real(dp) :: semi_major = unset_real, semi_minor = unset_real, pipe_radius = unset_real
    real(dp) :: gap_half_angle = unset_real, gap_arc_length = unset_real
    real(dp) :: scale = unset_real, section_ratio = unset_real
    ! Simple shapes.
    real(dp) :: separation = unset_real, radius = unset_real
    real(dp) :: major_radius = unset_real, minor_radius = unset_real
    real(dp) :: semi_axes(3) = unset_real
    !> Mesh files: the bead diameter d in the mesh's own length unit (the resolution).
    real(dp) :: bead_diameter = unset_real
    !> The lattice's shift against the body (d, each in [0, 1)): the bead centres are the points
    !> node + lattice_offset inside the body (the continuum job averages over such shifts).
    real(dp) :: lattice_offset(3) = 0.0_dp
    integer :: n_beads = unset_int
    integer :: box_beads(3) = unset_int
    !> A box by its side lengths (centred on a node; with bead_diameter in any unit).
    real(dp) :: box_size(3) = unset_real
  end type shape_config_t

  !> The &continuum group: the body's continuum mobility from a ladder of resolutions, each
  !> averaged over sub-lattice offsets and extrapolated to zero bead size (driver/continuum_job.F90).
  type :: continuum_settings_t
    logical :: enabled = .false.
    !> Estimated wall time (s) of the whole ladder on this run's ranks: it sets the finest level.
    real(dp) :: time_budget = 600.0_dp
    !> Resolutions (bead counts a factor 2 apart), offsets solved per resolution, and the
    !> geometry-only fills at the finest resolution that measure the body's volume and moments.
    integer :: levels = 7
    integer :: offsets = unset_int   ! resolve_continuum_defaults
    integer :: moment_fills = 32
    !> The finest level's bead diameter (shape units) instead of the budget's choice.
    real(dp) :: finest_bead_diameter = unset_real
    !> Meshes: every sample (and moment fill) on a lattice turned by its own rotation of at most
    !> turn_angle (degrees) from the body's tighter-boxing axes, as well as shifted, so no face
    !> of the body stays along the lattice (docs/theory.md T18).
    logical :: turned_lattices = .false.
    real(dp) :: turn_angle = 15.0_dp
    !> Control samples per level: offsets beyond `offsets` solved at order L - 1 alone, whose mean
    !> corrects the level's (the `offsets` samples also solve order L - 1 on their beads: a
    !> control variate, docs/theory.md T18); 0: none.
    integer :: control_offsets = unset_int   ! resolve_continuum_defaults
    !> With control samples and a ladder the budget chose: once the ladder's samples are solved,
    !> the rest of the time budget buys more control samples, one at a time on the level where
    !> each narrows the bar most per second (up to 64 samples per level; docs/theory.md T18).
    logical :: fill_budget = .true.
    !> Each level's mean with the samples' bead moments as control variates (their mean over
    !> random offsets is the body's; docs/theory.md T18, "Moment control"); .false.: without.
    logical :: moment_control = .true.
  end type continuum_settings_t

  !> The continuum job's samples per level when the input leaves them out: at multipole_order
  !> >= 2 two offsets and six control samples (a level at most the cost of four plain offsets;
  !> on the coverage bench its bars 0.68 times the plain four's at the same coverage,
  !> bench/continuum/coverage_control.md), at order 1 (no lower order to control with) four offsets.
  integer, parameter :: default_controlled_offsets = 2, default_control_offsets = 6, default_plain_offsets = 4

  type :: run_config_t
    !> Input file path, or 'built-in default' when run without one.
    character(len=:), allocatable :: source
    !> The input text as given (echoed into the result file).
    character(len=:), allocatable :: text
    character(len=1024) :: output = default_output_path
    !> Beads overlap when their centres are closer than 1 - overlap_tolerance (relative to d).
    real(dp) :: overlap_tolerance = 1.0e-6_dp
    !> Rank 0 prints a progress line per phase and per Krylov solve (-quiet silences it too).
    logical :: progress = .true.
    !> Save each solved motion to '<output>.checkpoint.h5' and resume from it.
    logical :: checkpoint = .true.
    type(shape_config_t) :: shape
    !> The &hydrodynamics group: the friction job's settings (its command-line part is filled by
    !> the driver, driver/command_line.F90)
    type(friction_settings_t) :: hydrodynamics
    type(continuum_settings_t) :: continuum
    !> Command-line switches of the run (driver/command_line.F90): skip the friction job; the
    !> dry run; the ranks it estimates for (0: the run's) and the GiB a rank may use (0: what the
    !> node has); HDF5's own error stack on a failed call; a continuum job's checkpoint kept after
    !> it finished (the same input then reruns the extrapolation without a solve)
    logical :: geometry_only = .false., dry_run = .false.
    integer :: estimate_ranks = 0
    real(dp) :: memory_limit_gib = 0.0_dp
    logical :: hdf5_error_stack = .false., keep_checkpoint = .false.
    !> Test option -fill_samples K: a continuum job's fill_budget buys exactly K control samples in
    !> all, whatever the time (0: as many as the time budget pays for)
    integer :: fill_samples = 0
    !> Test option -slow_samples F: a continuum job's samples after its pilot count F times their
    !> time (a machine slowed down after the pilot), which the budget's checks then see
    real(dp) :: slow_samples = 1.0_dp
  end type run_config_t

contains

  !> Parse the namelist text of an input file (`source` names it in messages).
  !> An empty text means: the built-in default run (the paper's cone and its mobility at the
  !> default &hydrodynamics settings).
  subroutine parse_input_text(text, source, config, err)
    character(len=*), intent(in) :: text, source
    type(run_config_t), intent(out) :: config
    type(error_t), intent(inout) :: err
    character(len=:), allocatable :: lines(:)
    logical :: found

    config%source = source
    config%text = text
    if (len_trim(text) == 0 .and. source == built_in_source) then
      config%hydrodynamics%enabled = .true.
      config%hydrodynamics%potential_order = max(config%hydrodynamics%multipole_order - 2, 0)
      return
    end if
    call split_lines(text, lines)
    call check_group_names(lines, source, err)
    if (err%failed) return
    call check_group_terminators(lines, source, err)
    if (err%failed) return
    call read_run_group(lines, source, config, err)
    if (err%failed) return
    call read_shape_group(lines, source, config%shape, found, err)
    if (err%failed) return
    call read_hydrodynamics_group(lines, source, config%hydrodynamics, err)
    if (err%failed) return
    call read_continuum_group(lines, source, config%continuum, err)
    if (err%failed) return
    call resolve_continuum_defaults(config%continuum, config%hydrodynamics%multipole_order)
    if (.not. found) call raise(err, source // ': no &shape group (say which bead model to build, e.g. &shape name=''cone'' /)')
    ! A relative bead file path is relative to the input file, wherever the run starts.
    if (len_trim(config%shape%file) > 0 .and. config%shape%file(1:1) /= '/' .and. index(source, '/') > 0) &
      config%shape%file = source(1:index(source, '/', back=.true.)) // trim(config%shape%file)
    if (len_trim(config%output) == 0) call raise(err, source // ': &run output is empty')
    if (.not. (config%overlap_tolerance >= 0.0_dp .and. config%overlap_tolerance < 1.0_dp)) &
      call raise(err, source // ': &run overlap_tolerance must be in [0, 1), got ' // str(config%overlap_tolerance))
  end subroutine parse_input_text

  subroutine read_continuum_group(lines, source, settings, err)
    character(len=*), intent(in) :: lines(:), source
    type(continuum_settings_t), intent(inout) :: settings
    type(error_t), intent(inout) :: err
    real(dp) :: time_budget, finest_bead_diameter, turn_angle
    integer :: levels, offsets, moment_fills, control_offsets, status
    logical :: turned_lattices, fill_budget, moment_control
    character(len=512) :: message
    namelist /continuum/ time_budget, levels, offsets, moment_fills, finest_bead_diameter, turned_lattices, &
                         turn_angle, control_offsets, fill_budget, moment_control

    settings%enabled = has_group(lines, 'continuum')
    if (.not. settings%enabled) return
    time_budget = settings%time_budget
    levels = settings%levels
    offsets = settings%offsets
    moment_fills = settings%moment_fills
    finest_bead_diameter = settings%finest_bead_diameter
    turned_lattices = settings%turned_lattices
    fill_budget = settings%fill_budget
    moment_control = settings%moment_control
    turn_angle = settings%turn_angle
    control_offsets = settings%control_offsets
    read (lines, nml=continuum, iostat=status, iomsg=message)
    if (status > 0) then
      call raise(err, namelist_error(lines, source, 'continuum', message))
      return
    end if
    if (.not. (time_budget > 0.0_dp .and. time_budget < huge(1.0_dp))) then
      call raise(err, source // ': &continuum time_budget must be a positive number of seconds, got ' // str(time_budget))
    else if (levels < 3 .or. levels > 12) then
      call raise(err, source // ': &continuum levels must be 3 to 12 (a quadratic in the bead size needs 3), got ' // &
                 str(levels))
    else if (is_set(offsets) .and. (offsets < 2 .or. offsets > 64)) then
      call raise(err, source // ': &continuum offsets must be 2 to 64 (a level''s scatter needs 2), got ' // str(offsets))
    else if (moment_fills < 8 .or. moment_fills > 4096) then
      call raise(err, source // ': &continuum moment_fills must be 8 to 4096, got ' // str(moment_fills))
    else if (is_set(finest_bead_diameter) .and. .not. (finest_bead_diameter > 0.0_dp .and. &
                                                       finest_bead_diameter < huge(1.0_dp))) then
      call raise(err, source // ': &continuum finest_bead_diameter must be positive, got ' // str(finest_bead_diameter))
    else if (.not. (turn_angle > 0.0_dp .and. turn_angle <= 180.0_dp)) then
      call raise(err, source // ': &continuum turn_angle must be in (0, 180] degrees, got ' // str(turn_angle))
    else if (is_set(control_offsets) .and. (control_offsets < 0 .or. control_offsets > 256)) then
      call raise(err, source // ': &continuum control_offsets must be 0 to 256, got ' // str(control_offsets))
    end if
    if (err%failed) return
    settings = continuum_settings_t(enabled=.true., time_budget=time_budget, levels=levels, offsets=offsets, &
                                    moment_fills=moment_fills, finest_bead_diameter=finest_bead_diameter, &
                                    turned_lattices=turned_lattices, turn_angle=turn_angle, &
                                    control_offsets=control_offsets, fill_budget=fill_budget, &
                                    moment_control=moment_control)
  end subroutine read_continuum_group

  !> The samples per level an input leaves out (default_*_offsets above): control samples
  !> wherever the multipole order has a lower one to control with, and then fewer full offsets.
  !> What the input gives is kept (a control_offsets > 0 at order 1 is refused by the job).
  subroutine resolve_continuum_defaults(settings, multipole_order)
    type(continuum_settings_t), intent(inout) :: settings
    integer, intent(in) :: multipole_order
    if (.not. is_set(settings%control_offsets)) &
      settings%control_offsets = merge(default_control_offsets, 0, multipole_order >= 2)
    if (.not. is_set(settings%offsets)) &
      settings%offsets = merge(default_controlled_offsets, default_plain_offsets, settings%control_offsets > 0)
  end subroutine resolve_continuum_defaults

  subroutine read_run_group(lines, source, config, err)
    character(len=*), intent(in) :: lines(:), source
    type(run_config_t), intent(inout) :: config
    type(error_t), intent(inout) :: err
    character(len=1024) :: output
    real(dp) :: overlap_tolerance
    logical :: progress, checkpoint
    integer :: status
    character(len=512) :: message
    namelist /run/ output, overlap_tolerance, progress, checkpoint

    output = config%output
    overlap_tolerance = config%overlap_tolerance
    progress = config%progress
    checkpoint = config%checkpoint
    ! gfortran reads 'progress = 3' as an obscure "bad repeat count" and a quoted text as no
    ! change at all: check these switches' values first.
    call check_logical_value(lines, source, 'run', 'progress', err)
    call check_logical_value(lines, source, 'run', 'checkpoint', err)
    if (err%failed) return
    read (lines, nml=run, iostat=status, iomsg=message)
    if (status > 0) then
      call raise(err, namelist_error(lines, source, 'run', message))
      return
    end if
    config%output = output
    config%overlap_tolerance = overlap_tolerance
    config%progress = progress
    config%checkpoint = checkpoint
  end subroutine read_run_group

  subroutine read_hydrodynamics_group(lines, source, hydro, err)
    character(len=*), intent(in) :: lines(:), source
    type(friction_settings_t), intent(inout) :: hydro
    type(error_t), intent(inout) :: err
    integer :: multipole_order, potential_order, shell_layers, status
    logical :: lubrication, bead_forces, use_symmetry, error_estimate, flow
    real(dp) :: lubrication_cutoff, accuracy, krylov_rtol
    character(len=1024) :: cache_file
    character(len=64) :: motions
    character(len=512) :: message
    namelist /hydrodynamics/ multipole_order, potential_order, lubrication, lubrication_cutoff, bead_forces, cache_file, &
                             shell_layers, krylov_rtol, accuracy, use_symmetry, motions, error_estimate, flow

    hydro%enabled = has_group(lines, 'hydrodynamics')
    if (.not. hydro%enabled) return
    ! Unset markers first: an accuracy target must know whether the input chose these itself.
    multipole_order = unset_int
    potential_order = unset_int
    shell_layers = unset_int
    krylov_rtol = unset_real
    lubrication = hydro%lubrication
    lubrication_cutoff = hydro%lubrication_cutoff
    bead_forces = hydro%bead_forces
    cache_file = hydro%cache_file
    accuracy = hydro%accuracy
    use_symmetry = hydro%use_symmetry
    error_estimate = hydro%error_estimate
    motions = hydro%motions_text
    flow = hydro%flow
    read (lines, nml=hydrodynamics, iostat=status, iomsg=message)
    if (status > 0) then
      call raise(err, namelist_error(lines, source, 'hydrodynamics', message))
      return
    end if
    ! A logical has no "unset" value: read again from the other default to see whether the
    ! input gives error_estimate.
    hydro%error_estimate_given = .false.
    if (error_estimate .eqv. hydro%error_estimate) then
      error_estimate = .not. hydro%error_estimate
      read (lines, nml=hydrodynamics, iostat=status, iomsg=message)
      hydro%error_estimate_given = error_estimate .eqv. hydro%error_estimate
      error_estimate = hydro%error_estimate
    else
      hydro%error_estimate_given = .true.
    end if
    hydro%choices_given = is_set(multipole_order) .or. is_set(potential_order) .or. is_set(shell_layers) .or. &
                          is_set(krylov_rtol)
    if (.not. is_set(multipole_order)) multipole_order = hydro%multipole_order
    if (.not. is_set(shell_layers)) shell_layers = hydro%shell_layers
    if (.not. is_set(krylov_rtol)) krylov_rtol = hydro%krylov_rtol
    if (.not. is_set(potential_order)) potential_order = max(multipole_order - 2, 0)
    if (accuracy /= 0.0_dp .and. .not. (accuracy > 0.0_dp .and. accuracy < 1.0_dp)) then
      call raise(err, source // ': &hydrodynamics accuracy must be a relative error between 0 and 1 (e.g. 1e-2), ' // &
                 'or 0 for none, got ' // str(accuracy))
    else if (accuracy > 0.0_dp .and. hydro%choices_given) then
      call raise(err, source // ': &hydrodynamics accuracy chooses multipole_order, potential_order, ' // &
                 'shell_layers and krylov_rtol itself: give either accuracy or those')
    else if (.not. (krylov_rtol > 0.0_dp .and. krylov_rtol < 1.0_dp)) then
      call raise(err, source // ': &hydrodynamics krylov_rtol must be between 0 and 1, got ' // str(krylov_rtol))
    else if (multipole_order < 1) then
      call raise(err, source // ': &hydrodynamics multipole_order must be >= 1, got ' // str(multipole_order))
    else if (multipole_order > 40) then
      call raise(err, source // ': &hydrodynamics multipole_order must be <= 40 (the quadrature and the ' // &
                 'harmonic recurrences are checked up to there), got ' // str(multipole_order))
    else if (potential_order < 0 .or. potential_order > multipole_order) then
      call raise(err, source // ': &hydrodynamics potential_order must be between 0 and multipole_order = ' // &
                 str(multipole_order) // ', got ' // str(potential_order))
    else if (.not. (lubrication_cutoff >= 1.0_dp .and. lubrication_cutoff <= 10.0_dp)) then
      call raise(err, source // ': &hydrodynamics lubrication_cutoff must be between 1 and 10 (bead diameters), got ' &
                 // str(lubrication_cutoff))
    else if (is_set(shell_layers) .and. shell_layers < 0) then
      call raise(err, source // ': &hydrodynamics shell_layers must be >= 0 (0 = all beads), got ' // str(shell_layers))
    end if
    hydro%multipole_order = multipole_order
    hydro%potential_order = potential_order
    hydro%lubrication = lubrication
    hydro%lubrication_cutoff = lubrication_cutoff
    hydro%bead_forces = bead_forces
    hydro%cache_file = cache_file
    hydro%shell_layers = shell_layers
    hydro%krylov_rtol = krylov_rtol
    hydro%accuracy = accuracy
    hydro%use_symmetry = use_symmetry
    hydro%error_estimate = error_estimate
    hydro%motions_text = motions
    hydro%flow = flow
    if (.not. err%failed) call parse_motions(motions, source, hydro%motions, err)
    ! The flow's response needs the whole friction; its pair correction has no strain terms.
    if (.not. err%failed .and. flow .and. .not. all(hydro%motions)) then
      call raise(err, source // ": &hydrodynamics flow = .true. needs all six motions (the free body's response " // &
                 "to a flow is solved with the whole friction), got motions = '" // trim(motions) // "'")
    else if (.not. err%failed .and. flow .and. lubrication) then
      call raise(err, source // ': &hydrodynamics flow = .true. cannot be combined with lubrication = .true.: ' // &
                 'the pair correction (theory.md T9) has no strain terms; run the flow without it')
    end if
  end subroutine read_hydrodynamics_group

  !> Every `name = value` of `group` must give a Fortran logical (.true., .false., t, f, ...):
  !> an error naming the line otherwise. Quoted texts and comments are skipped when looking.
  subroutine check_logical_value(lines, source, group, name, err)
    character(len=*), intent(in) :: lines(:), source, group, name
    type(error_t), intent(inout) :: err
    character(len=:), allocatable :: text, value
    logical :: inside
    integer :: i, at, finish
    inside = .false.
    do i = 1, size(lines)
      text = lower(unquoted(lines(i)))
      if (len(group_on_line(lines(i))) > 0) inside = group_on_line(lines(i)) == group
      if (.not. inside) cycle
      at = word_at(text, name)
      do while (at > 0)
        value = adjustl(text(at + len(name):))
        if (len_trim(value) > 0) then
          if (value(1:1) == '=') then
            value = trim(adjustl(value(2:)))
            finish = scan(value // ' ', ' ,/') - 1
            value = value(1:finish)
            if (.not. logical_literal(value)) then
              ! The raw text of the value (the quotes are blanked in `text`).
              value = trim(adjustl(lines(i)(index(lines(i)(at:), '=') + at:)))
              finish = scan(value // ' ', ',/') - 1
              call raise(err, source // ' line ' // str(i) // ': &' // group // ' ' // name // &
                         " must be .true. or .false., got '" // trim(value(1:finish)) // "'")
              return
            end if
          end if
        end if
        finish = word_at(text(at + len(name):), name)
        at = merge(at + len(name) + finish - 1, 0, finish > 0)
      end do
      if (index(text, '/') > 0) inside = .false.
    end do
  contains
    pure logical function logical_literal(word)
      character(len=*), intent(in) :: word
      character(len=:), allocatable :: w
      w = word
      if (len(w) > 0) then
        if (w(1:1) == '.') w = w(2:)
      end if
      logical_literal = len(w) > 0
      if (logical_literal) logical_literal = w(1:1) == 't' .or. w(1:1) == 'f'
      if (logical_literal) logical_literal = verify(w, 'abcdefghijklmnopqrstuvwxyz.') == 0
    end function logical_literal

    !> Position of `word` in `line` as a whole word (not part of a longer name), 0 if none.
    pure integer function word_at(line, word)
      character(len=*), intent(in) :: line, word
      character(len=*), parameter :: name_chars = 'abcdefghijklmnopqrstuvwxyz0123456789_%'
      integer :: start, k
      word_at = 0
      start = 1
      do
        k = index(line(start:), word)
        if (k == 0) return
        k = k + start - 1
        if (k > 1) then
          if (index(name_chars, line(k - 1:k - 1)) > 0) then
            start = k + 1
            cycle
          end if
        end if
        if (k + len(word) <= len(line)) then
          if (index(name_chars, line(k + len(word):k + len(word))) > 0) then
            start = k + 1
            cycle
          end if
        end if
        word_at = k
        return
      end do
    end function word_at

  end subroutine check_logical_value

  !> &hydrodynamics motions: 'all', or blank-separated motion names (U_x ... W_z, translations,
  !> rotations); at least one.
  subroutine parse_motions(text, source, requested, err)
    character(len=*), intent(in) :: text, source
    logical, intent(out) :: requested(6)
    type(error_t), intent(inout) :: err
    character(len=*), parameter :: names(6) = [character(len=3) :: 'U_x', 'U_y', 'U_z', 'W_x', 'W_y', 'W_z']
    character(len=len(text)) :: word
    integer :: start, finish, k
    requested = trim(adjustl(text)) == 'all'
    if (all(requested)) return
    start = 1
    do while (start <= len_trim(text))
      if (text(start:start) == ' ') then
        start = start + 1
        cycle
      end if
      finish = index(text(start:) // ' ', ' ') + start - 2
      word = text(start:finish)
      select case (trim(word))
      case ('translations')
        requested(1:3) = .true.
      case ('rotations')
        requested(4:6) = .true.
      case default
        k = findloc(names, trim(word), dim=1)
        if (k == 0) then
          call raise(err, source // ": &hydrodynamics motions: unknown motion '" // trim(word) // &
                     "' (use 'all' or names among U_x U_y U_z W_x W_y W_z translations rotations)")
          return
        end if
        requested(k) = .true.
      end select
      start = finish + 2
    end do
    if (.not. any(requested)) call raise(err, source // ': &hydrodynamics motions names no motion')
  end subroutine parse_motions

  subroutine read_shape_group(lines, source, shape_config, found, err)
    character(len=*), intent(in) :: lines(:), source
    type(shape_config_t), intent(inout) :: shape_config
    logical, intent(out) :: found
    type(error_t), intent(inout) :: err
    character(len=64) :: name
    character(len=1024) :: file
    character(len=256) :: dataset
    real(dp) :: reference_length, base_diameter, height, length, middle_height, width, semi_major, semi_minor, &
                pipe_radius, gap_half_angle, gap_arc_length, scale, section_ratio, separation, radius, &
                major_radius, minor_radius, semi_axes(3), bead_diameter, lattice_offset(3), box_size(3)
    integer :: n_beads, box_beads(3), status
    character(len=512) :: message
    namelist /shape/ name, file, dataset, reference_length, base_diameter, height, length, middle_height, width, &
      semi_major, semi_minor, pipe_radius, gap_half_angle, gap_arc_length, scale, section_ratio, separation, &
      radius, major_radius, minor_radius, semi_axes, n_beads, box_beads, bead_diameter, lattice_offset, box_size

    associate (c => shape_config)
      name = c%name; file = c%file; dataset = c%dataset; reference_length = c%reference_length
      base_diameter = c%base_diameter; height = c%height; length = c%length; middle_height = c%middle_height
      width = c%width; semi_major = c%semi_major; semi_minor = c%semi_minor; pipe_radius = c%pipe_radius
      gap_half_angle = c%gap_half_angle; gap_arc_length = c%gap_arc_length; scale = c%scale
      section_ratio = c%section_ratio; separation = c%separation; radius = c%radius
      major_radius = c%major_radius; minor_radius = c%minor_radius; semi_axes = c%semi_axes
      n_beads = c%n_beads; box_beads = c%box_beads; bead_diameter = c%bead_diameter
      lattice_offset = c%lattice_offset; box_size = c%box_size
    end associate
    ! gfortran reports success when the group is absent from an internal file: look for it.
    found = has_group(lines, 'shape')
    if (.not. found) return
    read (lines, nml=shape, iostat=status, iomsg=message)
    if (status > 0) then
      call raise(err, namelist_error(lines, source, 'shape', message))
      return
    end if
    shape_config = shape_config_t(name=name, file=file, dataset=dataset, reference_length=reference_length, &
      base_diameter=base_diameter, height=height, length=length, middle_height=middle_height, width=width, &
      semi_major=semi_major, semi_minor=semi_minor, pipe_radius=pipe_radius, gap_half_angle=gap_half_angle, &
      gap_arc_length=gap_arc_length, scale=scale, section_ratio=section_ratio, separation=separation, &
      radius=radius, major_radius=major_radius, minor_radius=minor_radius, semi_axes=semi_axes, &
      n_beads=n_beads, box_beads=box_beads, bead_diameter=bead_diameter, lattice_offset=lattice_offset, &
      box_size=box_size)
  end subroutine read_shape_group

  !> The configuration actually used, written back as namelists (defaults made visible).
  !> numbers_only: without the switches that change no number of the result (progress,
  !> checkpoint, cache_file): the input part of a checkpoint's key (checkpoint_file.f90).
  function effective_input_text(config, numbers_only) result(text)
    type(run_config_t), intent(in) :: config
    logical, intent(in), optional :: numbers_only
    character(len=:), allocatable :: text
    character(len=256) :: line
    logical :: all_switches
    all_switches = .true.
    if (present(numbers_only)) all_switches = .not. numbers_only
    text = '&run' // new_line('a') // "  output = '" // trim(config%output) // "'" // new_line('a')
    write (line, '(a, es23.16)') '  overlap_tolerance = ', config%overlap_tolerance
    text = text // trim(line) // new_line('a')
    if (all_switches) text = text // '  progress = ' // merge('.true. ', '.false.', config%progress) // new_line('a') // &
                             '  checkpoint = ' // merge('.true. ', '.false.', config%checkpoint) // new_line('a')
    text = text // '/' // new_line('a')
    text = text // '&shape' // new_line('a') // "  name = '" // trim(config%shape%name) // "'" // new_line('a')
    associate (c => config%shape)
      if (len_trim(c%file) > 0) text = text // "  file = '" // trim(c%file) // "'" // new_line('a') // &
                                       "  dataset = '" // trim(c%dataset) // "'" // new_line('a')
      call add_real('reference_length', c%reference_length)
      call add_real('base_diameter', c%base_diameter)
      call add_real('height', c%height)
      call add_real('length', c%length)
      call add_real('middle_height', c%middle_height)
      call add_real('width', c%width)
      call add_real('semi_major', c%semi_major)
      call add_real('semi_minor', c%semi_minor)
      call add_real('pipe_radius', c%pipe_radius)
      call add_real('gap_half_angle', c%gap_half_angle)
      call add_real('gap_arc_length', c%gap_arc_length)
      call add_real('scale', c%scale)
      call add_real('section_ratio', c%section_ratio)
      call add_real('separation', c%separation)
      call add_real('radius', c%radius)
      call add_real('major_radius', c%major_radius)
      call add_real('minor_radius', c%minor_radius)
      call add_real('bead_diameter', c%bead_diameter)
      if (all(is_set(c%semi_axes))) then
        write (line, '(a, 3(es23.16, :, ", "))') '  semi_axes = ', c%semi_axes
        text = text // trim(line) // new_line('a')
      end if
      if (all(is_set(c%box_size))) then
        write (line, '(a, 3(es23.16, :, ", "))') '  box_size = ', c%box_size
        text = text // trim(line) // new_line('a')
      end if
      if (any(c%lattice_offset /= 0.0_dp)) then
        write (line, '(a, 3(es23.16, :, ", "))') '  lattice_offset = ', c%lattice_offset
        text = text // trim(line) // new_line('a')
      end if
      if (is_set(c%n_beads)) text = text // '  n_beads = ' // str(c%n_beads) // new_line('a')
      if (all(is_set(c%box_beads))) text = text // '  box_beads = ' // str(c%box_beads(1)) // ', ' // &
                                           str(c%box_beads(2)) // ', ' // str(c%box_beads(3)) // new_line('a')
    end associate
    text = text // '/' // new_line('a')
    if (config%hydrodynamics%enabled) text = text // '&hydrodynamics' // new_line('a') // &
      '  multipole_order = ' // str(config%hydrodynamics%multipole_order) // new_line('a') // &
      '  potential_order = ' // str(config%hydrodynamics%potential_order) // new_line('a') // &
      '  lubrication = ' // merge('.true. ', '.false.', config%hydrodynamics%lubrication) // new_line('a') // &
      '  lubrication_cutoff = ' // str(config%hydrodynamics%lubrication_cutoff) // new_line('a') // &
      '  bead_forces = ' // merge('.true. ', '.false.', config%hydrodynamics%bead_forces) // new_line('a') // &
      '  shell_layers = ' // str(config%hydrodynamics%shell_layers) // new_line('a') // &
      '  krylov_rtol = ' // str(config%hydrodynamics%krylov_rtol) // new_line('a') // &
      '  use_symmetry = ' // merge('.true. ', '.false.', config%hydrodynamics%use_symmetry) // new_line('a') // &
      '  error_estimate = ' // merge('.true. ', '.false.', config%hydrodynamics%error_estimate) // new_line('a') // &
      '  flow = ' // merge('.true. ', '.false.', config%hydrodynamics%flow) // new_line('a') // &
      "  motions = '" // trim(config%hydrodynamics%motions_text) // "'" // new_line('a') // &
      accuracy_line(config%hydrodynamics%accuracy) // cache_line(config%hydrodynamics%cache_file, all_switches) // '/' // &
      new_line('a')
    if (config%continuum%enabled) then
      write (line, '(a, es23.16)') '  time_budget = ', config%continuum%time_budget
      text = text // '&continuum' // new_line('a') // trim(line) // new_line('a') // &
             '  levels = ' // str(config%continuum%levels) // new_line('a') // &
             '  offsets = ' // str(config%continuum%offsets) // new_line('a') // &
             '  moment_fills = ' // str(config%continuum%moment_fills) // new_line('a')
      ! Only when on: an aligned job's text (and its checkpoint key) stays that of earlier builds.
      if (config%continuum%turned_lattices) then
        write (line, '(a, es23.16)') '  turn_angle = ', config%continuum%turn_angle
        text = text // '  turned_lattices = .true. ' // new_line('a') // trim(line) // new_line('a')
      end if
      ! Always: an input that leaves it out gets control samples by default, so a plain job's
      ! text must say 0 to rerun as one.
      text = text // '  control_offsets = ' // str(config%continuum%control_offsets) // new_line('a')
      ! Only when off (the default is on): a default job's text stays that of earlier builds.
      if (.not. config%continuum%fill_budget) text = text // '  fill_budget = .false.' // new_line('a')
      call add_real('finest_bead_diameter', config%continuum%finest_bead_diameter)
      text = text // '/' // new_line('a')
    end if
  contains
    !> A comment: the settings above are the ones the target chose, and the text stays a valid
    !> input that reruns them (accuracy together with them would be refused).
    function accuracy_line(target) result(line_text)
      real(dp), intent(in) :: target
      character(len=:), allocatable :: line_text
      line_text = ''
      if (target > 0.0_dp) line_text = '  ! chosen for accuracy = ' // str(target) // new_line('a')
    end function accuracy_line

    pure function cache_line(path, wanted) result(line_text)
      character(len=*), intent(in) :: path
      logical, intent(in) :: wanted
      character(len=:), allocatable :: line_text
      line_text = ''
      if (wanted .and. len_trim(path) > 0) line_text = "  cache_file = '" // trim(path) // "'" // new_line('a')
    end function cache_line

    subroutine add_real(name, value)
      character(len=*), intent(in) :: name
      real(dp), intent(in) :: value
      if (.not. is_set(value)) return
      write (line, '(a, " = ", es23.16)') '  ' // name, value
      text = text // trim(line) // new_line('a')
    end subroutine add_real
  end function effective_input_text

  !> Lines starting with '&' must name a known group: a misspelt group would be ignored.
  subroutine check_group_names(lines, source, err)
    character(len=*), intent(in) :: lines(:), source
    type(error_t), intent(inout) :: err
    integer :: i
    character(len=:), allocatable :: group
    do i = 1, size(lines)
      group = group_on_line(lines(i))
      if (len(group) == 0 .or. group == 'end') cycle
      if (.not. any(known_groups == group)) then
        call raise(err, source // ' line ' // str(i) // ': unknown namelist group &' // group // &
                   ' (known groups: &run, &shape, &hydrodynamics)')
        return
      end if
    end do
  end subroutine check_group_names

  !> Every group must end with '/' (or &end) before the next group or the end of the file:
  !> gfortran reads an unterminated last group without a word, and one followed by another group
  !> into that group's text. Slashes inside quoted texts (file paths) and comments do not count.
  subroutine check_group_terminators(lines, source, err)
    character(len=*), intent(in) :: lines(:), source
    type(error_t), intent(inout) :: err
    character(len=:), allocatable :: group, open_group, text
    integer :: i, open_line, body_start
    open_group = ''
    open_line = 0
    do i = 1, size(lines)
      text = unquoted(lines(i))
      group = group_on_line(lines(i))
      body_start = 1
      if (len(group) > 0) then
        if (group == 'end') then
          open_group = ''
          cycle
        end if
        if (len(open_group) > 0) exit
        open_group = group
        open_line = i
        body_start = index(text, '&') + len(group) + 1
      end if
      if (len(open_group) > 0 .and. body_start <= len(text)) then
        if (index(text(body_start:), '/') > 0) open_group = ''
      end if
    end do
    if (len(open_group) == 0) return
    if (i <= size(lines)) then
      call raise(err, source // ' line ' // str(open_line) // ': namelist group &' // open_group // &
                 " has no closing '/' before &" // group // ' on line ' // str(i))
    else
      call raise(err, source // ' line ' // str(open_line) // ': namelist group &' // open_group // &
                 " has no closing '/' (the file ends first)")
    end if
  end subroutine check_group_terminators

  !> The line with quoted texts blanked and the comment cut off.
  pure function unquoted(line) result(plain)
    character(len=*), intent(in) :: line
    character(len=len(line)) :: plain
    character :: quote
    integer :: k
    plain = line
    quote = ' '
    do k = 1, len(line)
      if (quote /= ' ') then
        if (line(k:k) == quote) quote = ' '
        plain(k:k) = ' '
      else if (line(k:k) == '"' .or. line(k:k) == "'") then
        quote = line(k:k)
        plain(k:k) = ' '
      else if (line(k:k) == '!') then
        plain(k:) = ' '
        exit
      end if
    end do
  end function unquoted

  pure logical function has_group(lines, group)
    character(len=*), intent(in) :: lines(:), group
    integer :: i
    has_group = .false.
    do i = 1, size(lines)
      if (group_on_line(lines(i)) == group) has_group = .true.
    end do
  end function has_group

  !> The lower-case group name opened on this line ('&shape ...'), or '' if none.
  pure function group_on_line(line) result(group)
    character(len=*), intent(in) :: line
    character(len=:), allocatable :: group
    character(len=:), allocatable :: text
    integer :: stop_at
    text = trim(adjustl(line))
    group = ''
    if (len(text) < 2) return
    if (text(1:1) /= '&') return
    stop_at = scan(text(2:), ' /,')
    if (stop_at == 0) then
      group = trim(lower(text(2:)))
    else
      group = lower(text(2:stop_at))
    end if
  end function group_on_line

  !> Message for a namelist read error, with the line of the offending name when it can be found.
  function namelist_error(lines, source, group, message) result(text)
    character(len=*), intent(in) :: lines(:), source, group, message
    character(len=:), allocatable :: text
    integer :: i, at
    character(len=:), allocatable :: name
    text = source // ': error in namelist &' // group // ': ' // trim(message)
    at = index(message, 'object name ')
    if (at == 0) return
    name = lower(trim(message(at + len('object name '):)))
    do i = 1, size(lines)
      if (index(lower(lines(i)), name) > 0) then
        text = source // ' line ' // str(i) // ': error in namelist &' // group // ': ' // trim(message)
        return
      end if
    end do
  end function namelist_error

  subroutine split_lines(text, lines)
    character(len=*), intent(in) :: text
    character(len=:), allocatable, intent(out) :: lines(:)
    integer :: n_lines, longest, start, i, k, line_end
    n_lines = 0
    longest = 1
    start = 1
    do i = 1, len(text) + 1
      if (i > len(text)) then
        if (i > start) then
          n_lines = n_lines + 1
          longest = max(longest, i - start)
        end if
      else if (text(i:i) == new_line('a')) then
        n_lines = n_lines + 1
        longest = max(longest, i - start)
        start = i + 1
      end if
    end do
    allocate (character(len=longest) :: lines(max(n_lines, 1)))
    lines = ''
    start = 1
    k = 0
    do while (start <= len(text))
      line_end = index(text(start:), new_line('a'))
      if (line_end == 0) then
        line_end = len(text) + 1
      else
        line_end = start + line_end - 1
      end if
      k = k + 1
      lines(k) = text(start:line_end - 1)
      start = line_end + 1
    end do
  end subroutine split_lines

  pure function lower(text) result(low)
    character(len=*), intent(in) :: text
    character(len=len(text)) :: low
    integer :: i, code
    low = text
    do i = 1, len(text)
      code = iachar(text(i:i))
      if (code >= iachar('A') .and. code <= iachar('Z')) low(i:i) = achar(code + 32)
    end do
  end function lower
end module beadmob_input_config
