!> The result file of a run (schema in docs/output.md). Written collectively with
!> parallel HDF5 to '<output>.partial' and renamed to '<output>' only when complete, so a
!> failed run never leaves a half-written result under the requested name.
module beadmob_result_file
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_positive_inf
  use hdf5, only: hid_t
  use mpi, only: MPI_Barrier
  use beadmob_file_system, only: rename_file, remove_file
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str, either
  use beadmob_parallel, only: run_context_t, block_range, agree_on_error
  use beadmob_build_info, only: program_version, git_hash
  use beadmob_input_config, only: run_config_t, effective_input_text
  use beadmob_bead_model, only: bead_model_t
  use beadmob_body_frame, only: body_frame_t
  use beadmob_mobility, only: mobility_result_t
  use beadmob_rigid_body_solve, only: motion_names
  use beadmob_friction_job, only: friction_result_t, phase_names
  use beadmob_error_estimate, only: error_estimate_t, entry_factor, block_factor, extrapolation_ratio, &
                                    extrapolated_entry_factor, extrapolated_block_factor
  use beadmob_friction_diagnostics, only: friction_diagnostics_t, condition_threshold, asymmetry_threshold
  use beadmob_operator_error_bar, only: spread_factor, second_order_mid, second_order_half, coverage
  use beadmob_operator_error, only: operator_sample_t
  use beadmob_continuum_fit, only: continuum_result_t
  use beadmob_linear_flow, only: n_strain_modes, strain_mode
  use beadmob_brownian_numbers, only: brownian_numbers_t
  use beadmob_hdf5_support, only: h5_create_parallel, h5_close_file, h5_create_group, h5_close_group, &
                                  write_attribute, write_text_dataset, write_replicated_dataset, &
                                  write_distributed_columns
  implicit none
  private
  public :: write_result_file, result_format, result_format_version, partial_suffix

  character(len=*), parameter :: result_format = 'beadmob-result'
  integer, parameter :: result_format_version = 1
  character(len=*), parameter :: partial_suffix = '.partial'

contains

  !> Collective. On failure the partial file is removed and `err` holds the same message on all ranks.
  subroutine write_result_file(ctx, config, model, frame, err, mobility, job_result, continuum)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: config
    type(bead_model_t), intent(in) :: model
    type(body_frame_t), intent(in) :: frame
    type(error_t), intent(inout) :: err
    type(mobility_result_t), intent(in), optional :: mobility
    type(friction_result_t), intent(in), optional :: job_result
    !> A continuum job's ladder and values (the geometry is then its finest level without offset)
    type(continuum_result_t), intent(in), optional :: continuum
    character(len=:), allocatable :: final_path, partial_path
    integer(hid_t) :: file_id
    integer :: ierr

    final_path = trim(config%output)
    partial_path = final_path // partial_suffix
    call h5_create_parallel(ctx, partial_path, file_id, err)
    call agree_on_error(ctx, err)
    if (err%failed) return
    call write_metadata(ctx, file_id, config, err)
    call write_shape(file_id, model, err)
    call write_geometry(ctx, file_id, model, frame, err)
    if (present(mobility) .and. present(job_result)) &
      call write_hydrodynamics(ctx, file_id, config, model%n_beads(), mobility, job_result, err)
    if (present(job_result)) then
      if (job_result%flow) call write_flow(ctx, file_id, config, job_result, err)
      if (job_result%brownian%available) call write_diffusion(ctx, file_id, job_result%brownian, err)
    end if
    if (present(continuum)) call write_continuum(ctx, file_id, continuum, err)
    call h5_close_file(file_id, err)
    call agree_on_error(ctx, err)
    call MPI_Barrier(ctx%comm, ierr)
    if (ctx%rank == 0) then
      if (err%failed) then
        call remove_file(partial_path)
      else if (.not. rename_file(partial_path, final_path)) then
        call raise(err, "cannot rename '" // partial_path // "' to '" // final_path // "'")
        call remove_file(partial_path)
      end if
    end if
    call agree_on_error(ctx, err)
  end subroutine write_result_file

  subroutine write_metadata(ctx, file_id, config, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(in) :: file_id
    type(run_config_t), intent(in) :: config
    type(error_t), intent(inout) :: err
    integer(hid_t) :: group
    call write_attribute(file_id, 'format', result_format, err)
    call write_attribute(file_id, 'format_version', result_format_version, err)
    call write_attribute(file_id, 'program_version', program_version, err)
    call write_attribute(file_id, 'git_hash', git_hash, err)
    call write_attribute(file_id, 'created', timestamp(), err)
    call write_attribute(file_id, 'mpi_ranks', ctx%n_ranks, err)

    call h5_create_group(file_id, 'input', group, err)
    call write_attribute(group, 'source', config%source, err)
    call write_text_dataset(ctx, group, 'namelist', config%text, err)
    call write_text_dataset(ctx, group, 'effective_namelist', effective_input_text(config), err)
    call h5_close_group(group, err)

    call h5_create_group(file_id, 'units', group, err)
    call write_attribute(group, 'length', 'd (bead diameter; bead radius a = d/2)', err)
    call write_attribute(group, 'bead_diameter', 1.0_dp, err)
    call h5_close_group(group, err)
  end subroutine write_metadata

  subroutine write_shape(file_id, model, err)
    integer(hid_t), intent(in) :: file_id
    type(bead_model_t), intent(in) :: model
    type(error_t), intent(inout) :: err
    integer(hid_t) :: group
    integer :: k
    call h5_create_group(file_id, 'shape', group, err)
    call write_attribute(group, 'name', model%shape_name, err)
    call write_attribute(group, 'source', model%source, err)
    call write_attribute(group, 'reference_length', model%reference_length, err)
    do k = 1, size(model%parameters)
      call write_attribute(group, trim(model%parameters(k)%name), model%parameters(k)%value, err)
    end do
    call h5_close_group(group, err)
  end subroutine write_shape

  subroutine write_geometry(ctx, file_id, model, frame, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(in) :: file_id
    type(bead_model_t), intent(in) :: model
    type(body_frame_t), intent(in) :: frame
    type(error_t), intent(inout) :: err
    integer(hid_t) :: group
    integer(i8) :: first, count
    call h5_create_group(file_id, 'geometry', group, err)
    call write_attribute(group, 'n_beads', model%n_beads(), err)
    call write_attribute(group, 'paper_class', merge(1, 0, frame%paper_class), err)
    call block_range(ctx, model%n_beads(), first, count)
    call write_distributed_columns(group, 'positions', model%centres(:, first:first + count - 1), first, &
                                   model%n_beads(), err)
    call write_replicated_dataset(ctx, group, 'centre_of_mass', frame%centre_of_mass, err)
    call write_replicated_dataset(ctx, group, 'body_axes', frame%axes, err)
    call write_replicated_dataset(ctx, group, 'extent', frame%extent, err)
    call write_replicated_dataset(ctx, group, 'mirror_planes', merge(1.0_dp, 0.0_dp, frame%mirror_plane), err)
    call h5_close_group(group, err)
  end subroutine write_geometry

  subroutine write_hydrodynamics(ctx, file_id, config, n_beads, mobility, job_result, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(in) :: file_id
    integer(i8), intent(in) :: n_beads
    type(run_config_t), intent(in) :: config
    type(mobility_result_t), intent(in) :: mobility
    type(friction_result_t), intent(in) :: job_result
    type(error_t), intent(inout) :: err
    integer(hid_t) :: group
    integer :: k
    integer(i8) :: first, count
    character(len=:), allocatable :: names
    call h5_create_group(file_id, 'hydrodynamics', group, err)
    call write_attribute(group, 'multipole_order', config%hydrodynamics%multipole_order, err)
    call write_attribute(group, 'potential_order', config%hydrodynamics%potential_order, err)
    call write_attribute(group, 'unknowns_per_bead', job_result%unknowns_per_bead, err)
    call write_attribute(group, 'lubrication', merge(1, 0, config%hydrodynamics%lubrication), err)
    names = 'multipole method (Cichocki et al. 1994), Galerkin form, order L = ' // &
            str(config%hydrodynamics%multipole_order)
    if (config%hydrodynamics%lubrication) names = names // ', with rigid-doublet lubrication correction'
    call write_attribute(group, 'method', names, err)
    call write_attribute(group, 'units', 'eta = 1, lengths in d; friction maps (U, Omega) to (F, T)', err)
    call write_attribute(group, 'reference_point', 'centre of mass', err)
    call write_attribute(group, 'symmetry_error', mobility%symmetry_error, err)
    call write_diagnostics(group, 'friction', job_result%diagnostics, err)
    call write_diagnostics(group, 'multipole_friction', job_result%multipole_diagnostics, err)
    call write_attribute(group, 'friction_condition_threshold', condition_threshold, err)
    call write_attribute(group, 'friction_asymmetry_threshold', asymmetry_threshold, err)
    call write_attribute(group, 'off_pattern', mobility%off_pattern, err)
    call write_attribute(group, 'z_reversed', merge(1, 0, mobility%z_reversed), err)
    call write_attribute(group, 'coefficient_names', 'mu11 mu22 mu33 mu42 mu51', err)
    ! HDF5 stores in C order: a Fortran array appears transposed to C/Python readers, so the 6x6
    ! matrices are written transposed to read as documented, [row, column]. body_axes is not: its
    ! Fortran columns (the axes) are then the rows readers see.
    call write_replicated_dataset(ctx, group, 'friction', transpose(mobility%friction), err)
    call write_replicated_dataset(ctx, group, 'multipole_friction', transpose(job_result%multipole_friction), err)
    call write_replicated_dataset(ctx, group, 'mobility', transpose(mobility%mobility), err)
    call write_replicated_dataset(ctx, group, 'body_axes', mobility%body_axes, err)
    call write_replicated_dataset(ctx, group, 'body_mobility', transpose(mobility%body_mobility), err)
    call write_replicated_dataset(ctx, group, 'coefficients', mobility%coefficients, err)
    call write_replicated_dataset(ctx, group, 'centre_of_mobility', mobility%centre_of_mobility, err)
    call write_replicated_dataset(ctx, group, 'mobility_at_centre_of_mobility', transpose(mobility%mobility_at_centre), err)
    names = motion_names(1)
    do k = 2, 6
      names = names // ' ' // motion_names(k)
    end do
    call write_attribute(group, 'solve_motions', names, err)
    ! The motions are along these axes (columns): the identity, or the body axes of an
    ! off-lattice body solved in its body frame (job_plan.f90, choose_solve_frame).
    call write_replicated_dataset(ctx, group, 'solve_axes', transpose(job_result%solve_axes), err)
    call write_attribute(group, 'solve_iterations', job_result%solves%iterations, err)
    ! The plan the job ran (job_plan.f90), as the dry run prints it: its solves after symmetries
    ! and its estimate of memory and time.
    call write_attribute(group, 'planned_solves', job_result%planned_solves, err)
    call write_attribute(group, 'estimated_peak_memory_bytes', job_result%estimated_peak_memory_bytes, err)
    call write_attribute(group, 'estimated_seconds', job_result%estimated_seconds, err)
    ! 0: solved; m: derived from motion m by a symmetry of the bead set (motion_symmetry.F90).
    call write_attribute(group, 'solve_source', job_result%solves%source, err)
    ! 1: the solution was loaded from the checkpoint of an interrupted run (checkpoint_file.f90).
    call write_attribute(group, 'resumed_motions', job_result%solves%resumed, err)
    call write_attribute(group, 'symmetry_group_order', job_result%symmetry_group_order, err)
    call write_attribute(group, 'use_symmetry', merge(1, 0, config%hydrodynamics%use_symmetry), err)
    call write_attribute(group, 'solve_converged_reason', job_result%solves%converged_reason, err)
    call write_attribute(group, 'solve_true_relative_residual', job_result%solves%true_relative_residual, err)
    call write_attribute(group, 'ksp_type', trim(job_result%solves%ksp_type), err)
    call write_attribute(group, 'solved_together', job_result%solves%solved_together, err)
    call write_attribute(group, 'deflation_vectors', job_result%solves%deflation_vectors, err)
    call write_attribute(group, 'pc_type', trim(job_result%solves%pc_type), err)
    call write_attribute(group, 'ksp_relative_tolerance', job_result%solves%relative_tolerance, err)
    call write_attribute(group, 'plain_symmetry_error', job_result%solves%plain_symmetry_error, err)
    call write_attribute(group, 'variational_correction', job_result%solves%variational_correction, err)
    ! The solver's promise (theory.md T5, "Solver error bound"): |zeta_mn - zeta_mn(exact solve)|
    ! <= solver_error_bound sqrt(zeta_mm zeta_nn), for the order-L friction and the friction.
    call write_attribute(group, 'solve_natural_relative_residual', job_result%solves%natural_relative_residual, err)
    call write_attribute(group, 'condition_estimate', job_result%solves%condition_estimate, err)
    call write_attribute(group, 'solver_error_bound', job_result%solves%solver_error_bound, err)
    ! Motions not computed (solve_source -1) have no solve to converge.
    call write_attribute(group, 'all_converged', merge(1, 0, all(job_result%solves%converged_reason > 0 .or. &
                                                                  job_result%solves%source < 0)), err)
    call write_attribute(group, 'motions', trim(config%hydrodynamics%motions_text), err)
    call write_attribute(group, 'operator', trim(job_result%operator_name), err)
    if (allocated(job_result%operator_reason)) call write_attribute(group, 'operator_choice', &
                                                                     job_result%operator_reason, err)
    call write_attribute(group, 'near_field_radius', job_result%near_field_radius, err)
    ! the pfft operator's far-field settings (0 for the other operators: no approximation)
    call write_attribute(group, 'pfft_stencil', job_result%pfft_stencil, err)
    call write_attribute(group, 'pfft_near_radius', job_result%pfft_near_radius, err)
    call write_operator_error(ctx, group, job_result, err)
    call write_attribute(group, 'near_field_cluster', job_result%near_field_cluster, err)
    call write_attribute(group, 'shell_layers', config%hydrodynamics%shell_layers, err)
    call write_attribute(group, 'krylov_rtol_setting', config%hydrodynamics%krylov_rtol, err)
    ! accuracy_target 0: none asked for; otherwise the choice and the error the data promise
    ! (bench/accuracy/accuracy.md, against the reference run named by accuracy_reference).
    call write_attribute(group, 'accuracy_target', job_result%accuracy%target, err)
    if (job_result%accuracy%target > 0.0_dp) then
      call write_attribute(group, 'accuracy_setting', trim(job_result%accuracy%setting), err)
      call write_attribute(group, 'accuracy_expected_error', job_result%accuracy%expected_error, err)
      call write_attribute(group, 'accuracy_target_met', merge(1, 0, job_result%accuracy%target_met), err)
      call write_attribute(group, 'accuracy_reference', trim(job_result%accuracy%reference), err)
      call write_attribute(group, 'accuracy_estimated_error', job_result%accuracy%estimated_error, err)
      call write_attribute(group, 'accuracy_raised_order', job_result%accuracy%raised_order, err)
    end if
    call write_estimate(ctx, group, config, job_result, err)
    call write_attribute(group, 'hydrodynamic_beads', job_result%hydrodynamic_beads, err)
    call write_attribute(group, 'near_field_pairs', int(job_result%near_field_pairs), err)
    call write_attribute(group, 'on_lattice', merge(1, 0, job_result%on_lattice), err)
    call write_attribute(group, 'computed_blocks', int(job_result%computed_blocks), err)
    call write_attribute(group, 'cached_blocks', int(job_result%cached_blocks), err)
    call write_attribute(group, 'cache_file', trim(job_result%cache_file), err)
    call write_attribute(group, 'fft_plans_from_wisdom', merge(1, 0, job_result%plans_from_wisdom), err)
    call write_attribute(group, 'fft_by_mirror_class', merge(1, 0, job_result%by_mirror_class), err)
    call write_attribute(group, 'replicated_products', merge(1, 0, job_result%replicated_products), err)
    names = trim(phase_names(1))
    do k = 2, size(phase_names)
      names = names // ' ' // trim(phase_names(k))
    end do
    call write_attribute(group, 'phase_names', names, err)
    call write_attribute(group, 'phase_seconds', job_result%seconds, err)
    call write_attribute(group, 'peak_memory_bytes', job_result%peak_memory_bytes, err)
    call write_attribute(group, 'phase_peak_memory_bytes', job_result%phase_peak_memory_bytes, err)
    if (config%hydrodynamics%lubrication) then
      call write_attribute(group, 'lubrication_cutoff', config%hydrodynamics%lubrication_cutoff, err)
      call write_attribute(group, 'lubrication_pairs', job_result%lubrication_pairs, err)
      call write_attribute(group, 'lubrication_reference_order', job_result%lubrication_reference_order, err)
      call write_attribute(group, 'lubrication_cached_distances', job_result%lubrication_table%cached_distances, err)
      call write_attribute(group, 'lubrication_computed_distances', job_result%lubrication_table%computed_distances, err)
      call write_replicated_dataset(ctx, group, 'multipole_coefficients', job_result%multipole_coefficients, err)
      if (size(job_result%lubrication_table%distances) > 0) then
        call write_replicated_dataset(ctx, group, 'lubrication_distances', job_result%lubrication_table%distances, err)
        call write_replicated_dataset(ctx, group, 'lubrication_corrections', job_result%lubrication_table%correction, err)
      end if
    end if
    if (allocated(job_result%bead_forces)) then
      ! Same bead partition as the solve; C-order readers see (N, 36): bead, 6 (motion - 1) + component.
      call block_range(ctx, n_beads, first, count)
      call write_distributed_columns(group, 'bead_forces', job_result%bead_forces, first, n_beads, err)
    end if
    call h5_close_group(group, err)
  end subroutine write_hydrodynamics

  !> The group /diffusion (docs/output.md; brownian_numbers.f90): what Brownian motion does.
  subroutine write_diffusion(ctx, file_id, numbers, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(in) :: file_id
    type(brownian_numbers_t), intent(in) :: numbers
    type(error_t), intent(inout) :: err
    integer(hid_t) :: group
    call h5_create_group(file_id, 'diffusion', group, err)
    call write_attribute(group, 'units', 'eta = kT = 1, lengths in d (beadmob-post diffusion gives physical units)', err)
    call write_attribute(group, 'method', 'the order-L mobility about the centre of mobility (= centre of diffusion, ' // &
                         'Harvey & Garcia de la Torre 1980); relaxation times of Favro 1960; with /flow, [eta] of ' // &
                         'docs/postprocessing.md for the volume of the lattice cells (N d^3)', err)
    call write_replicated_dataset(ctx, group, 'centre_of_diffusion', numbers%centre_of_diffusion, err)
    call write_attribute(group, 'translational_diffusion', numbers%translational_diffusion, err)
    call write_attribute(group, 'stokes_radius', numbers%stokes_radius, err)
    call write_replicated_dataset(ctx, group, 'rotational_diffusion', numbers%rotational_diffusion, err)
    ! C-order readers see the axes as rows
    call write_replicated_dataset(ctx, group, 'rotational_axes', numbers%rotational_axes, err)
    call write_replicated_dataset(ctx, group, 'relaxation_times', numbers%relaxation_times, err)
    call write_attribute(group, 'harmonic_mean_relaxation_time', numbers%harmonic_mean_relaxation_time, err)
    if (numbers%with_flow) then
      call write_attribute(group, 'volume', numbers%volume, err)
      call write_attribute(group, 'intrinsic_viscosity_high_frequency', numbers%intrinsic_viscosity_high_frequency, err)
      call write_attribute(group, 'intrinsic_viscosity_zero_shear', numbers%intrinsic_viscosity_zero_shear, err)
    end if
    call h5_close_group(group, err)
  end subroutine write_diffusion

  !> The group /flow (docs/output.md; theory.md T19): the body in an ambient linear flow.
  subroutine write_flow(ctx, file_id, config, job_result, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(in) :: file_id
    type(run_config_t), intent(in) :: config
    type(friction_result_t), intent(in) :: job_result
    type(error_t), intent(inout) :: err
    integer(hid_t) :: group
    real(dp) :: modes(3, 3, n_strain_modes)
    integer :: k
    do k = 1, n_strain_modes
      modes(:, :, k) = strain_mode(k)
    end do
    associate (response => job_result%flow_response, strains => job_result%strain_solves)
    call h5_create_group(file_id, 'flow', group, err)
    call write_attribute(group, 'method', 'the five strain modes as right-hand sides of the order-L multipole ' // &
                         'system beside the six rigid motions; grand resistance in the variational form, free body ' // &
                         'by its Schur complement (docs/theory.md T19)', err)
    call write_attribute(group, 'units', 'eta = 1, lengths in d; velocity_per_strain: (U - u0(R0), Omega - Omega0) ' // &
                         'per unit strain amplitude; stresslet_per_strain: Batchelor''s particle stresslet ' // &
                         'amplitudes per unit strain amplitude', err)
    call write_attribute(group, 'reference_point', 'centre of mass', err)
    call write_attribute(group, 'strain_mode_names', 'E_1 E_2 E_3 E_4 E_5', err)
    call write_attribute(group, 'multipole_order', config%hydrodynamics%multipole_order, err)
    call write_attribute(group, 'companion_order', response%companion_order, err)
    call write_attribute(group, 'response_available', merge(1, 0, response%available), err)
    call write_attribute(group, 'strain_iterations', strains%iterations, err)
    call write_attribute(group, 'strain_converged_reason', strains%converged_reason, err)
    call write_attribute(group, 'strain_true_relative_residual', strains%true_relative_residual, err)
    call write_attribute(group, 'strain_condition_estimate', strains%condition_estimate, err)
    call write_attribute(group, 'strain_solved_together', strains%solved_together, err)
    call write_attribute(group, 'strain_deflation_vectors', strains%deflation_vectors, err)
    call write_attribute(group, 'strain_resumed', strains%resumed, err)
    call write_attribute(group, 'strain_derived_from', strains%source, err)
    call write_attribute(group, 'plain_symmetry_error', strains%plain_symmetry_error, err)
    call write_attribute(group, 'stresslet_asymmetry', response%stresslet_asymmetry, err)
    call write_attribute(group, 'bead_stresslets', trim(merge('Faxen''s law in the RPY fields (order 1)', &
                         'the strain densities of the basis      ', config%hydrodynamics%multipole_order == 1)), err)
    call write_attribute(group, 'all_converged', merge(1, 0, all(strains%converged_reason > 0)), err)
    ! C-order readers see (5, 3, 3): mode k is strain_modes[k] (symmetric, so no transpose needed).
    call write_replicated_dataset(ctx, group, 'strain_modes', modes, err)
    call write_replicated_dataset(ctx, group, 'grand_resistance', transpose(job_result%grand_resistance), err)
    call write_replicated_dataset(ctx, group, 'velocity_per_strain', transpose(response%velocity_per_strain), err)
    call write_replicated_dataset(ctx, group, 'stresslet_per_strain', transpose(response%stresslet_per_strain), err)
    call write_replicated_dataset(ctx, group, 'held_stresslet_per_strain', &
                                  transpose(response%held_stresslet_per_strain), err)
    if (response%companion_order > 0) then
      call write_attribute(group, 'companion_strain_iterations', job_result%companion_strain_solves%iterations, err)
      call write_attribute(group, 'companion_strain_converged_reason', &
                           job_result%companion_strain_solves%converged_reason, err)
      call write_replicated_dataset(ctx, group, 'companion_grand_resistance', &
                                    transpose(job_result%companion_grand_resistance), err)
      call write_replicated_dataset(ctx, group, 'companion_velocity_per_strain', &
                                    transpose(response%companion_velocity_per_strain), err)
      call write_replicated_dataset(ctx, group, 'companion_stresslet_per_strain', &
                                    transpose(response%companion_stresslet_per_strain), err)
      call write_replicated_dataset(ctx, group, 'velocity_per_strain_error', &
                                    transpose(response%velocity_per_strain_error), err)
      call write_replicated_dataset(ctx, group, 'stresslet_per_strain_error', &
                                    transpose(response%stresslet_per_strain_error), err)
    end if
    call h5_close_group(group, err)
    end associate
  end subroutine write_flow

  !> The continuum job's group (docs/output.md, docs/theory.md T18).
  subroutine write_continuum(ctx, file_id, c, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(in) :: file_id
    type(continuum_result_t), intent(in) :: c
    type(error_t), intent(inout) :: err
    integer(hid_t) :: group
    call h5_create_group(file_id, 'continuum', group, err)
    call write_attribute(group, 'method', 'levels of bead diameter a factor 2**(1/3) apart, each the mean over ' // &
                         'sub-lattice offsets of the order-L friction corrected by the exact friction of the body''s ' // &
                         'equivalent ellipsoid, extrapolated to zero bead size by a quadratic (docs/theory.md T18)', err)
    call write_attribute(group, 'units', 'lengths in the shape''s unit, viscosity 1; mobility about the centroid, ' // &
                         'input axes; coefficients with reference_length', err)
    call write_attribute(group, 'multipole_order', c%multipole_order, err)
    call write_attribute(group, 'offsets', c%offsets, err)
    call write_attribute(group, 'moment_fills', c%moment_fills, err)
    call write_attribute(group, 'time_budget', c%time_budget, err)
    call write_attribute(group, 'estimated_seconds', c%estimated_seconds, err)
    call write_attribute(group, 'ladder_chosen_by', c%chosen_by, err)
    call write_attribute(group, 'estimate_calibration', c%calibration, err)
    call write_attribute(group, 'ladder_moved_coarser', c%moved_coarser, err)
    call write_attribute(group, 'reference_length', c%reference_length, err)
    call write_attribute(group, 'reference_length_from', c%reference_length_from, err)
    call write_attribute(group, 'volume', c%volume, err)
    call write_attribute(group, 'volume_standard_error', c%volume_error, err)
    call write_attribute(group, 'all_converged', merge(1, 0, all(c%sample_converged == 1)), err)
    call write_attribute(group, 'coefficient_names', 'mu11 mu22 mu33 mu42 mu51', err)
    call write_replicated_dataset(ctx, group, 'bead_diameters', c%bead_diameters, err)
    call write_replicated_dataset(ctx, group, 'centroid', c%centroid, err)
    call write_replicated_dataset(ctx, group, 'body_moments', c%body_moments, err)
    call write_replicated_dataset(ctx, group, 'equivalent_semi_axes', c%semi_axes, err)
    call write_replicated_dataset(ctx, group, 'equivalent_axes', c%axes, err)
    call write_attribute(group, 'sample_level', c%sample_level, err)
    call write_attribute(group, 'sample_beads', c%sample_beads, err)
    call write_attribute(group, 'sample_iterations', c%sample_iterations, err)
    call write_attribute(group, 'sample_converged', c%sample_converged, err)
    call write_replicated_dataset(ctx, group, 'sample_offset', c%sample_offset, err)
    call write_attribute(group, 'turned_lattices', merge(1, 0, c%turned_lattices), err)
    call write_replicated_dataset(ctx, group, 'sample_lattice_axes', c%sample_lattice_axes, err)
    call write_replicated_dataset(ctx, group, 'lattice_pivot', c%lattice_pivot, err)
    call write_replicated_dataset(ctx, group, 'sample_true_relative_residual', c%sample_residual, err)
    call write_replicated_dataset(ctx, group, 'sample_seconds', c%sample_seconds, err)
    call write_replicated_dataset(ctx, group, 'sample_friction_symmetry_error', c%sample_symmetry_error, err)
    call write_replicated_dataset(ctx, group, 'sample_friction', c%sample_friction, err)
    call write_replicated_dataset(ctx, group, 'sample_mobility', c%sample_mobility, err)
    call write_replicated_dataset(ctx, group, 'sample_coefficients', c%sample_coefficients, err)
    call write_replicated_dataset(ctx, group, 'sample_moments', c%sample_moments, err)
    call write_attribute(group, 'moment_control', merge(1, 0, c%moment_control), err)
    call write_replicated_dataset(ctx, group, 'level_mobility', c%level_mobility, err)
    call write_replicated_dataset(ctx, group, 'level_mobility_error', c%level_mobility_error, err)
    call write_replicated_dataset(ctx, group, 'level_coefficients', c%level_coefficients, err)
    call write_replicated_dataset(ctx, group, 'level_coefficient_error', c%level_coefficient_error, err)
    call write_replicated_dataset(ctx, group, 'mobility', transpose(c%mobility), err)
    call write_replicated_dataset(ctx, group, 'mobility_error', transpose(c%mobility_error), err)
    call write_replicated_dataset(ctx, group, 'friction', transpose(c%friction), err)
    call write_replicated_dataset(ctx, group, 'coefficients', c%coefficients, err)
    call write_replicated_dataset(ctx, group, 'coefficient_error', c%coefficient_error, err)
    call write_replicated_dataset(ctx, group, 'coefficient_standard_error', c%coefficient_standard_error, err)
    call write_replicated_dataset(ctx, group, 'coefficients_linear_fit', c%coefficient_linear, err)
    call write_replicated_dataset(ctx, group, 'coefficients_without_coarsest', c%coefficient_reduced, err)
    ! huge() (no foresight on a short ladder) is written as infinity, which HDF5 readers understand
    call write_replicated_dataset(ctx, group, 'coefficients_next_term', &
                                  merge(ieee_value(1.0_dp, ieee_positive_inf), c%coefficient_next_term, &
                                        c%coefficient_next_term >= huge(1.0_dp)), err)
    call write_replicated_dataset(ctx, group, 'mobility_level_excess', transpose(c%mobility_level_excess), err)
    call write_replicated_dataset(ctx, group, 'coefficient_level_excess', c%coefficient_level_excess, err)
    call write_attribute(group, 'control_offsets', c%control_offsets, err)
    call write_attribute(group, 'fill_budget', merge(1, 0, c%filled), err)
    if (c%control_offsets > 0) then
      ! The control variate's samples (theory.md T18): order L - 1 on every sample's beads.
      call write_attribute(group, 'sample_full', c%sample_full, err)
      call write_replicated_dataset(ctx, group, 'sample_control_friction', c%sample_control_friction, err)
      call write_replicated_dataset(ctx, group, 'sample_control_mobility', c%sample_control_mobility, err)
      call write_replicated_dataset(ctx, group, 'sample_control_coefficients', c%sample_control_coefficients, err)
    end if
    call write_attribute(group, 'flow', merge(1, 0, c%flow), err)
    if (c%flow) then
      ! The flow's response (theory.md T19), extrapolated as the mobility is; C-order readers see
      ! the sample and level arrays as (samples or levels, 30 or 25), columns flattened Fortran-wise.
      call write_replicated_dataset(ctx, group, 'velocity_per_strain', transpose(c%velocity_per_strain), err)
      call write_replicated_dataset(ctx, group, 'velocity_per_strain_error', transpose(c%velocity_per_strain_error), err)
      call write_replicated_dataset(ctx, group, 'stresslet_per_strain', transpose(c%stresslet_per_strain), err)
      call write_replicated_dataset(ctx, group, 'stresslet_per_strain_error', transpose(c%stresslet_per_strain_error), err)
      call write_replicated_dataset(ctx, group, 'sample_velocity_per_strain', c%sample_velocity_per_strain, err)
      call write_replicated_dataset(ctx, group, 'sample_stresslet_per_strain', c%sample_stresslet_per_strain, err)
      call write_replicated_dataset(ctx, group, 'level_velocity_per_strain', c%level_velocity_per_strain, err)
      call write_replicated_dataset(ctx, group, 'level_velocity_per_strain_error', c%level_velocity_per_strain_error, err)
      call write_replicated_dataset(ctx, group, 'level_stresslet_per_strain', c%level_stresslet_per_strain, err)
      call write_replicated_dataset(ctx, group, 'level_stresslet_per_strain_error', &
                                    c%level_stresslet_per_strain_error, err)
      if (c%control_offsets > 0) then
        call write_replicated_dataset(ctx, group, 'sample_control_velocity_per_strain', &
                                      c%sample_control_velocity_per_strain, err)
        call write_replicated_dataset(ctx, group, 'sample_control_stresslet_per_strain', &
                                      c%sample_control_stresslet_per_strain, err)
      end if
    end if
    call h5_close_group(group, err)
  end subroutine write_continuum

  !> The error bar (error_estimate.f90, theory.md T14): the companion of order L - 1, the estimated
  !> error of the mobility and of the coefficients, the values extrapolated in L with theirs.
  subroutine write_estimate(ctx, group, config, job_result, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(in) :: group
    type(run_config_t), intent(in) :: config
    type(friction_result_t), intent(in) :: job_result
    type(error_t), intent(inout) :: err
    type(error_estimate_t) :: e
    character(len=:), allocatable :: missing
    e = job_result%estimate
    call write_attribute(group, 'error_estimate', merge(1, 0, e%available), err)
    if (.not. e%available) then
      if (.not. config%hydrodynamics%error_estimate) then
        missing = 'error_estimate = .false. (by the input, or by default above L = 4)'
      else if (config%hydrodynamics%multipole_order < 2) then
        missing = 'order L = 1 has no lower order to compare with'
      else if (.not. all(config%hydrodynamics%motions)) then
        missing = 'not all six motions were computed'
      else
        missing = 'the friction is not finite'
      end if
      call write_attribute(group, 'error_estimate_method', 'none: ' // missing, err)
      return
    end if
    call write_attribute(group, 'error_estimate_method', 'order L against the companion of order L - 1 on the ' // &
                         'same beads, factors fitted on bench/error_estimate/error_estimate.md (docs/theory.md T14)', err)
    call write_attribute(group, 'error_measure', '|dM_ij| / sqrt(M_ii M_jj), body-frame mobility M', err)
    call write_attribute(group, 'error_estimate_factors', [entry_factor, block_factor, extrapolation_ratio, &
                                                           extrapolated_entry_factor, extrapolated_block_factor], err)
    call write_attribute(group, 'estimated_error', e%largest, err)
    ! the truncation's part alone (estimated_error less the operator's bound, theory.md T16)
    call write_attribute(group, 'truncation_estimated_error', e%largest_truncation, err)
    call write_attribute(group, 'estimated_extrapolated_error', e%largest_extrapolated, err)
    call write_attribute(group, 'companion_order', job_result%companion_order, err)
    call write_attribute(group, 'companion_potential_order', job_result%companion_potential_order, err)
    call write_attribute(group, 'companion_unknowns_per_bead', job_result%companion_unknowns_per_bead, err)
    call write_attribute(group, 'companion_iterations', job_result%companion_solves%iterations, err)
    call write_attribute(group, 'companion_converged_reason', job_result%companion_solves%converged_reason, err)
    call write_attribute(group, 'companion_solved_together', job_result%companion_solves%solved_together, err)
    call write_attribute(group, 'companion_deflation_vectors', job_result%companion_solves%deflation_vectors, err)
    call write_attribute(group, 'companion_true_relative_residual', job_result%companion_solves%true_relative_residual, err)
    call write_attribute(group, 'companion_natural_relative_residual', &
                         job_result%companion_solves%natural_relative_residual, err)
    call write_attribute(group, 'companion_condition_estimate', job_result%companion_solves%condition_estimate, err)
    call write_attribute(group, 'companion_solver_error_bound', job_result%companion_solves%solver_error_bound, err)
    call write_replicated_dataset(ctx, group, 'companion_friction', transpose(job_result%companion_friction), err)
    call write_replicated_dataset(ctx, group, 'companion_body_mobility', transpose(e%companion_mobility), err)
    call write_replicated_dataset(ctx, group, 'companion_coefficients', e%companion_coefficients, err)
    call write_replicated_dataset(ctx, group, 'body_mobility_error', transpose(e%mobility_error), err)
    call write_replicated_dataset(ctx, group, 'scaled_body_mobility_error', transpose(e%scaled_mobility_error), err)
    call write_replicated_dataset(ctx, group, 'coefficient_error', e%coefficient_error, err)
    call write_replicated_dataset(ctx, group, 'scaled_coefficient_error', e%scaled_coefficient_error, err)
    call write_replicated_dataset(ctx, group, 'extrapolated_body_mobility', transpose(e%extrapolated_mobility), err)
    call write_replicated_dataset(ctx, group, 'extrapolated_coefficients', e%extrapolated_coefficients, err)
    call write_replicated_dataset(ctx, group, 'extrapolated_coefficient_error', e%extrapolated_coefficient_error, err)
    call write_replicated_dataset(ctx, group, 'scaled_extrapolated_coefficient_error', &
                                  e%scaled_extrapolated_coefficient_error, err)
  end subroutine write_estimate

  !> The approximate operator's error (operator_error_bar.f90, theory.md T16): operator_error 0
  !> for an exact operator, -1 when not measured (not all six motions, or a friction that is not
  !> finite); with a measurement, its parts and the sample behind it.
  subroutine write_operator_error(ctx, group, job_result, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(in) :: group
    type(friction_result_t), intent(in) :: job_result
    type(error_t), intent(inout) :: err
    associate (e => job_result%operator_error)
      if (job_result%operator_name /= 'pfft') then
        call write_attribute(group, 'operator_error', 0.0_dp, err)
        call write_attribute(group, 'operator_error_method', 'none: the ' // trim(job_result%operator_name) // &
                             ' operator is the Galerkin matrix itself (to rounding)', err)
        return
      end if
      if (.not. e%available) then
        call write_attribute(group, 'operator_error', -1.0_dp, err)
        call write_attribute(group, 'operator_error_method', 'none: the far field''s error needs all six motions ' // &
                             'and a finite friction', err)
        return
      end if
      call write_attribute(group, 'operator_error', e%relative_mobility, err)
      call write_attribute(group, 'operator_error_friction', e%relative_friction, err)
      call write_attribute(group, 'operator_error_scaled', e%largest, err)
      call write_attribute(group, 'operator_error_method', 'the friction''s change with the exact far field, ' // &
                           '-q_m . E q_n + rho (E q_m) . S^-1 (E q_n), E = A - A~ on exact rows (docs/theory.md T16): ' // &
                           trim(either(job_result%operator_sample%every_row, 'every row of ', str(e%rows) // ' draws of ')) // &
                           ' ' // str(e%n_beads) // ' beads', err)
      call write_attribute(group, 'operator_error_rows', e%rows, err)
      call write_attribute(group, 'operator_error_factors', [second_order_mid, second_order_half, spread_factor, coverage], &
                           err)
      call write_attribute(group, 'operator_error_seconds', e%seconds, err)
      call write_replicated_dataset(ctx, group, 'operator_friction_change', transpose(e%friction_change), err)
      call write_replicated_dataset(ctx, group, 'operator_friction_standard_error', &
                                    transpose(e%friction_standard_error), err)
      call write_replicated_dataset(ctx, group, 'operator_body_mobility_change', transpose(e%mobility_change), err)
      call write_replicated_dataset(ctx, group, 'operator_body_mobility_error', transpose(e%mobility_error), err)
      call write_replicated_dataset(ctx, group, 'scaled_operator_body_mobility_error', &
                                    transpose(e%scaled_mobility_error), err)
      call write_replicated_dataset(ctx, group, 'operator_coefficient_error', e%coefficient_error, err)
      call write_replicated_dataset(ctx, group, 'operator_friction_second_order', transpose(e%friction_second), err)
      call write_attribute(group, 'preconditioned_smallest_eigenvalue', job_result%solves%smallest_eigenvalue, err)
      call write_attribute(group, 'operator_error_row_beads', int(job_result%operator_sample%row), err)
      call write_replicated_dataset(ctx, group, 'operator_error_row_sizes', job_result%operator_sample%size_of_row, err)
      call write_replicated_dataset(ctx, group, 'operator_error_row_probabilities', &
                                    job_result%operator_sample%probability, err)
      call write_replicated_dataset(ctx, group, 'operator_error_row_terms', row_terms(job_result%operator_sample), err)
    end associate
  end subroutine write_operator_error

  !> (72, s): per sampled row k its first-order term t_k and its second-order w_k (operator_error.F90),
  !> each 6x6 in rows of m: C-order readers see (s, 72) = (s, 2, 6, 6) as [k, part, m, n].
  pure function row_terms(sample) result(values)
    type(operator_sample_t), intent(in) :: sample
    real(dp) :: values(72, sample%rows)
    integer :: k
    do k = 1, sample%rows
      values(1:36, k) = reshape(transpose(sample%terms(:, :, k)), [36])
      values(37:72, k) = reshape(transpose(sample%second(:, :, k)), [36])
    end do
  end function row_terms

  !> <prefix>_finite, _positive_definite, _symmetric, _well_conditioned (0/1), _condition_number,
  !> _min_eigenvalue, _eigenvalues (of the symmetric part), _asymmetry: friction_diagnostics.f90.
  subroutine write_diagnostics(group, prefix, diag, err)
    integer(hid_t), intent(in) :: group
    character(len=*), intent(in) :: prefix
    type(friction_diagnostics_t), intent(in) :: diag
    type(error_t), intent(inout) :: err
    call write_attribute(group, prefix // '_finite', merge(1, 0, diag%finite), err)
    call write_attribute(group, prefix // '_positive_definite', merge(1, 0, diag%positive_definite), err)
    call write_attribute(group, prefix // '_symmetric', merge(1, 0, diag%symmetric), err)
    call write_attribute(group, prefix // '_well_conditioned', merge(1, 0, diag%well_conditioned), err)
    call write_attribute(group, prefix // '_condition_number', diag%condition_number, err)
    call write_attribute(group, prefix // '_min_eigenvalue', diag%eigenvalues(1), err)
    call write_attribute(group, prefix // '_eigenvalues', diag%eigenvalues, err)
    call write_attribute(group, prefix // '_asymmetry', diag%asymmetry, err)
  end subroutine write_diagnostics

  function timestamp() result(text)
    character(len=:), allocatable :: text
    character(len=8) :: date
    character(len=10) :: time
    character(len=5) :: zone
    call date_and_time(date, time, zone)
    text = date(1:4) // '-' // date(5:6) // '-' // date(7:8) // 'T' // time(1:2) // ':' // time(3:4) // ':' // &
           time(5:6) // zone(1:3) // ':' // zone(4:5)
  end function timestamp
end module beadmob_result_file
