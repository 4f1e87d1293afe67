!> Tests src/io/input_config.f90.
!> CTest: test_input_config_np1 and test_input_config_np2 (the program keeps the test's name, test_input_config).
!> The namelist input: values read, defaults kept, errors located, effective text re-readable.
program test_input_config
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t
  use beadmob_input_config, only: run_config_t, parse_input_text, effective_input_text, is_set
  use beadmob_friction_settings, only: friction_settings_t
  use beadmob_testing
  implicit none
  type(test_suite_t) :: suite
  character(len=*), parameter :: nl = new_line('a')

  suite = start_tests('test_input_config')
  call test_values_and_defaults()
  call test_round_trip()
  call test_errors()
  call test_run_switches()
  call test_error_estimate_switch()
  call test_one_set_of_defaults()
  call finish_tests(suite)

contains

  subroutine test_values_and_defaults()
    type(run_config_t) :: config
    type(error_t) :: err
    call parse_input_text("! comment line" // nl // "&run output = 'x.h5' /" // nl // &
                          "&shape name = 'spheroid', semi_axes = 4, 3, 2.5 /" // nl, 'cases/a.nml', config, err)
    call check(suite, .not. err%failed, 'valid input parses')
    call check_equal(suite, trim(config%output), 'x.h5', 'output read')
    call check_equal(suite, trim(config%shape%name), 'spheroid', 'shape name read')
    call check(suite, all(config%shape%semi_axes == [4.0_dp, 3.0_dp, 2.5_dp]), 'semi_axes read')
    call check(suite, .not. is_set(config%shape%radius), 'radius stays unset')
    call check_close(suite, config%overlap_tolerance, 1.0e-6_dp, 0.0_dp, 'overlap tolerance default')

    call parse_input_text("&shape name = 'bead_file', file = 'beads.txt' /", 'cases/b.nml', config, err)
    call check_equal(suite, trim(config%shape%file), 'cases/beads.txt', 'bead file relative to the input file')
    call parse_input_text("&shape name = 'bead_file', file = '/abs/beads.txt' /", 'cases/b.nml', config, err)
    call check_equal(suite, trim(config%shape%file), '/abs/beads.txt', 'absolute bead file path kept')
    call check_equal(suite, trim(config%output), 'beadmob_result.h5', 'output default')
  end subroutine test_values_and_defaults

  !> The effective namelist written into result files reads back to the same configuration.
  subroutine test_round_trip()
    type(run_config_t) :: first, second
    type(error_t) :: err
    call parse_input_text("&shape name = 'ring_2mm', pipe_radius = 3.6000000000000001, gap_arc_length = 10.5 /" // &
                          nl // "&run overlap_tolerance = 1e-3 /", 'in.nml', first, err)
    call parse_input_text(effective_input_text(first), 'effective.nml', second, err)
    call check(suite, .not. err%failed, 'effective namelist parses')
    call check_equal(suite, trim(second%shape%name), 'ring_2mm', 'round trip: name')
    call check(suite, second%shape%pipe_radius == first%shape%pipe_radius, 'round trip: pipe_radius bit for bit')
    call check(suite, second%shape%gap_arc_length == 10.5_dp, 'round trip: gap_arc_length')
    call check(suite, second%overlap_tolerance == 1.0e-3_dp, 'round trip: overlap_tolerance')
    call check(suite, .not. is_set(second%shape%height), 'round trip: unset stays unset')
  end subroutine test_round_trip

  subroutine test_errors()
    type(run_config_t) :: config
    type(error_t) :: err
    call parse_input_text("&shape name = 'cone'," // nl // "  hieght = 3 /", 'c.nml', config, err)
    call check(suite, err%failed, 'misspelt variable rejected')
    if (err%failed) call check(suite, index(err%message, 'c.nml line 2') > 0, 'misspelt variable located: ' // err%message)
    err = error_t()
    call parse_input_text("&run output = 'a.h5' /" // nl // "&shapes name = 'cone' /", 'd.nml', config, err)
    call check(suite, err%failed, 'unknown group rejected')
    if (err%failed) call check(suite, index(err%message, 'd.nml line 2: unknown namelist group &shapes') > 0, &
                               'unknown group located: ' // err%message)
    err = error_t()
    call parse_input_text("&run output = 'a.h5' /", 'e.nml', config, err)
    call check(suite, err%failed, 'missing &shape rejected')
    err = error_t()
    call parse_input_text("&run overlap_tolerance = 2 /" // nl // "&shape name='cone' /", 'f.nml', config, err)
    call check(suite, err%failed, 'overlap tolerance 2 rejected')
    err = error_t()
    call parse_input_text("&shape name = 'cone', height = abc /", 'g.nml', config, err)
    call check(suite, err%failed, 'non-numeric value rejected')
  end subroutine test_errors

  !> &run progress and checkpoint: defaults, values, the numbers-only effective text
  !> (the checkpoint key must not change with them) and bad values named with their line.
  subroutine test_run_switches()
    type(run_config_t) :: config, second
    type(error_t) :: err
    call parse_input_text("&shape name = 'cone' /", 'a.nml', config, err)
    call check(suite, config%progress .and. config%checkpoint, 'progress and checkpoint default on')
    call parse_input_text("&run output = 'progress = 3.h5', progress = .false., ! progress = 3" // nl // &
                          "  checkpoint = F /" // nl // "&shape name = 'cone' /", 'a.nml', config, err)
    call check(suite, .not. err%failed, 'switches read (quoted text and comment ignored)')
    call check(suite, .not. config%progress .and. .not. config%checkpoint, 'progress and checkpoint off')
    call parse_input_text(effective_input_text(config), 'effective.nml', second, err)
    call check(suite, .not. second%progress .and. .not. second%checkpoint, 'round trip: switches')
    call check(suite, effective_input_text(config, numbers_only=.true.) == effective_input_text(second, &
               numbers_only=.true.), 'numbers-only text equal')
    second%progress = .true.
    second%checkpoint = .true.
    call check(suite, effective_input_text(config, numbers_only=.true.) == effective_input_text(second, &
               numbers_only=.true.), 'numbers-only text does not depend on the switches')
    call check(suite, index(effective_input_text(config, numbers_only=.true.), nl // '  progress =') == 0, &
               'numbers-only text without progress')
    err = error_t()
    call parse_input_text("&run output = 'a.h5'," // nl // " progress = 3 /" // nl // "&shape name = 'cone' /", &
                          'h.nml', config, err)
    call check(suite, err%failed, 'progress = 3 rejected')
    if (err%failed) call check(suite, index(err%message, "h.nml line 2: &run progress must be .true. or .false., " // &
                                            "got '3'") > 0, 'progress = 3 named: ' // err%message)
    err = error_t()
    call parse_input_text("&run checkpoint = 'no' /" // nl // "&shape name = 'cone' /", 'i.nml', config, err)
    call check(suite, err%failed, "checkpoint = 'no' rejected")
    if (err%failed) call check(suite, index(err%message, "got ''no''") > 0, "checkpoint = 'no' named: " // err%message)
  end subroutine test_run_switches
  !> error_estimate: whether the input gives it (either value) or leaves it to the driver's default.
  subroutine test_error_estimate_switch()
    type(run_config_t) :: config
    type(error_t) :: err
    character(len=*), parameter :: shape = "&shape name = 'sphere', radius = 2 /" // nl
    call parse_input_text(shape // "&hydrodynamics multipole_order = 3 /", 'e.nml', config, err)
    call check(suite, .not. err%failed .and. .not. config%hydrodynamics%error_estimate_given, &
               'error_estimate left out: not given')
    call parse_input_text(shape // "&hydrodynamics error_estimate = .true. /", 'e.nml', config, err)
    call check(suite, config%hydrodynamics%error_estimate_given .and. config%hydrodynamics%error_estimate, &
               'error_estimate = .true.: given, on')
    call parse_input_text(shape // "&hydrodynamics error_estimate = .false. /", 'e.nml', config, err)
    call check(suite, config%hydrodynamics%error_estimate_given .and. .not. config%hydrodynamics%error_estimate, &
               'error_estimate = .false.: given, off')
  end subroutine test_error_estimate_switch
  !> The input's &hydrodynamics group fills the job's settings type itself, so
  !> an empty group must leave every setting at the type's own default (the library's), apart
  !> from what the group's presence means (enabled) and what the reader resolves by a stated rule
  !> (potential_order = max(L - 2, 0), theory.md T3). A default declared a second time in the
  !> reader, as the lubrication default once was, fails here.
  subroutine test_one_set_of_defaults()
    type(run_config_t) :: config
    type(friction_settings_t) :: library
    type(error_t) :: err
    call parse_input_text("&shape name = 'sphere', radius = 2 /" // nl // "&hydrodynamics /" // nl, 'd.nml', config, err)
    call check(suite, .not. err%failed .and. config%hydrodynamics%enabled, 'an empty &hydrodynamics group enables the job')
    associate (input => config%hydrodynamics)
      call check(suite, input%multipole_order == library%multipole_order, 'same default: multipole_order')
      call check(suite, input%potential_order == max(library%multipole_order - 2, 0), 'potential_order by its rule')
      call check(suite, input%lubrication .eqv. library%lubrication, 'same default: lubrication')
      call check(suite, input%lubrication_cutoff == library%lubrication_cutoff, 'same default: lubrication_cutoff')
      call check(suite, input%bead_forces .eqv. library%bead_forces, 'same default: bead_forces')
      call check(suite, input%cache_file == library%cache_file, 'same default: cache_file')
      call check(suite, input%shell_layers == library%shell_layers, 'same default: shell_layers (left to the plan)')
      call check(suite, input%krylov_rtol == library%krylov_rtol, 'same default: krylov_rtol')
      call check(suite, input%motions_text == library%motions_text .and. all(input%motions .eqv. library%motions), &
                 'same default: motions')
      call check(suite, input%use_symmetry .eqv. library%use_symmetry, 'same default: use_symmetry')
      call check(suite, input%accuracy == library%accuracy, 'same default: accuracy')
      call check(suite, .not. input%error_estimate_given .and. .not. input%choices_given, 'nothing marked as given')
      call check(suite, input%operator_name == library%operator_name .and. input%fft_planner == library%fft_planner &
                 .and. input%pfft_stencil == library%pfft_stencil .and. input%pfft_near_radius == library%pfft_near_radius, &
                 'command-line settings untouched by the input')
    end associate
  end subroutine test_one_set_of_defaults
end program test_input_config
