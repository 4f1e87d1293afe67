!> One beadmob run, from the input file to the result file. Every step that can fail on
!> one rank ends in `agree_on_error`, so the ranks always stop together with one message.
module beadmob_run
  use, intrinsic :: iso_fortran_env, only: error_unit
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_finite
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str, str_significant
  use beadmob_parallel, only: run_context_t, agree_on_error, broadcast_text
  use beadmob_input_config, only: run_config_t, parse_input_text, built_in_source, default_estimate_order, &
                                  effective_input_text
  use beadmob_progress, only: progress_line
  use beadmob_checkpoint_file, only: checkpoint_suffix, remove_checkpoint
  use beadmob_bead_model, only: bead_model_t
  use beadmob_shape_catalog, only: build_bead_model
  use beadmob_geometry_checks, only: check_bead_model
  use beadmob_body_frame, only: body_frame_t, compute_body_frame
  use beadmob_result_file, only: write_result_file, partial_suffix
  use beadmob_file_system, only: probe_writable
  use beadmob_command_line, only: read_command_line, warn_unused_options
  use beadmob_hdf5_support, only: set_hdf5_error_stack
  use beadmob_friction_settings, only: friction_settings_t
  use beadmob_friction_job, only: friction_of_plan, friction_result_t, phase_names
  use beadmob_job_plan, only: job_plan_t, requested_accuracy
  use beadmob_mobility, only: mobility_result_t, compute_mobility, mobility_in_frame
  use beadmob_error_estimate, only: estimate_error, add_operator_error
  use beadmob_flow_response, only: flow_response_of
  use beadmob_brownian_numbers, only: brownian_numbers_of, intrinsic_viscosities
  use beadmob_operator_error_bar, only: estimate_operator_error
  use beadmob_friction_diagnostics, only: diagnose_friction, friction_warning
  use beadmob_accuracy_choice, only: accuracy_choice_t, choose_for_accuracy, max_accuracy_order
  use beadmob_unit_lattice, only: on_unit_lattice
  use beadmob_job_planning, only: plan_friction_job
  use beadmob_continuum_job, only: run_continuum_job
  implicit none
  private
  public :: run_beadmob, read_input_file

contains

  !> `input_path` empty: the built-in default job (the paper's cone).
  subroutine run_beadmob(ctx, input_path, err)
    type(run_context_t), intent(in) :: ctx
    character(len=*), intent(in) :: input_path
    type(error_t), intent(inout) :: err
    type(run_config_t) :: config
    type(bead_model_t) :: model
    type(body_frame_t) :: frame
    type(mobility_result_t) :: mobility
    real(dp) :: companion_mobility(6, 6)
    type(friction_result_t) :: job_result
    type(job_plan_t) :: plan
    type(accuracy_choice_t) :: choice
    character(len=:), allocatable :: text, source

    text = ''
    source = built_in_source
    if (len_trim(input_path) > 0) then
      source = trim(input_path)
      if (ctx%rank == 0) call read_input_file(source, text, err)
      call agree_on_error(ctx, err)
      if (err%failed) return
      call broadcast_text(ctx, text)
    end if
    ! The settings in one place: the input, then the command line (every rank the same: no divergence).
    call parse_input_text(text, source, config, err)
    if (.not. err%failed) call read_command_line(config, err)
    if (err%failed) return
    call set_hdf5_error_stack(config%hdf5_error_stack)
    ! Hydrodynamics only when asked for (&hydrodynamics group, not -geometry_only).
    if (config%geometry_only) config%hydrodynamics%enabled = .false.
    if (config%dry_run .and. .not. config%hydrodynamics%enabled) then
      call raise(err, '--estimate estimates the friction job: the input needs a &hydrodynamics group ' // &
                 '(and no -geometry_only)')
    else if (config%hydrodynamics%accuracy_on_command_line .and. .not. config%hydrodynamics%enabled) then
      call raise(err, '-accuracy needs the friction job (a &hydrodynamics group, no -geometry_only)')
    end if
    if (err%failed) return   ! the same options on every rank
    ! Nothing computed may be lost to an output that cannot be written: look before building.
    if (ctx%rank == 0) call check_output_locations(config, err)
    call agree_on_error(ctx, err)
    if (err%failed) return
    if (config%continuum%enabled) then
      ! A ladder of friction jobs and its extrapolation (continuum_job.f90).
      if (len_trim(config%hydrodynamics%cache_file) == 0) config%hydrodynamics%cache_file = environment_cache_file(ctx)
      call run_continuum_job(ctx, config, err)
      if (.not. err%failed .and. ctx%rank == 0 .and. .not. config%dry_run) call warn_unused_options()
      return
    end if

    call build_bead_model(ctx, config%shape, model, err)
    call agree_on_error(ctx, err)
    if (err%failed) return
    if (config%hydrodynamics%enabled) then
      ! Same options and input on every rank: the same choice (or error) everywhere. (The lattice
      ! test, a pass over the beads, only when a target asks for it.)
      if (config%hydrodynamics%accuracy > 0.0_dp) then
        call apply_accuracy_target(config, on_unit_lattice(model%centres), choice, err)
        if (err%failed) return
      end if
      ! The error bar: as the input says, else up to default_estimate_order and for a target.
      if (.not. config%hydrodynamics%error_estimate_given) config%hydrodynamics%error_estimate = &
        config%hydrodynamics%multipole_order <= default_estimate_order .or. choice%target > 0.0_dp
      if (len_trim(config%hydrodynamics%cache_file) == 0) config%hydrodynamics%cache_file = environment_cache_file(ctx)
    end if

    call check_bead_model(model, config%overlap_tolerance, err)
    if (err%failed) return
    call compute_body_frame(model%centres, frame, err)
    call agree_on_error(ctx, err)
    if (err%failed) return
    if (config%hydrodynamics%enabled) then
      ! Know before you run: the job's plan, made once (job_plan.f90); the dry run stops here, a
      ! job that cannot fit is refused here, before anything large is allocated.
      call plan_friction_job(ctx, config, model%centres, plan, err)
      if (err%failed .or. config%dry_run) return   ! agreed on inside; a dry run writes no result file
      ! The shell the plan chose when the settings left it open (written with the result).
      config%hydrodynamics%shell_layers = plan%shell_layers
    end if
    ! Without a paper value, L is the size along the body x axis (paper: x along L).
    if (model%reference_length <= 0.0_dp) model%reference_length = frame%extent(1)

    if (config%hydrodynamics%enabled) then
      if (config%checkpoint) then
        config%hydrodynamics%checkpoint_file = trim(config%output) // checkpoint_suffix
        config%hydrodynamics%checkpoint_input = effective_input_text(config, numbers_only=.true.)
      end if
      call solve_and_estimate()
      if (err%failed) return
      if (choice%target > 0.0_dp) call meet_accuracy_target()
      if (err%failed) return
      job_result%accuracy = choice
      call progress_line(config%hydrodynamics%progress .and. ctx%rank == 0, 'phase output')
      call write_result_file(ctx, config, model, frame, err, mobility, job_result)
      ! The result is safe: the saved solves are no longer needed (a failed write keeps them).
      if (.not. err%failed .and. config%checkpoint .and. ctx%rank == 0) call remove_checkpoint(trim(config%hydrodynamics%checkpoint_file))
    else
      call write_result_file(ctx, config, model, frame, err)
    end if
    if (err%failed) return
    if (ctx%rank == 0) call print_summary(config, model, frame)
    if (ctx%rank == 0 .and. config%hydrodynamics%enabled) call print_mobility(config, mobility, job_result)
    if (ctx%rank == 0) call warn_unused_options()

  contains

    !> The friction job with the settings as they stand, its diagnostics, mobility and error bar.
    subroutine solve_and_estimate()
        call friction_of_plan(ctx, config%hydrodynamics, plan, job_result, err)
        if (err%failed) return   ! agreed on inside
        ! Flagged in the file and on stderr, never hidden (docs/stress_tests.md); a non-finite
        ! friction has no mobility: NaN there, the file still written with friction_finite = 0.
        job_result%diagnostics = diagnose_friction(job_result%friction)
        job_result%multipole_diagnostics = diagnose_friction(job_result%multipole_friction)
        if (ctx%rank == 0 .and. .not. all(config%hydrodynamics%motions)) then
          write (*, '(a)') "  motions '" // trim(config%hydrodynamics%motions_text) // "' only: the friction " // &
            'entries between motions left out and the mobility are not computed (NaN)'
        else if (ctx%rank == 0) then
          if (config%hydrodynamics%lubrication) call warn(friction_warning(job_result%multipole_diagnostics, &
                                                                           'the order-L friction matrix'))
          call warn(friction_warning(job_result%diagnostics, 'the friction matrix'))
        end if
        if (job_result%multipole_diagnostics%finite) then
          call compute_mobility(job_result%multipole_friction, frame%centre_of_mass, frame%axes, model%reference_length, &
                                mobility, err)
          if (err%failed) return   ! same replicated friction on every rank: same outcome
          job_result%multipole_coefficients = mobility%coefficients
        else
          job_result%multipole_coefficients = ieee_value(1.0_dp, ieee_quiet_nan)
        end if
        if (job_result%diagnostics%finite) then
          call compute_mobility(job_result%friction, frame%centre_of_mass, frame%axes, model%reference_length, mobility, err)
          if (err%failed) return
        else
          mobility = undefined_mobility(job_result%friction)
        end if
        ! The error bar: the companion's mobility in this run's body frame (theory.md T14).
        if (job_result%companion_order > 0 .and. job_result%diagnostics%finite .and. all(ieee_is_finite(job_result%companion_friction))) then
          call mobility_in_frame(job_result%companion_friction, mobility%body_axes, companion_mobility, err)
          if (err%failed) return
          job_result%estimate = estimate_error(mobility%body_mobility, companion_mobility, model%reference_length, &
                                          job_result%companion_order)
        end if
        ! The free body in a linear flow and its bar from the companion (theory.md T19).
        if (job_result%flow) job_result%flow_response = flow_response_of(job_result%grand_resistance, &
          job_result%companion_grand_resistance, job_result%companion_order)
        ! What Brownian motion does (brownian_numbers.f90), with the flow [eta] for the volume of
        ! the lattice cells, N d^3.
        if (job_result%diagnostics%finite .and. all(config%hydrodynamics%motions)) then
          job_result%brownian = brownian_numbers_of(mobility%mobility_at_centre, mobility%centre_of_mobility)
          if (job_result%brownian%available .and. job_result%flow_response%available) then
            job_result%brownian%with_flow = .true.
            job_result%brownian%volume = real(model%n_beads(), dp)
            call intrinsic_viscosities(job_result%flow_response%velocity_per_strain(4:6, :), &
                                       job_result%flow_response%stresslet_per_strain, mobility%mobility(4:6, 4:6), &
                                       job_result%brownian%volume, job_result%brownian%intrinsic_viscosity_high_frequency, &
                                       job_result%brownian%intrinsic_viscosity_zero_shear)
          end if
        end if
        ! The pfft far field's error, measured on a sample of rows, added to the error bar (theory.md T16).
        if (job_result%operator_sample%rows > 0 .and. job_result%diagnostics%finite .and. &
            all(config%hydrodynamics%motions)) then
          job_result%operator_error = estimate_operator_error(job_result%operator_sample%terms, &
                                                              job_result%operator_sample%second, &
                                                              job_result%operator_sample%probability, &
                                                              job_result%operator_sample%every_row, &
                                                              job_result%operator_sample%n_beads, job_result%friction, &
                                                              mobility%mobility, mobility%body_axes, model%reference_length)
          job_result%operator_error%seconds = job_result%operator_sample%seconds
          if (job_result%estimate%available) call add_operator_error(job_result%estimate, &
            job_result%operator_error%scaled_mobility_error, mobility%body_mobility, model%reference_length)
          associate (measured => max(job_result%operator_error%relative_mobility, &
                                     job_result%operator_error%relative_friction), &
                     asked => requested_accuracy(config%hydrodynamics))
            if (measured > asked .and. ctx%rank == 0) write (error_unit, '(a)') 'beadmob: warning: the pfft far ' // &
              'field''s measured error, ' // str_significant(measured, 2) // ' of the largest friction or mobility ' // &
              'entry, is above the ' // str_significant(asked, 2) // ' the job asks for (its Krylov tolerance or ' // &
              'accuracy target); -operator direct, or a larger -pfft_near_radius, meets it (docs/theory.md T16)'
          end associate
        end if
    end subroutine solve_and_estimate

    !> An accuracy target is met when the run's own estimate (the largest over the five
    !> coefficients, theory.md T14) is within it. Otherwise L is raised by one, on the full model
    !> (the shell model's part does not fall with L), while the order is at most
    !> max_accuracy_order and the job fits in memory; the last run is the result.
    subroutine meet_accuracy_target()
      type(error_t) :: refused
      type(job_plan_t) :: raised
      type(friction_settings_t) :: solved
      associate (job => config%hydrodynamics)
      do while (job_result%estimate%available)
        choice%estimated_error = maxval(job_result%estimate%scaled_coefficient_error)
        if (choice%estimated_error <= choice%target .or. job%multipole_order >= max_accuracy_order) exit
        solved = job
        job%multipole_order = job%multipole_order + 1
        job%potential_order = max(job%multipole_order - 2, 0)
        job%shell_layers = 0
        call plan_friction_job(ctx, config, model%centres, raised, refused)
        if (refused%failed) then
          if (ctx%rank == 0) write (error_unit, '(a)') 'beadmob: warning: the accuracy target would need L = ' // &
            str(job%multipole_order) // ', which does not fit: ' // trim(refused%message)
          job = solved   ! the settings of the result that stands
          exit
        end if
        if (ctx%rank == 0) write (*, '(a, es8.1, a, es8.1, a)') 'beadmob: accuracy: estimated error', &
          choice%estimated_error, ' above the target', choice%target, ' at L = ' // str(job%multipole_order - 1) // &
          '; solving again at L = ' // str(job%multipole_order) // ' on the full model'
        plan = raised
        choice%raised_order = job%multipole_order
        if (config%checkpoint) then
          ! The lower order's saves are of a finished job: not a stale checkpoint to warn about.
          job%checkpoint_input = effective_input_text(config, numbers_only=.true.)
          if (ctx%rank == 0) call remove_checkpoint(trim(job%checkpoint_file))
          call agree_on_error(ctx, refused)   ! collective: no rank opens it before it is gone
        end if
        call solve_and_estimate()
        if (err%failed) return
      end do
      end associate
      if (job_result%estimate%available) then
        choice%estimated_error = maxval(job_result%estimate%scaled_coefficient_error)
        choice%target_met = choice%estimated_error <= choice%target
      end if
    end subroutine meet_accuracy_target
  end subroutine run_beadmob

  !> An accuracy target (&hydrodynamics accuracy > 0, or -accuracy on the command line, which wins)
  !> sets L, the sigma = 2 degree, the shell and the Krylov tolerance to the cheapest candidate
  !> the benchmark data say reaches it (accuracy_choice.f90). It refuses to share these choices
  !> with the input or -ksp_rtol: the promise holds only for the settings it chose.
  subroutine apply_accuracy_target(config, on_lattice, choice, err)
    type(run_config_t), intent(inout) :: config
    logical, intent(in) :: on_lattice
    type(accuracy_choice_t), intent(out) :: choice
    type(error_t), intent(inout) :: err
    associate (job => config%hydrodynamics)
      if (job%accuracy_on_command_line .and. job%choices_given) then
        call raise(err, '-accuracy chooses multipole_order, potential_order, shell_layers and krylov_rtol; ' // &
                   config%source // ' sets some of them: give either -accuracy or those')
        return
      else if (job%krylov_rtol_on_command_line) then
        call raise(err, '-ksp_rtol would override the Krylov tolerance the accuracy target chooses: ' // &
                   'give one or the other')
        return
      end if
      call choose_for_accuracy(job%accuracy, job%lubrication, on_lattice .and. .not. job%bead_forces, &
                               choice, err)
      if (err%failed) return
      job%multipole_order = choice%order
      job%potential_order = max(choice%order - 2, 0)
      job%shell_layers = choice%shell_layers
      job%krylov_rtol = choice%krylov_rtol
    end associate
  end subroutine apply_accuracy_target

  !> The files a run writes, tried before anything is built (call on one rank): the result's
  !> temporary '<output>.partial' (renamed over '<output>' when complete) and, for the friction
  !> job, the checkpoint.
  subroutine check_output_locations(config, err)
    type(run_config_t), intent(in) :: config
    type(error_t), intent(inout) :: err
    character(len=:), allocatable :: reason
    logical :: exists
    call probe_writable(trim(config%output) // partial_suffix, reason)
    if (len(reason) > 0) then
      call raise(err, "cannot write the result file '" // trim(config%output) // "': " // reason)
      return
    end if
    ! A directory of that name would refuse the final rename ('name/.' exists only for one).
    inquire (file=trim(config%output) // '/.', exist=exists)
    if (exists) then
      call raise(err, "the result file '" // trim(config%output) // "' is the name of a directory")
      return
    end if
    if (.not. (config%checkpoint .and. config%hydrodynamics%enabled)) return
    call probe_writable(trim(config%output) // checkpoint_suffix, reason)
    if (len(reason) > 0) call raise(err, "cannot write the checkpoint '" // trim(config%output) // &
                                    checkpoint_suffix // "' (&run checkpoint = .false. runs without one): " // reason)
  end subroutine check_output_locations

  subroutine print_mobility(config, mobility, job_result)
    type(run_config_t), intent(in) :: config
    type(mobility_result_t), intent(in) :: mobility
    type(friction_result_t), intent(in) :: job_result
    integer :: phase, k
    write (*, '(a)') '  hydrodynamics: multipole order L = ' // str(config%hydrodynamics%multipole_order) // &
      ' (sigma = 2 family to degree ' // str(config%hydrodynamics%potential_order) // ', ' // &
      str(job_result%unknowns_per_bead) // ' unknowns per bead), lubrication ' // &
      lubrication_summary(config%hydrodynamics%lubrication, job_result%lubrication_pairs)
    if (job_result%accuracy%target > 0.0_dp) then
      write (*, '(a, es8.1, a, es8.1, a)') '  accuracy target', job_result%accuracy%target, ': setting ' // &
        trim(job_result%accuracy%setting) // ', expected error', job_result%accuracy%expected_error, &
        ' (bench/accuracy/accuracy.md, against ' // trim(job_result%accuracy%reference) // ')'
      if (job_result%accuracy%estimated_error >= 0.0_dp) write (*, '(a, es8.1, a)') '  accuracy: the run''s own ' // &
        'estimated error', job_result%accuracy%estimated_error, merge(' meets the target      ', ' misses the target     ', &
                                                                 job_result%accuracy%target_met)
      if (.not. job_result%accuracy%target_met) write (error_unit, '(a)') 'beadmob: warning: the accuracy target ' // &
        'is not met (no measured setting promises it, or the run''s own estimate exceeds it at the highest order tried)'
    end if
    if (config%hydrodynamics%shell_layers > 0) write (*, '(a)') '  shell model: ' // str(job_result%hydrodynamic_beads) // &
      ' beads within ' // str(config%hydrodynamics%shell_layers) // ' layer(s) of the surface'
    write (*, '(a)') '  operator: ' // trim(job_result%operator_name) // &
      trim(merge(' (by mirror class)', '                  ', job_result%by_mirror_class)) // &
      trim(merge(' (whole on every rank)', '                      ', job_result%replicated_products)) // ', Krylov method ' // &
      trim(job_result%solves%ksp_type) // ', preconditioner ' // trim(job_result%solves%pc_type)
    write (*, '(a, 6i5)') '  Krylov iterations: ', job_result%solves%iterations
    if (any(job_result%solves%resumed == 1)) write (*, '(a)') '  resumed ' // str(count(job_result%solves%resumed == 1)) // &
      ' motions from the checkpoint ' // trim(config%output) // checkpoint_suffix // ' (solved ' // &
      str(count(job_result%solves%source == 0 .and. job_result%solves%resumed == 0)) // ')'
    if (any(job_result%solves%source /= 0)) write (*, '(a, i0, a, 6i3, a)') '  symmetries of the bead set: ', &
      job_result%symmetry_group_order, '; motions derived, not solved (from):', job_result%solves%source, &
      ' (0 = solved, -1 = not computed)'
    write (*, '(a, es10.2)') '  largest true relative residual: ', maxval(job_result%solves%true_relative_residual)
    write (*, '(a, es10.2)') '  friction symmetry error: ', mobility%symmetry_error
    write (*, '(a, 5f10.4)') '  mu11 mu22 mu33 mu42 mu51:', mobility%coefficients
    if (job_result%estimate%available) then
      write (*, '(a, 5f10.4)') '  estimated error (+-):    ', job_result%estimate%coefficient_error
      write (*, '(a, 5f10.4)') '  extrapolated in L:       ', job_result%estimate%extrapolated_coefficients
      write (*, '(a, 5f10.4)') '  its error (+-):          ', job_result%estimate%extrapolated_coefficient_error
      write (*, '(a, es8.1, a, es8.1, a)') '  estimated error of the mobility:', job_result%estimate%largest, &
        ' (extrapolated', job_result%estimate%largest_extrapolated, '), largest entry on the scale sqrt(M_ii M_jj); ' // &
        'companion order L = ' // str(job_result%estimate%companion_order)
    else if (config%hydrodynamics%multipole_order == 1) then
      write (*, '(a)') '  estimated error: none at L = 1 (no lower order to compare with)'
    else if (.not. config%hydrodynamics%error_estimate) then
      write (*, '(a)') '  estimated error: not computed (error_estimate = .false.; on by default up to L = ' // &
        str(default_estimate_order) // ', docs/theory.md T14)'
    end if
    if (job_result%operator_error%available) write (*, '(a, es8.1, a, es8.1, a)') '  far-field (pfft) error:', &
      job_result%operator_error%relative_mobility, ' of the largest mobility entry,', job_result%operator_error%largest, &
      ' on the scale sqrt(M_ii M_jj)' // trim(merge(', in the error bar', '                  ', &
      job_result%estimate%available)) // ' (exact rows of ' // str(job_result%operator_error%rows) // ' of ' // &
      str(job_result%operator_error%n_beads) // ' beads, docs/theory.md T16)'
    if (job_result%flow_response%available) then
      associate (r => job_result%flow_response)
      write (*, '(a)') '  free body in a linear flow (/flow, docs/theory.md T19), per unit strain amplitude E_1 ... E_5:'
      write (*, '(a, 5es11.3)') '    stresslet, diagonal:   ', [(r%stresslet_per_strain(k, k), k=1, 5)]
      if (r%companion_order > 0) write (*, '(a, 5es11.3)') '    its error (+-):       ', &
        [(r%stresslet_per_strain_error(k, k), k=1, 5)]
      write (*, '(a, es11.3, a, es9.2, a)') '    largest rotation |Omega - Omega0|:', maxval(abs(r%velocity_per_strain(4:6, :))), &
        ' (+-', maxval(r%velocity_per_strain_error(4:6, :)), ')'
      end associate
      if (any(job_result%strain_solves%converged_reason <= 0)) write (error_unit, '(a, 5i4, a)') &
        'beadmob: warning: not every strain solve converged (reasons ', job_result%strain_solves%converged_reason, &
        '); the result file flags it: /flow all_converged = 0'
    end if
    if (len_trim(job_result%cache_file) > 0) write (*, '(a)') '  table cache ' // trim(job_result%cache_file) // ': ' // &
      str(job_result%cached_blocks) // ' blocks read, ' // str(job_result%computed_blocks) // ' computed; lubrication ' // &
      str(job_result%lubrication_table%cached_distances) // ' distances read, ' // &
      str(job_result%lubrication_table%computed_distances) // ' computed'
    write (*, '(a, f0.1, a)') '  peak memory (largest rank): ', job_result%peak_memory_bytes / 2.0_dp**20, ' MiB'
    write (*, '(a, *(a, f0.2, :, ","))') '  wall time (s):', (' ' // trim(phase_names(phase)) // ' ', &
      job_result%seconds(phase), phase = 1, size(phase_names))
    if (any(job_result%solves%converged_reason <= 0 .and. job_result%solves%source >= 0)) write (error_unit, '(a, 6i4, a)') &
      'beadmob: warning: not every Krylov solve converged (reasons ', job_result%solves%converged_reason, &
      '); the result file flags it: /hydrodynamics all_converged = 0'
  end subroutine print_mobility

  subroutine warn(text)
    character(len=*), intent(in) :: text
    if (len(text) > 0) write (error_unit, '(a)') 'beadmob: warning: ' // text
  end subroutine warn

  !> The mobility of a non-finite friction: every derived quantity NaN (quiet: no trap).
  function undefined_mobility(friction) result(mobility)
    real(dp), intent(in) :: friction(6, 6)
    type(mobility_result_t) :: mobility
    real(dp) :: nan
    nan = ieee_value(1.0_dp, ieee_quiet_nan)
    mobility%friction = friction
    mobility%mobility = nan
    mobility%symmetry_error = nan
    mobility%body_axes = nan
    mobility%body_mobility = nan
    mobility%coefficients = nan
    mobility%off_pattern = nan
    mobility%centre_of_mobility = nan
    mobility%mobility_at_centre = nan
  end function undefined_mobility

  !> BEADMOB_CACHE ('' when unset), as rank 0 sees it: the ranks must agree on caching.
  function environment_cache_file(ctx) result(path)
    type(run_context_t), intent(in) :: ctx
    character(len=:), allocatable :: path
    integer :: length, status
    path = ''
    if (ctx%rank == 0) then
      call get_environment_variable('BEADMOB_CACHE', length=length, status=status)
      if (status == 0 .and. length > 0) then
        deallocate (path)
        allocate (character(len=length) :: path)
        call get_environment_variable('BEADMOB_CACHE', path)
      end if
    end if
    call broadcast_text(ctx, path)
  end function environment_cache_file

  pure function lubrication_summary(enabled, pairs) result(text)
    logical, intent(in) :: enabled
    integer, intent(in) :: pairs
    character(len=:), allocatable :: text
    text = 'off'
    if (enabled) text = 'on (' // str(pairs) // ' pairs)'
  end function lubrication_summary

  subroutine read_input_file(path, text, err)
    character(len=*), intent(in) :: path
    character(len=:), allocatable, intent(out) :: text
    type(error_t), intent(inout) :: err
    integer :: unit, status, file_size
    character(len=512) :: message
    open (newunit=unit, file=path, status='old', action='read', access='stream', form='unformatted', &
          iostat=status, iomsg=message)
    if (status /= 0) then
      text = ''
      call raise(err, "cannot open input file '" // path // "': " // trim(message))
      return
    end if
    inquire (unit=unit, size=file_size)
    allocate (character(len=max(file_size, 0)) :: text)
    if (file_size > 0) read (unit, iostat=status, iomsg=message) text
    close (unit)
    if (status /= 0) call raise(err, "cannot read input file '" // path // "': " // trim(message))
    if (status == 0 .and. len_trim(text) == 0) call raise(err, "input file '" // path // "' is empty")
  end subroutine read_input_file

  subroutine print_summary(config, model, frame)
    type(run_config_t), intent(in) :: config
    type(bead_model_t), intent(in) :: model
    type(body_frame_t), intent(in) :: frame
    character(len=*), parameter :: vector_format = '(a, 3f12.4)'
    write (*, '(a)') 'beadmob: shape ' // model%shape_name // ' (' // model%source // ')'
    write (*, '(a)') '  beads:             ' // str(model%n_beads())
    write (*, vector_format) '  centre of mass:   ', frame%centre_of_mass
    write (*, vector_format) '  extent x, y, z:   ', frame%extent
    write (*, vector_format) '  body x axis:      ', frame%axes(:, 1)
    write (*, vector_format) '  body z axis:      ', frame%axes(:, 3)
    write (*, '(a, 3l2, a, l1)') '  mirror planes x,y,z:', frame%mirror_plane, '   paper class: ', frame%paper_class
    write (*, '(a, f10.4)') '  reference length L (d): ', model%reference_length
    write (*, '(a)') '  result written to ' // trim(config%output)
  end subroutine print_summary
end module beadmob_run
