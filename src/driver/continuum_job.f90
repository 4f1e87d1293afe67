!> The continuum job (&continuum, docs/theory.md T18): the mobility of the body
!> a shape describes, not of one bead model of it. A ladder of resolutions (bead diameters a
!> factor 2**(1/3) apart, bead counts a factor 2), chosen from the time budget with the dry
!> run's estimates; at each, the friction job on `offsets` bead models of the same body on
!> lattices shifted by sub-lattice offsets; each sample corrected for the volume and shape its
!> lattice gave the body (the exact friction of the equivalent ellipsoids); the level means
!> extrapolated to zero bead size (continuum_fit.f90); with control_offsets, order L - 1 solves on
!> every sample's beads and on further offsets correct each level's mean (a control variate,
!> theory.md T18 "Control samples"). Every solved sample is kept in a text
!> checkpoint '<output>.continuum_checkpoint' (rewritten whole and renamed after each), so a
!> killed job resumes with the samples it has; the result file holds them all.
module beadmob_continuum_job
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use mpi, only: MPI_Bcast, MPI_INTEGER, MPI_DOUBLE_PRECISION, MPI_Wtime
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str, str_approx, either
  use beadmob_parallel, only: run_context_t, agree_on_error
  use beadmob_file_system, only: rename_file, remove_file
  use beadmob_input_config, only: run_config_t, effective_input_text, is_set
  use beadmob_checkpoint_file, only: fnv1a_hex
  use beadmob_bead_model, only: bead_model_t
  use beadmob_lattice_fill, only: offset_sequence, turn_sequence
  use beadmob_vector_algebra, only: cross
  use beadmob_shape_catalog, only: build_bead_model, read_mesh_once, triangle_mesh_t
  use beadmob_geometry_checks, only: check_bead_model
  use beadmob_body_frame, only: body_frame_t, compute_body_frame, spread_along
  use beadmob_body_extent, only: continuous_extent
  use beadmob_body_moments, only: body_moments_t, moments_of_beads, moments_of_polyhedron, moments_about_origin, &
                                  unpacked_moments, packed_moments_size, &
                                  equivalent_ellipsoid
  use beadmob_ellipsoid_friction, only: ellipsoid_friction, ellipsoid_grand_resistance
  use beadmob_mobility, only: mobility_result_t, compute_mobility, invert
  use beadmob_lapack, only: dsyev
  use beadmob_moment_control, only: moment_features, body_moment_features, moment_control_shift, n_moment_features
  use beadmob_continuum_fit, only: continuum_result_t, continuum_value_t, extrapolate_to_zero, level_mean, &
                                   controlled_level_mean
  use beadmob_continuum_fill, only: next_fill_level, fill_variance_parts
  use beadmob_job_plan, only: job_plan_t, solve_rtol
  use beadmob_friction_job, only: friction_of_plan, friction_result_t, companion_orders
  use beadmob_rigid_body_solve, only: solve_statistics_t
  use beadmob_linear_flow, only: n_strain_modes, strain_rotation
  use beadmob_flow_response, only: free_body_response
  use beadmob_result_file, only: write_result_file
  use beadmob_job_planning, only: plan_friction_job
  implicit none
  private
  public :: run_continuum_job, continuum_checkpoint_suffix

  character(len=*), parameter :: continuum_checkpoint_suffix = '.continuum_checkpoint'
  character(len=*), parameter :: checkpoint_header = 'beadmob-continuum-checkpoint 1'
  !> Shapes whose lattice can be shifted against the body and whose size is given in a unit.
  character(len=*), parameter :: filled_shapes(14) = [character(len=16) :: 'sphere', 'spheroid', 'torus', 'mesh', &
    'box', 'cylinder', &
    'cone', 'arrowhead', 'crescent_moon', 'ring_1mm', 'ring_2mm', 'ring_3mm', 'ring_4mm', 'open_ring']
  !> A ladder whose coarsest level has fewer beads is too coarse to extrapolate from.
  integer, parameter :: minimum_coarsest_beads = 100
  !> The pilot solve that calibrates the time estimates has about this many beads.
  integer, parameter :: pilot_beads = 1000
  !> Candidate ladders reach this many levels below the coarsest feasible one (bead counts 2**ladder_span).
  integer, parameter :: ladder_span = 21
  !> Numbers per sample in the checkpoint (see pack_sample), and those a flow job adds (its grand
  !> resistance): a flow job's input, and so its checkpoint key, differs from any other's.
  integer, parameter :: sample_numbers = 60, flow_numbers = 121
  !> Numbers a job with control samples adds per sample: 1 when solved at order L, the order L - 1 friction.
  integer, parameter :: control_numbers = 37
  !> fill_budget's limit of a level's samples (the turns of turned lattices are numbered for 64).
  integer, parameter :: max_samples_per_level = 64
  !> The offset index of the estimates and the pilot: Halton point 2, (1/4, 2/3, 2/5) of a
  !> lattice cell, keeps no mirror plane of a body symmetric about one through a lattice node, as
  !> no later point does; point 1, (1/2, 1/3, 1/5), keeps the plane normal to x, and a solve with a
  !> mirror plane costs less (an arrowhead at 145k beads: 42.8 s against 69 s), so estimates made
  !> there foresaw a 300 s job's finest levels at half their time. Always a full sample (offsets >= 2).
  integer, parameter :: generic_offset = 2
  !> keep_to_budget trusts a solved level's measured time over its estimate for the rest of the
  !> ladder when that level took at least this fraction of the rest's cost.
  real(dp), parameter :: trusted_fraction = 0.125_dp
  !> A control solve's Krylov tolerance over the job's (control_settings).
  real(dp), parameter :: control_tolerance_factor = 5.0_dp

  !> What a sample carries in the checkpoint beyond the sample_numbers every job's has: a flow
  !> job's grand resistance; a controlled job's full-sample flag and order L - 1 friction, and
  !> with flow its order L - 1 grand resistance too.
  type :: sample_layout_t
    logical :: flow = .false., controlled = .false.
  end type sample_layout_t

  !> One solved bead model of the ladder (lengths in d unless said otherwise).
  type :: continuum_sample_t
    integer :: level = 0, offset_index = 0, beads = 0, iterations = 0, converged = 0
    real(dp) :: seconds = 0.0_dp, residual = 0.0_dp, bead_diameter = 0.0_dp, offset(3) = 0.0_dp
    real(dp) :: friction(6, 6) = 0.0_dp          ! about the beads' centre of mass
    !> With control samples (&continuum control_offsets): .false. for a control sample, solved at
    !> order L - 1 alone (friction then 0); `control` the order L - 1 friction of its beads.
    logical :: full = .true.
    real(dp) :: control(6, 6) = 0.0_dp
    !> A flow job's grand resistance (theory.md T19), about the same point; 0 otherwise
    real(dp) :: grand(6 + n_strain_modes, 6 + n_strain_modes) = 0.0_dp
    real(dp) :: control_grand(6 + n_strain_modes, 6 + n_strain_modes) = 0.0_dp   ! a controlled flow job's order L - 1
    type(body_moments_t) :: moments              ! in the shape's unit
  end type continuum_sample_t

  !> How a sample's lattice meets the body besides its offset: with &continuum turned_lattices
  !> (meshes), the lattice of offset index j >= 1 at bead diameter d has the axes
  !> base turn_sequence(turn_index(d, j), max_angle) (columns, in the input's frame): `base` is
  !> the input's axes or the body's principal axes, whichever boxes the mesh tighter (a sample's
  !> FFT box is its cost), tilted by at most max_angle (radians) so that no face stays along the
  !> lattice; the body turns about `pivot` (its centroid, shape units) to meet it. `unit`: the
  !> user's bead diameter, by which a level is known (d = unit 2**(k/3)).
  type :: lattice_turns_t
    logical :: enabled = .false.
    real(dp) :: pivot(3) = 0.0_dp, base(3, 3) = 0.0_dp, max_angle = 0.0_dp, unit = 1.0_dp
  end type lattice_turns_t

  !> What the job knows of its levels before solving: level k has bead diameter
  !> bead_diameter * 2**(k/3), k from `finest` to `coarsest` (survey_body); per level the beads at
  !> the generic offset and the dry run's estimate of a sample (s), -1 until surveyed; the pilot's
  !> calibration of the estimates.
  type :: ladder_survey_t
    integer :: user_beads = 0, coarsest = 0, finest = 0
    real(dp) :: thinnest = 0.0_dp, calibration = 1.0_dp
    type(lattice_turns_t) :: turns
    integer, allocatable :: beads(:)
    real(dp), allocatable :: seconds(:), control_seconds(:)
    !> A mesh's exact volume and moments about the input's origin (its polyhedron's); unset for
    !> other shapes, whose survey fill only foresees the levels.
    type(body_moments_t) :: moments
  end type ladder_survey_t

  !> A sample corrected for the body its lattice gave it (docs/theory.md T18, step 2): mobility
  !> (36) and coefficients (5) about the body's centroid in the shape's unit, and the same of its
  !> order L - 1 solve (control samples); NaN where nothing was solved.
  type :: corrected_sample_t
    real(dp) :: mobility(36), coefficients(5), control_mobility(36), control_coefficients(5)
  end type corrected_sample_t

contains

  !> Collective. The continuum job of config (its &continuum group), result to config%output.
  subroutine run_continuum_job(ctx, config, err)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: config
    type(error_t), intent(inout) :: err
    type(continuum_sample_t), allocatable :: samples(:)
    type(continuum_result_t) :: result
    type(body_moments_t) :: body
    type(bead_model_t) :: model
    type(body_frame_t) :: frame
    type(triangle_mesh_t) :: mesh
    type(ladder_survey_t) :: survey
    real(dp), allocatable :: diameters(:), volumes(:)
    real(dp) :: estimated_seconds, finest, estimate, job_start, resumed_seconds, seconds_left
    type(continuum_sample_t) :: pilot
    type(corrected_sample_t), allocatable :: corrected(:)   ! fill_budget's, of samples(1:size(corrected))
    logical :: budget_chooses, fills
    character(len=:), allocatable :: key, checkpoint, chosen_by
    integer :: level, j, fill, solved_here, pilot_level, finest_level, moved_coarser
    logical :: overrun_told   ! keep_to_budget's warning that no move helps, once

    job_start = MPI_Wtime()
    call check_continuum_input(config, err)
    if (err%failed) return
    ! With control samples the key holds their Krylov tolerance too (not an input): a checkpoint of
    ! controls solved at another tolerance is not resumed (they must be computed alike).
    key = effective_input_text(config, numbers_only=.true.)
    if (config%continuum%control_offsets > 0) key = key // ' control rtol ' // &
                                                  str(control_rtol(config))
    key = fnv1a_hex(key)
    checkpoint = trim(config%output) // continuum_checkpoint_suffix
    finest = -1.0_dp
    allocate (samples(0))
    if (config%checkpoint) call read_checkpoint(ctx, checkpoint, key, layout_of(config), finest, samples, err)
    if (err%failed) return
    resumed_seconds = sum(samples%seconds)
    ! A mesh is read and checked once; every fill of the job below uses it.
    if (config%shape%name == 'mesh') call read_mesh_once(ctx, config%shape, mesh, err)
    if (err%failed) return

    ! The ladder: levels the body's size allows (every one with enough beads), the finest whose
    ! estimated time fits the budget. All of it is decided before any solve, by geometry-only
    ! fills and the dry run's estimates; only the pilot's calibration (below) depends on speed.
    call survey_body(ctx, config, mesh, survey, err)
    if (err%failed) return
    pilot_level = huge(1)
    budget_chooses = finest <= 0.0_dp .and. .not. is_set(config%continuum%finest_bead_diameter)
    if (budget_chooses) then
      chosen_by = 'time_budget'
      call budget_ladder(ctx, config, mesh, survey, 1.0_dp, diameters, estimated_seconds, finest_level, err)
      if (err%failed) return
      call pilot_level_of(ctx, config, mesh, survey, finest_level, pilot_level, err)
      if (err%failed) return
    else
      chosen_by = either(finest > 0.0_dp, 'checkpoint', 'finest_bead_diameter')
      call fixed_ladder(ctx, config, mesh, survey, merge(finest, config%continuum%finest_bead_diameter, finest > 0.0_dp), &
                        diameters, estimated_seconds, err)
      if (err%failed) return
    end if
    ! fill_budget: what a ladder the budget chose leaves of it goes to control samples once the
    ! ladder's are solved (a ladder of finest_bead_diameter is the user's, not the budget's).
    fills = config%continuum%fill_budget .and. config%continuum%control_offsets > 0 .and. &
            .not. is_set(config%continuum%finest_bead_diameter)
    if (config%dry_run .or. config%progress) call print_ladder(ctx, config, survey, diameters, estimated_seconds, &
                                                                1.0_dp, fills, pilot_level)
    if (config%dry_run) return
    ! The dry run's estimates, calibrated by one pilot sample of about pilot_beads beads (kept when
    ! it lands on the ladder); a pilot slower than its estimate can only make the ladder coarser.
    if (budget_chooses) then
      pilot = solve_sample(0, generic_offset, level_diameter(config, pilot_level))
      if (err%failed) return
      estimate = survey%seconds(pilot_level)
      if (estimate > 0.0_dp .and. pilot%beads >= minimum_coarsest_beads) survey%calibration = max(1.0_dp, pilot%seconds / estimate)
      if (survey%calibration > 1.0_dp) then
        call budget_ladder(ctx, config, mesh, survey, survey%calibration, diameters, estimated_seconds, finest_level, err)
        if (err%failed) return
        if (config%progress) call print_ladder(ctx, config, survey, diameters, estimated_seconds, survey%calibration, fills)
      end if
      do level = 1, size(diameters)
        if (abs(diameters(level) - pilot%bead_diameter) <= 1.0e-9_dp * pilot%bead_diameter) then
          pilot%level = level
          samples = [samples, pilot]
        end if
      end do
    end if

    ! The body: a mesh's exact volume and moments (its polyhedron's: nothing to estimate, so no
    ! volume error), another shape's from geometry-only fills at the finest level
    ! (body_moments.f90), on the samples' lattices (with turns, each fill's own), whose scatter is
    ! the volume's standard error. Both are what the samples' bead moments average to.
    if (config%shape%name == 'mesh') then
      body = survey%moments
      volumes = [body%volume]
    else
      allocate (volumes(config%continuum%moment_fills))
      do fill = 1, config%continuum%moment_fills
        call build_at(ctx, config, mesh, survey%turns, diameters(size(diameters)), fill, model, err)
        if (err%failed) return
        call accumulate(body, moments_in_input_frame(model%centres, diameters(size(diameters)), survey%turns, fill), &
                        config%continuum%moment_fills)
        volumes(fill) = size(model%centres, 2) * diameters(size(diameters))**3
      end do
    end if

    ! Coarsest level first. Before each level a budget's ladder is checked against what its levels
    ! have taken so far, and moved coarser if the rest would overrun (keep_to_budget); a move adds
    ! an unsolved coarsest level, so the pass starts over (solved levels are skipped).
    solved_here = 0
    moved_coarser = 0
    overrun_told = .false.
    level = 1
    do while (level <= size(diameters))
      if (budget_chooses) then
        call keep_to_budget(level)
        if (err%failed) return
      end if
      do j = 1, config%continuum%offsets + config%continuum%control_offsets
        if (any(samples%level == level .and. samples%offset_index == j)) cycle
        if (budget_chooses .and. j > config%continuum%offsets) then
          if (control_overruns(level)) exit
        end if
        call add_sample(level, j)
        if (err%failed) return
      end do
      level = level + 1
    end do

    ! The reference model carries the geometry and the body frame of the coefficients: the finest
    ! level on the lattice through the body's origin (offset 0), which keeps the shape's mirror
    ! planes (an offset breaks them, and the paper's frame is chosen by them: body_frame.f90).
    call build_at(ctx, config, mesh, survey%turns, diameters(size(diameters)), 0, model, err)
    if (err%failed) return
    call compute_body_frame(model%centres, frame, err)
    call agree_on_error(ctx, err)
    if (err%failed) return
    call coefficient_length(ctx, config, mesh, frame, diameters(size(diameters)), result%reference_length, &
                            result%reference_length_from)
    if (fills) then
      allocate (corrected(0))
      do
        ! What is left of the budget: this process's wall time and the resumed samples' seconds
        ! (-fill_samples, a test: a number of samples instead, counted with the resumed ones).
        seconds_left = config%continuum%time_budget - (MPI_Wtime() - job_start + resumed_seconds)
        if (config%fill_samples > 0) then
          if (count(samples%offset_index > config%continuum%offsets + config%continuum%control_offsets) >= &
              config%fill_samples) exit
          seconds_left = huge(1.0_dp)
        end if
        level = fill_level(ctx, config, diameters, samples, body, frame%axes, result%reference_length, corrected, &
                           seconds_left, err)
        if (err%failed) return
        if (level == 0) exit
        call add_sample(level, maxval(samples%offset_index, mask=samples%level == level) + 1)
        if (err%failed) return
      end do
    end if
    call continuum_values(config, survey%turns, diameters, samples, body, volumes, frame%axes, result, err)
    if (err%failed) return
    result%estimated_seconds = estimated_seconds
    result%filled = fills
    result%calibration = survey%calibration
    result%chosen_by = chosen_by
    result%moved_coarser = moved_coarser
    call write_result_file(ctx, config, model, frame, err, continuum=result)
    if (err%failed) return
    if (config%checkpoint .and. .not. config%keep_checkpoint .and. ctx%rank == 0) call remove_file(checkpoint)
    if (ctx%rank == 0) call print_continuum(config, result)

  contains

    !> Collective. Before level `level` of a ladder the budget chose (docs/theory.md T18, "The
    !> ladder"): the unsolved levels' estimates times the finest complete level's measured time
    !> over its estimate, against what is left of the budget (rank 0's clock). When they overrun,
    !> the ladder moves s levels coarser, the least s that fits (or the most the body allows): s
    !> coarser levels are added, the s finest incomplete ones dropped (with a pilot sample kept on
    !> one), every other sample kept on its bead diameter. The estimates' CG iteration counts do not know the body's shape (a flat
    !> arrowhead's rotations took 32 iterations at 145k beads where 17 were foreseen), and the
    !> pilot's small solve does not show it; the levels solved do. On a move, `level` goes back to 1.
    subroutine keep_to_budget(level)
      integer, intent(inout) :: level
      real(dp) :: ratio, left, cost(0:size(diameters) - 1), full_level, solved_seconds
      integer :: complete, i, s, most, chosen_s
      type(error_t) :: refused
      full_level = config%continuum%offsets + config%continuum%control_offsets
      complete = 0
      do i = 1, size(diameters)
        if (count(samples%level == i) >= full_level) complete = i
      end do
      if (complete == 0) return
      solved_seconds = sum(pack(samples%seconds, samples%level == complete))
      ratio = solved_seconds / (count(samples%level == complete) / full_level * estimate_of(grid_index(complete)))
      if (.not. ratio > 0.0_dp) return
      left = ladder_seconds_left()
      ! cost(s): the unsolved levels of the ladder moved s levels coarser, at the measured ratio.
      cost(0) = ratio * sum([(merge(estimate_of(grid_index(i)), 0.0_dp, count(samples%level == i) < full_level), &
                              i = 1, size(diameters))])
      if (cost(0) <= left) return
      ! A level whose time is a small part of the rest says little of it: fixed costs weigh more in
      ! a small solve and CG iterations grow with the beads, so the ratio drifts with the size. Only
      ! a level that took at least trusted_fraction of the rest's cost (in practice one of the three
      ! finest: each level costs about twice the one above it) moves the ladder.
      if (solved_seconds < trusted_fraction * cost(0)) return
      most = 0
      do s = 1, size(diameters) - 1
        if (size(diameters) - s < complete .or. finest_level + s + size(diameters) - 1 > survey%coarsest) exit
        call survey_level(ctx, config, mesh, survey, finest_level + s + size(diameters) - 1, refused, err)
        if (err%failed) return
        if (refused%failed .or. survey%beads(finest_level + s + size(diameters) - 1) < minimum_coarsest_beads) exit
        cost(s) = cost(s - 1) - ratio * estimate_of(finest_level + s - 1) + &
                  ratio * estimate_of(finest_level + s + size(diameters) - 1)
        most = s
      end do
      if (most == 0) then
        if (.not. overrun_told .and. ctx%rank == 0) write (*, '(a)') 'beadmob: warning: &continuum: level ' // &
          str(complete) // ' took ' // trim(str_approx(ratio)) // ' times its estimate; the rest of the ladder would ' // &
          'take ' // trim(seconds_text(cost(0))) // ' of the ' // trim(seconds_text(max(left, 0.0_dp))) // ' left of ' // &
          'the budget, and no coarser ladder has its coarsest level at ' // str(minimum_coarsest_beads) // &
          ' beads or more and keeps the levels solved: running on'
        overrun_told = .true.
        return
      end if
      chosen_s = most
      do s = most, 1, -1
        if (cost(s) <= left) chosen_s = s
      end do
      finest_level = finest_level + chosen_s
      diameters = [(level_diameter(config, i), i = finest_level + size(diameters) - 1, finest_level, -1)]
      samples%level = samples%level + merge(chosen_s, 0, samples%level > 0)
      samples = pack(samples, samples%level <= size(diameters))   ! a dropped level's pilot sample
      moved_coarser = moved_coarser + chosen_s
      if (ctx%rank == 0) write (*, '(a)') 'beadmob: &continuum: level ' // str(complete) // ' took ' // &
        trim(str_approx(ratio)) // ' times its estimate; the rest of the ladder would take ' // &
        trim(seconds_text(cost(0))) // ' of the ' // trim(seconds_text(max(left, 0.0_dp))) // ' left of the budget: ' // &
        'the ladder moves ' // str(chosen_s) // ' level(s) coarser (bead diameters ' // &
        trim(ladder_text(config, finest_level, size(diameters))) // ', estimated ' // trim(seconds_text(cost(chosen_s))) // &
        ' more)' // either(cost(chosen_s) > left, ', as far as it can move (the solved levels stay, the ' // &
        'coarsest holds ' // str(minimum_coarsest_beads) // ' beads or more), still beyond the budget', '')
      level = 1
    end subroutine keep_to_budget

    !> Collective. Before a planned control sample of `level` on a ladder the budget chose: .true.
    !> when what is left of the budget (rank 0's clock, as keep_to_budget counts it) would not pay
    !> for it, at the mean time of the level's control samples so far (before the first: its full
    !> samples' mean times the estimates' ratio of a control sample to a full one). The level then
    !> keeps the samples it has (its mean and standard error are made of them, and the fill finds
    !> no time left). keep_to_budget checks a level before it starts; this catches the finest level
    !> running over its estimate, which no solved level foresaw: a 3-D cross whose 53k-bead level
    !> kept its mirror planes at every offset took 17 s per full sample, its 105k-bead level none
    !> and 158 s (the job 762 s of its 600; bench/continuum/nonconvex_control_first.md).
    !> -fill_samples (a test: samples whatever the time) turns it off.
    logical function control_overruns(level)
      integer, intent(in) :: level
      real(dp) :: expected, left, full_estimate
      logical :: control(size(samples)), full(size(samples))
      control_overruns = .false.
      if (config%fill_samples > 0) return
      control = samples%level == level .and. .not. samples%full
      full = samples%level == level .and. samples%full
      full_estimate = survey%seconds(grid_index(level))
      expected = 0.0_dp
      if (count(control) > 0) then
        expected = sum(pack(samples%seconds, control)) / count(control)
      else if (count(full) > 0 .and. full_estimate > 0.0_dp) then
        expected = sum(pack(samples%seconds, full)) / count(full) * survey%control_seconds(grid_index(level)) / full_estimate
      end if
      left = ladder_seconds_left()
      control_overruns = expected > left
      if (control_overruns .and. ctx%rank == 0) write (*, '(a)') 'beadmob: warning: &continuum: level ' // &
        str(level) // ' keeps ' // str(count(samples%level == level)) // ' of its ' // &
        str(config%continuum%offsets + config%continuum%control_offsets) // ' samples: its next control sample ' // &
        '(about ' // trim(seconds_text(expected)) // ') would not fit in the ' // &
        trim(seconds_text(max(left, 0.0_dp))) // ' left of the budget'
    end function control_overruns

    !> Collective. What is left of the budget for the ladder's samples, by rank 0's clock since
    !> this process started (keep_to_budget and control_overruns decide by it alike).
    real(dp) function ladder_seconds_left() result(left)
      integer :: ierr
      left = config%continuum%time_budget - (MPI_Wtime() - job_start)
      call MPI_Bcast(left, 1, MPI_DOUBLE_PRECISION, 0, ctx%comm, ierr)
    end function ladder_seconds_left

    !> The grid index k (bead diameter level_diameter(config, k)) of the ladder's level i.
    pure integer function grid_index(i)
      integer, intent(in) :: i
      grid_index = finest_level + size(diameters) - i
    end function grid_index

    !> The dry run's estimate of a whole level at grid index k (surveyed).
    pure real(dp) function estimate_of(k)
      integer, intent(in) :: k
      estimate_of = level_seconds(config, survey%seconds(k), survey%control_seconds(k))
    end function estimate_of

    !> Collective. Solves sample j of `level` into samples and the checkpoint.
    subroutine add_sample(level, j)
      integer, intent(in) :: level, j
      samples = [samples, solve_sample(level, j, diameters(level))]
      if (err%failed) return
      if (config%checkpoint .and. ctx%rank == 0) call write_checkpoint(checkpoint, key, layout_of(config), &
                                                                         diameters(size(diameters)), samples, err)
      call agree_on_error(ctx, err)
      if (err%failed) return
      ! The test stop of -stop_after_solves counts a continuum job's samples (a kill at a known
      ! point: the checkpoint holds exactly these samples).
      solved_here = solved_here + 1
      if (solved_here == config%hydrodynamics%stop_after_solves) &
        call raise(err, 'stopped after ' // str(solved_here) // ' samples as -stop_after_solves asks (a test of ' // &
                   'the continuum checkpoint: rerun to resume)')
    end subroutine add_sample

    !> Collective. Sample j of level `level` (bead diameter d): the friction job with the run's
    !> settings (no error bar of its own: the ladder's scatter and extrapolation are this job's).
    !> With control samples, j <= offsets also solves the control problem on the same beads, first
    !> and as the order-L job's companion (friction_job.F90: the order-L solves start from its
    !> solutions; bench/continuum/control_first.md), and j > offsets is a control sample, the
    !> control problem alone (control_settings).
    function solve_sample(level, j, d) result(sample)
      integer, intent(in) :: level, j
      real(dp), intent(in) :: d
      type(continuum_sample_t) :: sample
      type(run_config_t) :: sample_config
      type(bead_model_t) :: sample_model
      type(body_frame_t) :: sample_frame
      type(friction_result_t) :: job_result
      real(dp) :: start, turn(6 + n_strain_modes, 6 + n_strain_modes)
      integer :: ierr
      logical :: controlled
      start = MPI_Wtime()
      controlled = config%continuum%control_offsets > 0
      sample%full = j <= config%continuum%offsets
      sample_config = config
      call build_at(ctx, config, mesh, survey%turns, d, j, sample_model, err, sample_config)
      if (.not. err%failed .and. size(sample_model%centres, 2) < 2) &
        call raise(err, '&continuum: ' // str(size(sample_model%centres, 2)) // ' beads at bead diameter ' // str(d) // &
                   ': the shape is too small for this resolution')
      if (err%failed) return
      call check_bead_model(sample_model, config%overlap_tolerance, err)
      if (.not. err%failed) call compute_body_frame(sample_model%centres, sample_frame, err)
      call agree_on_error(ctx, err)
      if (err%failed) return
      sample%level = level
      sample%offset_index = j
      sample%beads = size(sample_model%centres, 2)
      sample%bead_diameter = d
      sample%offset = sample_config%shape%lattice_offset
      sample%moments = moments_in_input_frame(sample_model%centres, d, survey%turns, j)
      sample%converged = 1
      ! Into the input's frame from the lattice's (diag(Q, Q) and D(Q) on the strains, as
      ! friction_job.F90 turns its solve axes back).
      turn = input_frame_turn(survey%turns, d, j)
      if (sample%full) then
        ! With control samples one job: the control problem first (its companion), the order-L
        ! solves started from its solutions.
        call solve_friction(ctx, sample_config, sample_model%centres, job_result, sample, err, &
                            merge(control_rtol(config), 0.0_dp, controlled))
        if (err%failed) return
        sample%friction = turned(turn, job_result%friction)
        if (job_result%flow) sample%grand = turned(turn, job_result%grand_resistance)
        if (controlled) sample%control = turned(turn, job_result%companion_friction)
        if (controlled .and. job_result%flow) sample%control_grand = turned(turn, job_result%companion_grand_resistance)
      else
        call solve_friction(ctx, control_settings(sample_config), sample_model%centres, job_result, sample, err, 0.0_dp)
        if (err%failed) return
        sample%control = turned(turn, job_result%friction)
        if (job_result%flow) sample%control_grand = turned(turn, job_result%grand_resistance)
      end if
      ! Rank 0's clock for all: the pilot's calibration and fill_budget decide by it.
      sample%seconds = MPI_Wtime() - start
      call MPI_Bcast(sample%seconds, 1, MPI_DOUBLE_PRECISION, 0, ctx%comm, ierr)
      if (level > 0) sample%seconds = sample%seconds * config%slow_samples   ! a test (-slow_samples)
      if (config%progress .and. ctx%rank == 0) write (*, '(a, i0, a, i0, a, i0, a, es10.3, a, i0, a, f0.1, a)') &
        'beadmob: continuum level ', level, ' offset ', j, ': ', sample%beads, ' beads, d = ', d, ', ', &
        sample%iterations, ' iterations, ', sample%seconds, ' s' // either(sample%full, '', ' (control sample)')
    end function solve_sample
  end subroutine run_continuum_job

  !> What a continuum job needs of its input (the same on every rank: no collective needed).
  subroutine check_continuum_input(config, err)
    type(run_config_t), intent(in) :: config
    type(error_t), intent(inout) :: err
    if (.not. config%hydrodynamics%enabled) then
      call raise(err, '&continuum extrapolates the friction job: the input needs a &hydrodynamics group ' // &
                 '(and no -geometry_only)')
    else if (config%hydrodynamics%accuracy > 0.0_dp) then
      call raise(err, '&continuum chooses its own resolutions: an accuracy target (accuracy, -accuracy) does not apply')
    else if (.not. all(config%hydrodynamics%motions)) then
      call raise(err, '&continuum needs all six motions (motions = ''all'')')
    else if (.not. any(filled_shapes == config%shape%name)) then
      call raise(err, "&continuum needs a shape that fills a body on the lattice, not '" // trim(config%shape%name) // &
                 "' (one of sphere, spheroid, box with box_size, cylinder, torus, mesh and the paper's shapes)")
    else if (.not. is_set(config%shape%bead_diameter)) then
      call raise(err, '&continuum needs the shape in its own unit with &shape bead_diameter: the resolution of one ' // &
                 'ordinary run, around which the ladder is chosen')
    else if (any(config%shape%lattice_offset /= 0.0_dp)) then
      call raise(err, '&continuum chooses the lattice offsets itself: leave &shape lattice_offset out')
    else if (config%continuum%turned_lattices .and. config%shape%name /= 'mesh') then
      call raise(err, "&continuum turned_lattices turns the body against the lattice, which beadmob does for " // &
                 "meshes only, not for shape '" // trim(config%shape%name) // "' (leave it out, or give the body as a mesh)")
    else if (config%continuum%control_offsets > 0 .and. config%hydrodynamics%multipole_order < 2) then
      call raise(err, '&continuum control_offsets solves order L - 1 beside order L: it needs multipole_order >= 2, got ' // &
                 str(config%hydrodynamics%multipole_order))
    end if
  end subroutine check_continuum_input

  !> Collective. The model of config's shape at bead diameter d on the lattice of offset index j
  !> (offset_sequence: well spread over the unit cell; j = 0: no offset) and, with turns, of
  !> axes lattice_axes(turns, d, j) (j >= 1): the centres are then in the lattice's frame
  !> (moments_in_input_frame, input_frame_turn turn back); `used` gets the config.
  !> `mesh`: shape 'mesh' read once (read_mesh_once), unused for the other shapes.
  subroutine build_at(ctx, config, mesh, turns, d, j, model, err, used)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: config
    type(triangle_mesh_t), intent(in) :: mesh
    type(lattice_turns_t), intent(in) :: turns
    real(dp), intent(in) :: d
    integer, intent(in) :: j
    type(bead_model_t), intent(out) :: model
    type(error_t), intent(inout) :: err
    type(run_config_t), intent(inout), optional :: used
    type(run_config_t) :: c
    type(triangle_mesh_t) :: turned
    real(dp) :: axes(3, 3)
    c = config
    c%shape%bead_diameter = d
    c%shape%lattice_offset = offset_sequence(j)
    if (config%shape%name == 'mesh' .and. turns%enabled .and. j >= 1) then
      ! The body in the lattice's frame: x' = pivot + Q^T (x - pivot) (rank 0 holds the mesh).
      axes = lattice_axes(turns, d, j)
      turned%triangles = mesh%triangles
      turned%vertices = spread(turns%pivot, 2, size(mesh%vertices, 2)) + &
                        matmul(transpose(axes), mesh%vertices - spread(turns%pivot, 2, size(mesh%vertices, 2)))
      call build_bead_model(ctx, c%shape, model, err, turned)
    else if (config%shape%name == 'mesh') then
      call build_bead_model(ctx, c%shape, model, err, mesh)
    else
      call build_bead_model(ctx, c%shape, model, err)
    end if
    call agree_on_error(ctx, err)
    if (present(used)) used = c
  end subroutine build_at

  !> Collective. L of the continuum coefficients (shape units) and where it came from: the
  !> input's reference_length; else the body's own extent along the body x axis (`frame`, of the
  !> finest level's reference model), exact for a mesh (its vertices, rank 0's) and the simple
  !> shapes (body_extent.f90); else, for the paper's shapes, that reference model's outer size,
  !> which lies up to a bead diameter d beyond the body's and is the paper's L at its d.
  subroutine coefficient_length(ctx, config, mesh, frame, d, length, source)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: config
    type(triangle_mesh_t), intent(in) :: mesh
    type(body_frame_t), intent(in) :: frame
    real(dp), intent(in) :: d
    real(dp), intent(out) :: length
    character(len=:), allocatable, intent(out) :: source
    logical :: known
    integer :: ierr
    if (is_set(config%shape%reference_length)) then
      length = config%shape%reference_length
      source = 'input'
      return
    end if
    if (config%shape%name == 'mesh') then
      if (ctx%rank == 0) length = spread_along(mesh%vertices, frame%axes(:, 1))
      call MPI_Bcast(length, 1, MPI_DOUBLE_PRECISION, 0, ctx%comm, ierr)
      known = .true.
    else
      call continuous_extent(config%shape, frame%axes(:, 1), length, known)
    end if
    if (known) then
      source = 'body'
    else
      length = frame%extent(1) * d
      source = 'finest level'
    end if
  end subroutine coefficient_length

  !> The lattice axes of offset index j at bead diameter d (columns, input frame): the base axes
  !> tilted by the turn of turn_index with turns, else the input's own.
  pure function lattice_axes(turns, d, j) result(axes)
    type(lattice_turns_t), intent(in) :: turns
    real(dp), intent(in) :: d
    integer, intent(in) :: j
    real(dp) :: axes(3, 3)
    integer :: a
    axes = 0.0_dp
    do a = 1, 3
      axes(a, a) = 1.0_dp
    end do
    if (turns%enabled .and. j >= 1) axes = matmul(turns%base, turn_sequence(turn_index(turns, d, j), turns%max_angle))
  end function lattice_axes

  !> Each level its own turns: offset index j of level k (d = unit 2**(k/3)) takes turn number
  !> j + 64 k (k modulo 128; offsets <= 64). An offset's effect decorrelates from level to level
  !> (it is a fraction of d), a turn's would not (the lattice's anisotropy does not scale with
  !> d): the same turns on every level made one error common to all level means, which their
  !> scatter cannot show (a 3:2:1 ellipsoid's bar missed by up to 2x, bench/continuum/coverage_turned.md).
  pure integer function turn_index(turns, d, j)
    type(lattice_turns_t), intent(in) :: turns
    real(dp), intent(in) :: d
    integer, intent(in) :: j
    turn_index = j + 64 * modulo(nint(3.0_dp * log(d / turns%unit) / log(2.0_dp)), 128)
  end function turn_index

  !> T = diag(Q, Q, D(Q)) (Q = lattice_axes(turns, d, j), D: strain_rotation): a sample's friction
  !> or grand resistance K' in the lattice's frame is T K' T^T in the input's.
  pure function input_frame_turn(turns, d, j) result(turn)
    type(lattice_turns_t), intent(in) :: turns
    real(dp), intent(in) :: d
    integer, intent(in) :: j
    real(dp) :: turn(6 + n_strain_modes, 6 + n_strain_modes), axes(3, 3)
    axes = lattice_axes(turns, d, j)
    turn = 0.0_dp
    turn(1:3, 1:3) = axes
    turn(4:6, 4:6) = axes
    turn(7:, 7:) = strain_rotation(axes)
  end function input_frame_turn

  !> The moments (shape units, input frame) of beads at `centres` (d, in the frame of lattice j:
  !> build_at), turned back about the pivot: x = pivot + Q (x' - pivot).
  pure function moments_in_input_frame(centres, d, turns, j) result(moments)
    real(dp), intent(in) :: centres(:, :), d
    type(lattice_turns_t), intent(in) :: turns
    integer, intent(in) :: j
    type(body_moments_t) :: moments
    real(dp) :: pivot(3)
    if (.not. (turns%enabled .and. j >= 1)) then
      moments = moments_of_beads(centres, d)
    else
      pivot = turns%pivot / d
      moments = moments_of_beads(spread(pivot, 2, size(centres, 2)) + &
                                 matmul(lattice_axes(turns, d, j), centres - spread(pivot, 2, size(centres, 2))), d)
    end if
  end function moments_in_input_frame

  !> Level k's bead diameter: the user's bead_diameter * 2**(k/3) (bead counts a factor 2 apart).
  pure real(dp) function level_diameter(config, k)
    type(run_config_t), intent(in) :: config
    integer, intent(in) :: k
    level_diameter = config%shape%bead_diameter * 2.0_dp**(k / 3.0_dp)
  end function level_diameter

  !> Collective. The friction job of c on a sample's beads (centres, d units) into job_result; its
  !> solves' record (iterations, convergence, largest residual) added to the sample's.
  subroutine solve_friction(ctx, c, centres, job_result, sample, err, control_rtol)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: c
    real(dp), intent(in) :: centres(:, :)
    type(friction_result_t), intent(out) :: job_result
    type(continuum_sample_t), intent(inout) :: sample
    type(error_t), intent(inout) :: err
    real(dp), intent(in) :: control_rtol   ! > 0: the control problem first, at this tolerance
    type(run_config_t) :: solved
    type(job_plan_t) :: plan
    solved = c
    associate (job => solved%hydrodynamics)
      job%error_estimate = .false.
      job%control_rtol = control_rtol
      job%progress = .false.
      job%checkpoint_file = ''
      job%stop_after_solves = 0   ! counts samples here (run_continuum_job)
      call plan_friction_job(ctx, solved, centres, plan, err)
      if (err%failed) return
      job%shell_layers = plan%shell_layers
      call friction_of_plan(ctx, job, plan, job_result, err)
      if (err%failed) return
    end associate
    call count_solves(job_result%solves)
    if (control_rtol > 0.0_dp) call count_solves(job_result%companion_solves)
  contains
    subroutine count_solves(solves)
      type(solve_statistics_t), intent(in) :: solves
      sample%iterations = sample%iterations + sum(max(solves%iterations, 0))
      if (.not. all(solves%converged_reason > 0 .or. solves%source /= 0)) sample%converged = 0
      sample%residual = max(sample%residual, maxval(solves%true_relative_residual))
    end subroutine count_solves
  end subroutine solve_friction

  !> A sample's friction (6 x 6) or grand resistance in the input's frame from its lattice's, by
  !> `turn` (input_frame_turn), whose leading block applies to the friction.
  pure function turned(turn, matrix)
    real(dp), intent(in) :: turn(:, :), matrix(:, :)
    real(dp) :: turned(size(matrix, 1), size(matrix, 1))
    associate (t => turn(1:size(matrix, 1), 1:size(matrix, 1)))
      turned = matmul(t, matmul(matrix, transpose(t)))
    end associate
  end function turned

  !> Collective. The body's size before any level is filled: a mesh's exact volume and second
  !> moments (moments_of_polyhedron; the lattice turns' pivot and base axes set from them),
  !> another shape's from one geometry-only fill at the user's
  !> bead_diameter d (first offset). Its bead count at d, volume / d^3, foresees every level's
  !> (beads ~ d^-3); its thinnest equivalent semi-axis bounds how coarse a level may be. The
  !> coarsest candidate level is the coarsest foreseen to hold minimum_coarsest_beads and to be a
  !> bead diameter thick (d_k <= twice the thinnest semi-axis); levels are filled (survey_level) only from there down, so a level
  !> without beads is never visited, whatever the machine's speed.
  subroutine survey_body(ctx, config, mesh, survey, err)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: config
    type(triangle_mesh_t), intent(in) :: mesh
    type(ladder_survey_t), intent(out) :: survey
    type(error_t), intent(inout) :: err
    type(bead_model_t) :: model
    type(body_moments_t) :: moments
    real(dp) :: semi_axes(3), axes(3, 3), d, numbers(25), beads
    type(error_t) :: no_axes
    integer :: ierr
    d = config%shape%bead_diameter
    if (config%shape%name == 'mesh') then
      if (ctx%rank == 0) then
        ! About the first vertex (far-off coordinates lose no digits); the centroid is the pivot of turns.
        moments = moments_about_origin(moments_of_polyhedron(mesh%vertices, mesh%triangles, mesh%vertices(:, 1)), &
                                       mesh%vertices(:, 1))
        ! The turns' base axes: a pass over the vertices only when the job turns.
        if (config%continuum%turned_lattices) call equivalent_ellipsoid(moments, 0.0_dp, semi_axes, axes, no_axes)
        numbers = [moments%packed(), moments%centroid(), &
                   reshape(tighter_box_axes(mesh%vertices, axes, config%continuum%turned_lattices .and. &
                                                                      .not. no_axes%failed), [9])]
      end if
      call MPI_Bcast(numbers, 25, MPI_DOUBLE_PRECISION, 0, ctx%comm, ierr)
      moments = unpacked_moments(numbers(1:packed_moments_size))
      survey%moments = moments
      survey%turns = lattice_turns_t(config%continuum%turned_lattices, numbers(14:16), reshape(numbers(17:25), [3, 3]), &
                                     config%continuum%turn_angle * acos(-1.0_dp) / 180.0_dp, d)
    else
      call build_at(ctx, config, mesh, survey%turns, d, 1, model, err)
      if (err%failed) return
      moments = moments_of_beads(model%centres, d)
    end if
    beads = moments%volume / d**3
    if (beads < 2.0_dp) then
      call raise(err, '&continuum: the ' // trim(config%shape%name) // ' holds ' // trim(str_approx(beads)) // &
                 ' bead(s) at its bead_diameter = ' // diameter_text(d) // &
                 ': give the bead diameter of an ordinary run of the body (a finer one)')
      return
    end if
    call equivalent_ellipsoid(moments, 0.0_dp, semi_axes, axes, err)
    if (err%failed) return
    survey%user_beads = nint(min(beads, 2.0e9_dp))
    survey%thinnest = minval(semi_axes)
    ! beads(k) ~ beads 2**(-k) >= minimum_coarsest_beads, and d_k = d 2**(k/3) <= 2 thinnest
    ! (a bead across the thinnest extent; the budget then chooses how much finer to go).
    survey%coarsest = min(floor(log(beads / minimum_coarsest_beads) / log(2.0_dp)), &
                          floor(3.0_dp * log(2.0_dp * survey%thinnest / d) / log(2.0_dp)))
    survey%finest = survey%coarsest - config%continuum%levels + 1 - ladder_span
    allocate (survey%beads(survey%finest:survey%coarsest), survey%seconds(survey%finest:survey%coarsest), &
              survey%control_seconds(survey%finest:survey%coarsest))
    survey%beads = -1
    survey%seconds = -1.0_dp
    survey%control_seconds = -1.0_dp
  end subroutine survey_body

  !> The axes (columns, a proper rotation) that box the vertices tighter: the input's, or the
  !> principal axes `principal` when given (`use_principal`) and their bounding box is smaller.
  pure function tighter_box_axes(vertices, principal, use_principal) result(axes)
    real(dp), intent(in) :: vertices(:, :), principal(3, 3)
    logical, intent(in) :: use_principal
    real(dp) :: axes(3, 3), q(3, 3), low(3), high(3), x(3)
    integer :: a, v
    axes = 0.0_dp
    do a = 1, 3
      axes(a, a) = 1.0_dp
    end do
    if (.not. use_principal) return
    q = principal
    if (dot_product(q(:, 3), cross(q(:, 1), q(:, 2))) < 0.0_dp) q(:, 3) = -q(:, 3)
    low = huge(1.0_dp)
    high = -huge(1.0_dp)
    do v = 1, size(vertices, 2)
      x = matmul(vertices(:, v), q)   ! q^T v: the vertex in the principal frame
      low = min(low, x)
      high = max(high, x)
    end do
    if (product(high - low) < product(maxval(vertices, dim=2) - minval(vertices, dim=2))) axes = q
  end function tighter_box_axes

  !> Collective. Level k surveyed once: its bead count at the generic offset and the dry run's
  !> estimate of one sample (uncalibrated; 0 s below minimum_coarsest_beads, where no plan is
  !> made); a plan refused for memory leaves `refused` set and seconds = -2.
  subroutine survey_level(ctx, config, mesh, survey, k, refused, err)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: config
    type(triangle_mesh_t), intent(in) :: mesh
    type(ladder_survey_t), intent(inout) :: survey
    integer, intent(in) :: k
    type(error_t), intent(inout) :: refused, err
    type(run_config_t) :: c
    type(bead_model_t) :: model
    if (survey%seconds(k) >= 0.0_dp) return
    ! At the generic offset, as the pilot and most samples: no mirror plane of the lattice left.
    call build_at(ctx, config, mesh, survey%turns, level_diameter(config, k), generic_offset, model, err, c)
    if (err%failed) return
    survey%beads(k) = size(model%centres, 2)
    survey%seconds(k) = 0.0_dp
    survey%control_seconds(k) = 0.0_dp
    if (survey%beads(k) < minimum_coarsest_beads) return
    call sample_estimates(ctx, c, model%centres, survey%seconds(k), survey%control_seconds(k), refused)
    if (refused%failed) survey%seconds(k) = -2.0_dp
  end subroutine survey_level

  !> Collective. The dry run's estimate (s) of a sample of these beads (with control samples, its
  !> control solve included) and of a control sample (control_settings alone; 0 without control
  !> samples); `refused` when the plan is (memory).
  subroutine sample_estimates(ctx, sample_config, centres, seconds, control_seconds, refused)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: sample_config
    real(dp), intent(in) :: centres(:, :)
    real(dp), intent(out) :: seconds, control_seconds
    type(error_t), intent(inout) :: refused
    type(run_config_t) :: c
    type(job_plan_t) :: plan
    c = sample_config
    c%dry_run = .false.
    c%hydrodynamics%error_estimate = .false.
    c%hydrodynamics%progress = .false.
    seconds = 0.0_dp
    control_seconds = 0.0_dp
    call plan_friction_job(ctx, c, centres, plan, refused)
    if (refused%failed) return
    seconds = plan%estimate%seconds_total
    if (sample_config%continuum%control_offsets == 0) return
    call plan_friction_job(ctx, control_settings(c), centres, plan, refused)
    if (refused%failed) return
    control_seconds = plan%estimate%seconds_total
    seconds = seconds + control_seconds
  end subroutine sample_estimates

  !> The control problem of a sample (docs/theory.md T18, "Control samples"): the friction job at
  !> order L - 1 (companion_orders) with five times the job's Krylov tolerance. A control needs no
  !> accuracy, only to be computed alike on every sample (the level's mean stays unbiased) and to
  !> follow the order-L sample's scatter. At 1e-2 the Krylov solves stop after 3-9 iterations, and
  !> which iteration meets the tolerance moved a bent rod's solver error by 0.26 % between two
  !> offsets of its 171k-bead level (0.35 % against 0.085 % in one entry); at 5e-3 (8-19
  !> iterations) the two differ by 0.02 % at most, for 1.18 times the run time (3e-3: 0.005 %,
  !> 1.75 times; docs/theory.md T18).
  pure function control_settings(config) result(control)
    type(run_config_t), intent(in) :: config
    type(run_config_t) :: control
    control = config
    call companion_orders(config%hydrodynamics%multipole_order, config%hydrodynamics%potential_order, &
                          control%hydrodynamics%multipole_order, control%hydrodynamics%potential_order)
    control%hydrodynamics%krylov_rtol = control_rtol(config)
    control%hydrodynamics%krylov_rtol_on_command_line = .false.
    ! The single-bead preconditioner, as the full samples' control problem has it (their
    ! companion, friction_job.F90): the same iterates on every sample.
    control%hydrodynamics%near_field_radius = 0.0_dp
    control%hydrodynamics%near_field_cluster = 0
  end function control_settings

  !> The Krylov tolerance of a control solve: control_tolerance_factor times the job's.
  pure real(dp) function control_rtol(config)
    type(run_config_t), intent(in) :: config
    control_rtol = control_tolerance_factor * solve_rtol(config%hydrodynamics)
  end function control_rtol

  !> The estimated time (s) of a level's samples, ordinary and control, from one of each (sample_estimates).
  pure real(dp) function level_seconds(config, seconds, control_seconds)
    type(run_config_t), intent(in) :: config
    real(dp), intent(in) :: seconds, control_seconds
    level_seconds = config%continuum%offsets * seconds + config%continuum%control_offsets * control_seconds
  end function level_seconds

  !> Collective. fill_budget's next control sample (docs/theory.md T18, "Filling the budget"):
  !> its level, or 0 when no level's next control sample fits in `seconds_left` (its cost: the mean
  !> of the level's control samples so far) or none would narrow the bar. The quantities weighed
  !> are the six diagonal mobility entries in the axes of the body's equivalent ellipsoid, each
  !> relative to its extrapolation so far, their level variances as continuum_values forms them
  !> (with the moment control's shift and factor); rank 0 decides for all (its clock).
  !> `corrected` holds rank 0's corrected samples: only those added since the last call are
  !> corrected here, and only the six quantities weighed are fitted (a decision costs no more than
  !> a sample's share).
  integer function fill_level(ctx, config, diameters, samples, body, axes, reference_length, corrected, seconds_left, &
                              err) result(level)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: config
    real(dp), intent(in) :: diameters(:), axes(3, 3), reference_length, seconds_left
    type(continuum_sample_t), intent(in) :: samples(:)
    type(body_moments_t), intent(in) :: body
    type(corrected_sample_t), allocatable, intent(inout) :: corrected(:)
    type(error_t), intent(inout) :: err
    type(corrected_sample_t) :: one
    real(dp) :: paired(6, size(diameters)), per_control(6, size(diameters)), costs(size(diameters))
    real(dp) :: frame(6, 6), semi(3), ellipsoid_axes(3, 3), y(6, size(samples)), x(6, size(samples))
    real(dp) :: features(n_moment_features, size(samples)), body_features(n_moment_features), body_packed(packed_moments_size)
    logical :: on_level(size(samples)), full(size(samples))
    integer :: k, q, s, ierr
    level = 0
    if (ctx%rank == 0) then
      body_packed = body%packed()
      features = moment_features(reshape([(samples(s)%moments%packed(), s = 1, size(samples))], &
                                         [packed_moments_size, size(samples)]), body_packed)
      body_features = body_moment_features(body_packed)
      do s = size(corrected) + 1, size(samples)
        call correct_sample(samples(s), body, axes, reference_length, config%continuum%control_offsets > 0, one, err)
        if (err%failed) exit
        corrected = [corrected, one]
      end do
      if (.not. err%failed) call equivalent_ellipsoid(body, 0.0_dp, semi, ellipsoid_axes, err)
      if (.not. err%failed) then
        frame = 0.0_dp
        frame(1:3, 1:3) = ellipsoid_axes
        frame(4:6, 4:6) = ellipsoid_axes
        full = samples%full
        do q = 1, 6
          associate (entry => frame(:, q))
            do s = 1, size(samples)
              y(q, s) = dot_product(entry, matmul(reshape(corrected(s)%mobility, [6, 6]), entry))
              x(q, s) = dot_product(entry, matmul(reshape(corrected(s)%control_mobility, [6, 6]), entry))
            end do
          end associate
        end do
        ! Relative to each entry's value, so that every entry counts alike.
        call fill_variance_parts(diameters, y, x, full, samples%level, features, body_features, &
                                 config%continuum%moment_control, paired, per_control)
        do k = 1, size(diameters)
          on_level = samples%level == k .and. .not. full
          costs(k) = 0.0_dp
          if (count(on_level) > 0) costs(k) = sum(pack(samples%seconds, on_level)) / count(on_level)
        end do
        level = next_fill_level(diameters, paired, per_control, [(count(samples%level == k), k = 1, size(diameters))], &
                                costs, seconds_left, max_samples_per_level)
      end if
    end if
    call agree_on_error(ctx, err)
    if (err%failed) return
    call MPI_Bcast(level, 1, MPI_INTEGER, 0, ctx%comm, ierr)
  end function fill_level

  !> Collective. The finest ladder whose levels all hold minimum_coarsest_beads (the coarsest
  !> is the fewest) and whose estimate times `calibration` fits the time budget. With none that
  !> fits: refused when uncalibrated (before any solve), naming the cheapest feasible ladder and
  !> its estimate; after a pilot (calibration > 1) the cheapest feasible ladder is run, with a
  !> warning, since the pilot has shown only that this machine is slower than the estimates.
  subroutine budget_ladder(ctx, config, mesh, survey, calibration, diameters, estimated_seconds, chosen, err)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: config
    type(triangle_mesh_t), intent(in) :: mesh
    type(ladder_survey_t), intent(inout) :: survey
    real(dp), intent(in) :: calibration
    real(dp), allocatable, intent(out) :: diameters(:)
    real(dp), intent(out) :: estimated_seconds
    integer, intent(out) :: chosen     ! the finest level's index k
    type(error_t), intent(inout) :: err
    type(error_t) :: refused
    real(dp) :: total, cheapest_total
    integer :: j, k, levels, cheapest
    levels = config%continuum%levels
    chosen = huge(1)
    cheapest = huge(1)
    cheapest_total = 0.0_dp
    do j = survey%coarsest - levels + 1, survey%finest, -1
      total = 0.0_dp
      do k = j, j + levels - 1
        call survey_level(ctx, config, mesh, survey, k, refused, err)
        if (err%failed) return
        if (refused%failed) exit
        total = total + calibration * level_seconds(config, survey%seconds(k), survey%control_seconds(k))
      end do
      if (refused%failed) exit
      if (survey%beads(j + levels - 1) < minimum_coarsest_beads) cycle   ! foreseen, not found: go finer
      if (cheapest == huge(1)) then
        cheapest = j
        cheapest_total = total
      end if
      if (total > config%continuum%time_budget) exit   ! finer ladders cost more
      chosen = j
      estimated_seconds = total
    end do
    if (chosen == huge(1) .and. (cheapest == huge(1) .or. calibration <= 1.0_dp)) then
      if (cheapest == huge(1)) then
        call raise(err, '&continuum: no ladder of ' // str(levels) // ' levels with at least ' // &
                   str(minimum_coarsest_beads) // ' beads on the coarsest fits in memory' // &
                   either(refused%failed, ' (' // trim(refused%message) // ')', '') // &
                   '; give fewer levels, or a coarser bead_diameter')
      else
        call raise(err, '&continuum: no ladder of ' // str(levels) // ' levels fits the time budget of ' // &
                   trim(seconds_text(config%continuum%time_budget)) // ': the cheapest whose coarsest level holds ' // &
                   str(minimum_coarsest_beads) // ' beads (bead diameters ' // &
                   trim(ladder_text(config, cheapest, levels)) // ') is estimated at ' // trim(seconds_text(cheapest_total)) // &
                   '; raise time_budget to that, or give finest_bead_diameter')
      end if
      return
    end if
    if (chosen == huge(1)) then
      chosen = cheapest
      estimated_seconds = cheapest_total
      if (ctx%rank == 0) write (*, '(a)') 'beadmob: warning: &continuum: the pilot solve ran ' // &
        trim(str_approx(calibration)) // ' times slower than estimated; even the cheapest ladder is estimated at ' // &
        trim(seconds_text(cheapest_total)) // ', beyond the time budget: running it'
    end if
    diameters = [(level_diameter(config, k), k = chosen + levels - 1, chosen, -1)]
  end subroutine budget_ladder

  !> Collective. The ladder ending at `finest` (finest_bead_diameter or a checkpoint's), refused
  !> before any solve when its coarsest level holds fewer than minimum_coarsest_beads beads.
  subroutine fixed_ladder(ctx, config, mesh, survey, finest, diameters, estimated_seconds, err)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: config
    type(triangle_mesh_t), intent(in) :: mesh
    type(ladder_survey_t), intent(inout) :: survey
    real(dp), intent(in) :: finest
    real(dp), allocatable, intent(out) :: diameters(:)
    real(dp), intent(out) :: estimated_seconds
    type(error_t), intent(inout) :: err
    type(run_config_t) :: c
    type(bead_model_t) :: model
    type(error_t) :: refused
    real(dp) :: seconds, control_seconds
    integer :: k, levels
    levels = config%continuum%levels
    diameters = [(finest * 2.0_dp**((levels - k) / 3.0_dp), k = 1, levels)]
    estimated_seconds = 0.0_dp
    do k = 1, levels
      call build_at(ctx, config, mesh, survey%turns, diameters(k), generic_offset, model, err, c)
      if (err%failed) return
      if (k == 1 .and. size(model%centres, 2) < minimum_coarsest_beads) then
        call raise(err, '&continuum: finest_bead_diameter = ' // diameter_text(finest) // ' puts ' // str(size(model%centres, 2)) // &
                   ' beads on the coarsest of ' // str(levels) // ' levels (bead diameter ' // diameter_text(diameters(1)) // &
                   '; at least ' // str(minimum_coarsest_beads) // ' needed): a ladder of ' // str(levels) // &
                   ' levels of this body needs finest_bead_diameter <= ' // &
                   diameter_text(level_diameter(config, survey%coarsest - levels + 1)))
        return
      end if
      call sample_estimates(ctx, c, model%centres, seconds, control_seconds, refused)
      if (refused%failed) cycle
      estimated_seconds = estimated_seconds + level_seconds(config, seconds, control_seconds)
    end do
  end subroutine fixed_ladder

  !> Collective. The pilot's level: the coarsest with at least pilot_beads beads (a second or
  !> so of solving), but none finer than the ladder's finest level `lowest` (then it is a sample).
  subroutine pilot_level_of(ctx, config, mesh, survey, lowest, k, err)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: config
    type(triangle_mesh_t), intent(in) :: mesh
    type(ladder_survey_t), intent(inout) :: survey
    integer, intent(in) :: lowest
    integer, intent(out) :: k
    type(error_t), intent(inout) :: err
    type(error_t) :: refused
    k = survey%coarsest
    do while (k > lowest)
      call survey_level(ctx, config, mesh, survey, k, refused, err)
      if (err%failed) return
      if (survey%beads(k) >= pilot_beads) exit
      k = k - 1
    end do
    call survey_level(ctx, config, mesh, survey, k, refused, err)
  end subroutine pilot_level_of

  !> Rank 0 prints the ladder: its bead diameters and bead counts (generic offset), the estimate,
  !> what fill_budget does with the rest (`fills`), and before the pilot, how the pilot may change it.
  subroutine print_ladder(ctx, config, survey, diameters, estimated_seconds, calibration, fills, pilot_level)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: config
    type(ladder_survey_t), intent(in) :: survey
    real(dp), intent(in) :: diameters(:), estimated_seconds, calibration
    logical, intent(in) :: fills
    integer, intent(in), optional :: pilot_level
    integer :: k, levels, first
    if (ctx%rank /= 0) return
    levels = size(diameters)
    write (*, '(a)') 'beadmob: continuum ladder of ' // str(levels) // ' levels x ' // str(config%continuum%offsets) // &
      ' offsets' // either(config%continuum%control_offsets > 0, ' (+ ' // str(config%continuum%control_offsets) // &
      ' control samples of order ' // str(config%hydrodynamics%multipole_order - 1) // ')', '') // &
      ', bead diameters (coarsest first):'
    write (*, '(4x, *(es11.4))') diameters
    first = nint(3.0_dp * log(diameters(levels) / config%shape%bead_diameter) / log(2.0_dp))
    if (abs(level_diameter(config, first) - diameters(levels)) <= 1.0e-9_dp * diameters(levels) .and. &
        first >= survey%finest .and. first + levels - 1 <= survey%coarsest) then
      if (all(survey%beads(first:first + levels - 1) >= 0)) &
        write (*, '(a, *(i11))') '  beads', (survey%beads(k), k = first + levels - 1, first, -1)
    end if
    write (*, '(a, f0.0, a, f0.0, a, f0.2, a)') '  estimated time ', estimated_seconds, ' s (budget ', &
      config%continuum%time_budget, ' s; the dry run''s estimates times ', calibration, &
      either(calibration /= 1.0_dp, ', from a pilot solve)', ')')
    if (fills .and. estimated_seconds < config%continuum%time_budget) write (*, '(a)') '  fill_budget: the rest, ' // &
      'about ' // trim(seconds_text(config%continuum%time_budget - estimated_seconds)) // ', then buys control ' // &
      'samples one at a time, each on the level where it narrows the bar most per second (up to ' // &
      str(max_samples_per_level) // ' samples per level)'
    if (present(pilot_level)) then
      if (pilot_level /= huge(1)) write (*, '(a)') '  a run first solves a pilot of ' // str(survey%beads(pilot_level)) // &
        ' beads (bead diameter ' // trim(diameter_text(level_diameter(config, pilot_level))) // '); if it runs slower ' // &
        'than its estimate, the estimates are scaled up and the finest level may move coarser (never below ' // &
        str(minimum_coarsest_beads) // ' beads on the coarsest)'
    end if
  end subroutine print_ladder

  !> "d1 ... d2" of the ladder whose finest level is k.
  function ladder_text(config, k, levels) result(text)
    type(run_config_t), intent(in) :: config
    integer, intent(in) :: k, levels
    character(len=:), allocatable :: text
    text = diameter_text(level_diameter(config, k + levels - 1)) // ' ... ' // diameter_text(level_diameter(config, k))
  end function ladder_text

  !> A bead diameter in messages: four significant digits (levels are 26 % apart).
  function diameter_text(d) result(text)
    real(dp), intent(in) :: d
    character(len=:), allocatable :: text
    character(len=32) :: buffer
    write (buffer, '(es10.3e2)') d
    text = trim(adjustl(buffer))
  end function diameter_text

  function seconds_text(seconds) result(text)
    real(dp), intent(in) :: seconds
    character(len=:), allocatable :: text
    character(len=32) :: buffer
    if (seconds < 10.0_dp) then
      write (buffer, '(f0.2)') seconds
      if (buffer(1:1) == '.') buffer = '0' // buffer(:len(buffer) - 1)   ! the blank at its end makes room
    else
      write (buffer, '(i0)') nint(seconds)
    end if
    text = trim(buffer) // ' s'
  end function seconds_text

  !> The corrected samples, the level means and the extrapolation (docs/theory.md T18).
  subroutine continuum_values(config, turns, diameters, samples, body, volumes, axes, result, err)
    type(run_config_t), intent(in) :: config
    type(lattice_turns_t), intent(in) :: turns
    real(dp), intent(in) :: diameters(:), volumes(:), axes(3, 3)
    type(continuum_sample_t), intent(in) :: samples(:)
    type(body_moments_t), intent(in) :: body
    type(continuum_result_t), intent(inout) :: result
    type(error_t), intent(inout) :: err
    type(corrected_sample_t) :: corrected
    type(continuum_value_t) :: fit
    real(dp) :: true_axes(3, 3), true_semi(3), sample_axes(3, 3), sample_semi(3), mean, volume_spread
    real(dp) :: relative_volume_error, volume_power(41), nan
    real(dp) :: body_grand(6 + n_strain_modes, 6 + n_strain_modes), sample_grand(6 + n_strain_modes, 6 + n_strain_modes)
    integer :: s, k, q, n, levels, row, column
    integer, allocatable :: members(:), full_members(:)
    logical :: controlled
    real(dp) :: features(n_moment_features, size(samples)), body_features(n_moment_features)

    n = size(samples)
    levels = size(diameters)
    nan = ieee_value(0.0_dp, ieee_quiet_nan)
    controlled = config%continuum%control_offsets > 0
    result%control_offsets = config%continuum%control_offsets
    result%offsets = config%continuum%offsets
    result%multipole_order = config%hydrodynamics%multipole_order
    result%moment_fills = merge(0, config%continuum%moment_fills, config%shape%name == 'mesh')
    result%time_budget = config%continuum%time_budget
    result%bead_diameters = diameters
    result%volume = body%volume
    call level_mean(volumes, mean, volume_spread)
    result%volume_error = volume_spread
    relative_volume_error = volume_spread / body%volume
    result%centroid = body%centroid()
    result%body_moments = body%packed()
    call equivalent_ellipsoid(body, 0.0_dp, result%semi_axes, result%axes, err)
    if (err%failed) return
    allocate (result%sample_level(n), result%sample_beads(n), result%sample_iterations(n), result%sample_converged(n))
    allocate (result%sample_offset(3, n), result%sample_residual(n), result%sample_seconds(n), result%sample_symmetry_error(n))
    allocate (result%sample_friction(36, n), result%sample_mobility(36, n), result%sample_coefficients(5, n))
    allocate (result%sample_moments(packed_moments_size, n), result%sample_lattice_axes(9, n))
    result%turned_lattices = turns%enabled
    result%lattice_pivot = turns%pivot
    result%flow = config%hydrodynamics%flow
    if (result%flow) allocate (result%sample_velocity_per_strain(6 * n_strain_modes, n), &
                               result%sample_stresslet_per_strain(n_strain_modes**2, n))
    if (controlled) allocate (result%sample_full(n), result%sample_control_friction(36, n), &
                              result%sample_control_mobility(36, n), result%sample_control_coefficients(5, n))
    if (controlled .and. result%flow) allocate (result%sample_control_velocity_per_strain(6 * n_strain_modes, n), &
                                                result%sample_control_stresslet_per_strain(n_strain_modes**2, n))
    do s = 1, n
      associate (p => samples(s), d => samples(s)%bead_diameter)
        result%sample_level(s) = p%level
        result%sample_beads(s) = p%beads
        result%sample_iterations(s) = p%iterations
        result%sample_converged(s) = p%converged
        result%sample_offset(:, s) = p%offset
        result%sample_lattice_axes(:, s) = reshape(lattice_axes(turns, p%bead_diameter, p%offset_index), [9])
        result%sample_residual(s) = p%residual
        result%sample_seconds(s) = p%seconds
        result%sample_moments(:, s) = p%moments%packed()
        call correct_sample(p, body, axes, result%reference_length, controlled, corrected, err)
        if (err%failed) return
        result%sample_mobility(:, s) = corrected%mobility
        result%sample_coefficients(:, s) = corrected%coefficients
        if (result%flow) then
          ! The equivalent ellipsoids (with a cell's d^2 / 12) correct the flow as the friction.
          call equivalent_ellipsoid(p%moments, d**2 / 12.0_dp, sample_semi, sample_axes, err)
          if (.not. err%failed) call equivalent_ellipsoid(body, d**2 / 12.0_dp, true_semi, true_axes, err)
          if (err%failed) return
          result%sample_velocity_per_strain(:, s) = nan
          result%sample_stresslet_per_strain(:, s) = nan
          body_grand = ellipsoid_grand_resistance(true_semi, true_axes)
          sample_grand = ellipsoid_grand_resistance(sample_semi, sample_axes)
          if (p%full) call sample_flow(p%grand, d, body_grand, sample_grand, result%sample_velocity_per_strain(:, s), &
                                       result%sample_stresslet_per_strain(:, s))
          if (controlled) call sample_flow(p%control_grand, d, body_grand, sample_grand, &
                                           result%sample_control_velocity_per_strain(:, s), &
                                           result%sample_control_stresslet_per_strain(:, s))
        end if
        result%sample_symmetry_error(s) = nan   ! a control sample: nothing solved at order L
        result%sample_friction(:, s) = nan
        if (p%full) then
          result%sample_symmetry_error(s) = norm2(p%friction - transpose(p%friction)) / norm2(p%friction)
          result%sample_friction(:, s) = reshape(p%friction, [36])
        end if
        if (controlled) then
          result%sample_full(s) = merge(1, 0, p%full)
          result%sample_control_friction(:, s) = reshape(p%control, [36])
          result%sample_control_mobility(:, s) = corrected%control_mobility
          result%sample_control_coefficients(:, s) = corrected%control_coefficients
        end if
        if (err%failed) return
      end associate
    end do

    ! Level means and the fit; the volume's uncertainty scales mobility entries as length^-p.
    allocate (result%level_mobility(36, levels), result%level_mobility_error(36, levels))
    allocate (result%level_coefficients(5, levels), result%level_coefficient_error(5, levels))
    ! A mobility entry scales as length^-p with the body: p = 1 (tt), 2 (tr, rt), 3 (rr);
    ! mu11 mu22 mu33 are tt, mu42 mu51 rt.
    do q = 1, 36
      row = modulo(q - 1, 6) + 1
      column = (q - row) / 6 + 1
      volume_power(q) = 1 + merge(1, 0, row > 3) + merge(1, 0, column > 3)
    end do
    volume_power(37:41) = [1, 1, 1, 2, 2]
    result%moment_control = config%continuum%moment_control
    features = moment_features(result%sample_moments, result%body_moments)
    body_features = body_moment_features(result%body_moments)
    call level_means(result%sample_mobility, result%level_mobility, result%level_mobility_error, &
                     result%sample_control_mobility)
    call level_means(result%sample_coefficients, result%level_coefficients, result%level_coefficient_error, &
                     result%sample_control_coefficients)
    do q = 1, 36
      row = modulo(q - 1, 6) + 1
      column = (q - row) / 6 + 1
      fit = extrapolate_to_zero(diameters, result%level_mobility(q, :), result%level_mobility_error(q, :), 0.0_dp)
      result%mobility(row, column) = fit%value
      result%mobility_error(row, column) = fit%error + abs(fit%value) * volume_power(q) / 3.0_dp * relative_volume_error
      result%mobility_level_excess(row, column) = fit%excess_deviation
    end do
    do q = 1, 5
      fit = extrapolate_to_zero(diameters, result%level_coefficients(q, :), result%level_coefficient_error(q, :), 0.0_dp)
      result%coefficients(q) = fit%value
      result%coefficient_error(q) = fit%error + abs(fit%value) * volume_power(36 + q) / 3.0_dp * relative_volume_error
      result%coefficient_standard_error(q) = fit%standard_error
      result%coefficient_linear(q) = fit%linear_value
      result%coefficient_reduced(q) = fit%reduced_value
      result%coefficient_next_term(q) = fit%next_term
      result%coefficient_level_excess(q) = fit%excess_deviation
    end do
    result%mobility = 0.5_dp * (result%mobility + transpose(result%mobility))
    call invert(result%mobility, result%friction, err, 'the extrapolated mobility')
    if (result%flow) call flow_values()

  contains

    !> Every level's mean of every quantity (rows of values, a column per sample) and its standard
    !> error (columns of mean and error: the levels); with control samples the controlled mean (T18:
    !> the order L - 1 solves `controls` on all of a level's samples correct the mean over its full
    !> ones), with moment_control the samples' moments as control variates besides (T18, "Moment
    !> control"). The sample_control_* arrays are allocated only with control samples, and an
    !> unallocated one is not present.
    subroutine level_means(values, mean, error, controls)
      real(dp), intent(in) :: values(:, :)
      real(dp), intent(out) :: mean(:, :), error(:, :)
      real(dp), intent(in), optional :: controls(:, :)
      real(dp) :: shift(size(values, 1), size(values, 2)), factor(size(values, 1))
      integer :: row
      ! Each quantity's moment shift (over all levels: the regression is pooled), then the levels.
      shift = 0.0_dp
      factor = 1.0_dp
      if (result%moment_control) then
        if (present(controls)) then
          call moment_control_shift(controls, result%sample_level, features, body_features, shift, factor)
        else
          call moment_control_shift(values, result%sample_level, features, body_features, shift, factor)
        end if
      end if
      do k = 1, levels
        members = pack([(s, s = 1, n)], result%sample_level == k)
        full_members = pack(members, samples(members)%full)
        do row = 1, size(values, 1)
          if (present(controls)) then
            call controlled_level_mean(values(row, full_members) - shift(row, full_members), &
                                       controls(row, full_members) - shift(row, full_members), &
                                       controls(row, members) - shift(row, members), mean(row, k), error(row, k))
          else
            call level_mean(values(row, members) - shift(row, members), mean(row, k), error(row, k))
          end if
        end do
      end do
      error = error * spread(sqrt(factor), 2, levels)
    end subroutine level_means

    !> The flow's response (theory.md T19) extrapolated entry by entry as the mobility's: the
    !> velocity per strain (translation ~ length, rotation ~ length^0) and the stresslet per strain
    !> (~ length^3), each with the volume's share in its bar.
    subroutine flow_values()
      integer, parameter :: nv = 6 * n_strain_modes, nt = n_strain_modes**2
      real(dp) :: power
      allocate (result%level_velocity_per_strain(nv, levels), result%level_velocity_per_strain_error(nv, levels))
      allocate (result%level_stresslet_per_strain(nt, levels), result%level_stresslet_per_strain_error(nt, levels))
      call level_means(result%sample_velocity_per_strain, result%level_velocity_per_strain, &
                       result%level_velocity_per_strain_error, result%sample_control_velocity_per_strain)
      call level_means(result%sample_stresslet_per_strain, result%level_stresslet_per_strain, &
                       result%level_stresslet_per_strain_error, result%sample_control_stresslet_per_strain)
      do q = 1, nv
        row = modulo(q - 1, 6) + 1
        column = (q - row) / 6 + 1
        fit = extrapolate_to_zero(diameters, result%level_velocity_per_strain(q, :), &
                                  result%level_velocity_per_strain_error(q, :), 0.0_dp)
        power = merge(1.0_dp, 0.0_dp, row <= 3)
        result%velocity_per_strain(row, column) = fit%value
        result%velocity_per_strain_error(row, column) = fit%error + abs(fit%value) * power / 3.0_dp * relative_volume_error
      end do
      do q = 1, nt
        row = modulo(q - 1, n_strain_modes) + 1
        column = (q - row) / n_strain_modes + 1
        fit = extrapolate_to_zero(diameters, result%level_stresslet_per_strain(q, :), &
                                  result%level_stresslet_per_strain_error(q, :), 0.0_dp)
        result%stresslet_per_strain(row, column) = fit%value
        result%stresslet_per_strain_error(row, column) = fit%error + abs(fit%value) * relative_volume_error
      end do
      result%stresslet_per_strain = 0.5_dp * (result%stresslet_per_strain + transpose(result%stresslet_per_strain))
      result%stresslet_per_strain_error = max(result%stresslet_per_strain_error, &
                                              transpose(result%stresslet_per_strain_error))
    end subroutine flow_values
  end subroutine continuum_values

  !> A flow sample (theory.md T19) in the shape's unit, corrected as its friction is by the
  !> equivalent ellipsoids' grand resistances B (the body's) and S (its own): T K T^T with T =
  !> B^(1/2) S^(-1/2) on the translation block and on the rotation-and-strain block (both scale
  !> as length^3; an ellipsoid couples neither to translation), so a sample that is its ellipsoid
  !> becomes the body's; then the free body's velocity and stresslet per unit strain (columns
  !> flattened).
  subroutine sample_flow(grand, d, body, sample, velocity, stresslet)
    integer, parameter :: n = 6 + n_strain_modes
    real(dp), intent(in) :: grand(n, n), d, body(n, n), sample(n, n)
    real(dp), intent(out) :: velocity(6 * n_strain_modes), stresslet(n_strain_modes**2)
    real(dp) :: lengths(n), corrected(n, n), scaling(n, n), v(6, n_strain_modes), t(n_strain_modes, n_strain_modes)
    logical :: ok
    integer :: b
    ! To the shape's unit: entry (m, n) ~ length^(1 + [m rotational or strain] + [n ...]).
    lengths = [1.0_dp, 1.0_dp, 1.0_dp, (d, b=4, n)]
    corrected = grand * d * spread(lengths, 2, n) * spread(lengths, 1, n)
    scaling = 0.0_dp
    scaling(1:3, 1:3) = matmul(symmetric_power(body(1:3, 1:3), 0.5_dp), symmetric_power(sample(1:3, 1:3), -0.5_dp))
    scaling(4:, 4:) = matmul(symmetric_power(body(4:, 4:), 0.5_dp), symmetric_power(sample(4:, 4:), -0.5_dp))
    corrected = matmul(scaling, matmul(corrected, transpose(scaling)))
    corrected = 0.5_dp * (corrected + transpose(corrected))
    call free_body_response(corrected, v, t, ok)
    velocity = reshape(v, [6 * n_strain_modes])
    stresslet = reshape(t, [n_strain_modes**2])
  end subroutine sample_flow

  !> Sample p corrected for the body its lattice gave it (docs/theory.md T18, step 2): its friction
  !> (and with control samples its order L - 1 friction) in the shape's unit, scaled by the ratio
  !> of the body's and its own equivalent ellipsoids' exact frictions (both with a lattice cell's
  !> d^2 / 12), as mobility and coefficients about the body's centroid in the frame `axes`.
  subroutine correct_sample(p, body, axes, reference_length, controlled, corrected, err)
    type(continuum_sample_t), intent(in) :: p
    type(body_moments_t), intent(in) :: body
    real(dp), intent(in) :: axes(3, 3), reference_length
    logical, intent(in) :: controlled
    type(corrected_sample_t), intent(out) :: corrected
    type(error_t), intent(inout) :: err
    real(dp) :: true_axes(3, 3), true_semi(3), sample_axes(3, 3), sample_semi(3), to_shape_units(6, 6), nan
    real(dp) :: body_friction(6, 6), sample_friction(6, 6)
    nan = ieee_value(0.0_dp, ieee_quiet_nan)
    corrected = corrected_sample_t(nan, nan, nan, nan)
    associate (d => p%bead_diameter)
      ! Force per velocity ~ length, torque per angular velocity ~ length^3.
      to_shape_units = spread([d, d, d, d**2, d**2, d**2], 2, 6) * spread([1.0_dp, 1.0_dp, 1.0_dp, d, d, d], 1, 6)
      call equivalent_ellipsoid(p%moments, d**2 / 12.0_dp, sample_semi, sample_axes, err)
      if (.not. err%failed) call equivalent_ellipsoid(body, d**2 / 12.0_dp, true_semi, true_axes, err)
    end associate
    if (err%failed) return
    body_friction = ellipsoid_friction(true_semi, true_axes)
    sample_friction = ellipsoid_friction(sample_semi, sample_axes)
    if (p%full) call mobility_of(p%friction, corrected%mobility, corrected%coefficients)
    if (controlled) call mobility_of(p%control, corrected%control_mobility, corrected%control_coefficients)

  contains

    subroutine mobility_of(solved, mobility, coefficients)
      real(dp), intent(in) :: solved(6, 6)
      real(dp), intent(out) :: mobility(36), coefficients(5)
      type(mobility_result_t) :: found
      real(dp) :: friction(6, 6)
      mobility = nan
      coefficients = nan
      if (err%failed) return
      friction = scaled_by_ratio(solved * to_shape_units, body_friction, sample_friction)
      friction = 0.5_dp * (friction + transpose(friction))
      call compute_mobility(friction, body%centroid(), axes, reference_length, found, err)
      if (err%failed) return
      mobility = reshape(found%mobility, [36])
      coefficients = found%coefficients
    end subroutine mobility_of
  end subroutine correct_sample

  !> The sample's friction K corrected by the ratio of its body's and its own equivalent
  !> ellipsoids' frictions B and S (docs/theory.md T18, step 2): T K T^T with T = B^(1/2) S^(-1/2)
  !> on the translation and the rotation blocks (B and S have no coupling), so a sample that is
  !> its ellipsoid (K = S) becomes the body's (B), and a sample that is the body scaled by s is
  !> scaled back exactly, whatever its shape (translation ~ s, rotation ~ s^3). The difference
  !> K + B - S, exact only for ellipsoids, left 10-20 % more scatter on two spheres' rotation.
  function scaled_by_ratio(friction, body, sample) result(corrected)
    real(dp), intent(in) :: friction(6, 6), body(6, 6), sample(6, 6)
    real(dp) :: corrected(6, 6), scaling(6, 6)
    scaling = ratio_scaling(body, sample)
    corrected = matmul(scaling, matmul(friction, transpose(scaling)))
  end function scaled_by_ratio

  !> T = B^(1/2) S^(-1/2) on the translation and the rotation blocks (scaled_by_ratio).
  function ratio_scaling(body, sample) result(scaling)
    real(dp), intent(in) :: body(6, 6), sample(6, 6)
    real(dp) :: scaling(6, 6)
    integer :: b
    scaling = 0.0_dp
    do b = 0, 3, 3
      scaling(b + 1:b + 3, b + 1:b + 3) = matmul(symmetric_power(body(b + 1:b + 3, b + 1:b + 3), 0.5_dp), &
                                                 symmetric_power(sample(b + 1:b + 3, b + 1:b + 3), -0.5_dp))
    end do
  end function ratio_scaling

  !> a^p of a symmetric positive definite matrix, by its eigenvalues.
  function symmetric_power(a, p) result(power)
    real(dp), intent(in) :: a(:, :), p
    real(dp) :: power(size(a, 1), size(a, 1)), vectors(size(a, 1), size(a, 1)), values(size(a, 1)), work(64 * size(a, 1))
    integer :: info, n
    n = size(a, 1)
    vectors = a
    call dsyev('V', 'U', n, vectors, n, values, work, size(work), info)
    power = matmul(vectors * spread(max(values, tiny(1.0_dp))**p, 1, n), transpose(vectors))
  end function symmetric_power

  !> Running mean of the moment fills.
  subroutine accumulate(total, one, fills)
    type(body_moments_t), intent(inout) :: total
    type(body_moments_t), intent(in) :: one
    integer, intent(in) :: fills
    total%volume = total%volume + one%volume / fills
    total%first = total%first + one%first / fills
    total%second = total%second + one%second / fills
  end subroutine accumulate

  subroutine print_continuum(config, c)
    type(run_config_t), intent(in) :: config
    type(continuum_result_t), intent(in) :: c
    integer :: k
    write (*, '(a)') 'beadmob: continuum of shape ' // trim(config%shape%name) // ': ' // str(size(c%bead_diameters)) // &
      ' levels x ' // str(c%offsets) // ' offsets' // either(c%control_offsets > 0, ' (+ ' // str(c%control_offsets) // &
      ' control offsets of order ' // str(c%multipole_order - 1) // ')', '') // ', ' // str(sum(c%sample_beads)) // &
      ' beads solved in all'
    if (c%filled) write (*, '(a, *(1x, i0))') '  fill_budget: samples per level (coarsest first)', &
      (count(c%sample_level == k), k = 1, size(c%bead_diameters))
    write (*, '(a, es12.5, a, es9.2, a)') '  volume ', c%volume, ' (+-', c%volume_error, '), equivalent ellipsoid'
    write (*, '(4x, 3es12.4)') c%semi_axes
    write (*, '(a, es12.5, a)') '  coefficients with L = ', c%reference_length, ' (' // &
      either(c%reference_length_from == 'finest level', 'the finest bead model''s size', &
             either(c%reference_length_from == 'body', 'the body''s extent', 'reference_length')) // ' along body x)'
    write (*, '(a)') '  level  bead diameter     mu11      mu22      mu33      mu42      mu51'
    do k = 1, size(c%bead_diameters)
      write (*, '(i7, es15.4, 5f10.5)') k, c%bead_diameters(k), c%level_coefficients(:, k)
    end do
    write (*, '(a, 5f10.5)') '  continuum (d -> 0):   ', c%coefficients
    write (*, '(a, 5f10.5)') '  its error (+-):       ', c%coefficient_error
    write (*, '(a)') '  result written to ' // trim(config%output) // ' (/continuum)'
    if (any(c%sample_converged == 0)) write (*, '(a)') 'beadmob: warning: not every Krylov solve of the ladder ' // &
      'converged; the result file flags it: /continuum all_converged = 0'
  end subroutine print_continuum

  !> The samples of a checkpoint whose key is the run's (rank 0 reads, all ranks get them); a
  !> checkpoint of another input is ignored with a note, a damaged one is an error.
  subroutine read_checkpoint(ctx, path, key, layout, finest, samples, err)
    type(run_context_t), intent(in) :: ctx
    character(len=*), intent(in) :: path, key
    type(sample_layout_t), intent(in) :: layout
    real(dp), intent(out) :: finest
    type(continuum_sample_t), allocatable, intent(inout) :: samples(:)
    type(error_t), intent(inout) :: err
    real(dp), allocatable :: numbers(:, :)
    character(len=256) :: header
    character(len=16) :: found_key
    logical :: exists
    integer :: unit, status, n, s, ierr, width
    real(dp), allocatable :: values(:)
    width = sample_numbers + extra_numbers(layout)
    allocate (values(width))
    n = 0
    finest = -1.0_dp
    allocate (numbers(width, 0))
    if (ctx%rank == 0) then
      inquire (file=path, exist=exists)
      if (exists) call read_samples()
      n = size(numbers, 2)
    end if
    call agree_on_error(ctx, err)
    if (err%failed) return
    call MPI_Bcast(n, 1, MPI_INTEGER, 0, ctx%comm, ierr)
    call MPI_Bcast(finest, 1, MPI_DOUBLE_PRECISION, 0, ctx%comm, ierr)
    if (ctx%rank /= 0) then
      deallocate (numbers)
      allocate (numbers(width, n))
    end if
    if (n > 0) call MPI_Bcast(numbers, width * n, MPI_DOUBLE_PRECISION, 0, ctx%comm, ierr)
    samples = [(unpack_sample(numbers(:, s), layout), s = 1, n)]

  contains

    subroutine read_samples()
      open (newunit=unit, file=path, status='old', action='read', iostat=status)
      if (status /= 0) then
        call raise(err, "cannot open the continuum checkpoint '" // path // "'")
        return
      end if
      read (unit, '(a)', iostat=status) header
      if (status /= 0 .or. index(header, checkpoint_header) /= 1) then
        call raise(err, "continuum checkpoint '" // path // "' is not one (delete it to start over)")
      else
        read (header(len(checkpoint_header) + 2:), *, iostat=status) found_key, finest
        if (status /= 0 .or. found_key /= key) then
          write (*, '(a)') 'beadmob: continuum: ' // path // ' is of another input; starting over'
          finest = -1.0_dp
        else
          do
            read (unit, *, iostat=status) values
            if (status /= 0) exit
            numbers = reshape([numbers, values], [width, size(numbers, 2) + 1])
          end do
          if (.not. is_iostat_end(status)) then
            call raise(err, "continuum checkpoint '" // path // "' line " // str(size(numbers, 2) + 2) // &
                       ': not a sample (delete the file to start over)')
          else
            write (*, '(a)') 'beadmob: continuum: resuming with ' // str(size(numbers, 2)) // ' samples of ' // path
          end if
        end if
      end if
      close (unit)
    end subroutine read_samples
  end subroutine read_checkpoint

  !> Rank 0: every sample so far to '<path>.tmp', renamed over the checkpoint (a kill while
  !> writing leaves the previous one whole).
  subroutine write_checkpoint(path, key, layout, finest, samples, err)
    character(len=*), intent(in) :: path, key
    type(sample_layout_t), intent(in) :: layout
    real(dp), intent(in) :: finest
    type(continuum_sample_t), intent(in) :: samples(:)
    type(error_t), intent(inout) :: err
    integer :: unit, status, s
    open (newunit=unit, file=path // '.tmp', status='replace', action='write', iostat=status)
    if (status == 0) write (unit, '(a, 1x, a, 1x, es25.17e3)', iostat=status) checkpoint_header, key, finest
    do s = 1, size(samples)
      if (status == 0) write (unit, '(*(es25.17e3, :, 1x))', iostat=status) pack_sample(samples(s), layout)
    end do
    if (status == 0) close (unit, iostat=status)
    if (status /= 0 .or. .not. rename_file(path // '.tmp', path)) &
      call raise(err, "cannot write the continuum checkpoint '" // path // "' (&run checkpoint = .false. runs without one)")
  end subroutine write_checkpoint

  !> The checkpoint's sample layout of a job.
  pure type(sample_layout_t) function layout_of(config)
    type(run_config_t), intent(in) :: config
    layout_of = sample_layout_t(config%hydrodynamics%flow, config%continuum%control_offsets > 0)
  end function layout_of

  !> The numbers a sample of this layout adds to the sample_numbers.
  pure integer function extra_numbers(layout)
    type(sample_layout_t), intent(in) :: layout
    extra_numbers = 0
    if (layout%flow) extra_numbers = flow_numbers
    if (layout%controlled) extra_numbers = extra_numbers + control_numbers
    if (layout%flow .and. layout%controlled) extra_numbers = extra_numbers + flow_numbers
  end function extra_numbers

  !> level, offset index, beads, iterations, converged, seconds, residual, d, offset(3),
  !> friction(36), volume, first(3), second(9): 60 numbers; then (layout) the grand resistance
  !> (121), 1 for a full sample and the control friction (37), the control's grand resistance (121).
  pure function pack_sample(p, layout) result(values)
    type(continuum_sample_t), intent(in) :: p
    type(sample_layout_t), intent(in) :: layout
    real(dp), allocatable :: values(:)
    values = [real(p%level, dp), real(p%offset_index, dp), real(p%beads, dp), real(p%iterations, dp), &
              real(p%converged, dp), p%seconds, p%residual, p%bead_diameter, p%offset, reshape(p%friction, [36]), &
              p%moments%packed()]
    if (layout%flow) values = [values, reshape(p%grand, [flow_numbers])]
    if (layout%controlled) values = [values, merge(1.0_dp, 0.0_dp, p%full), reshape(p%control, [36])]
    if (layout%flow .and. layout%controlled) values = [values, reshape(p%control_grand, [flow_numbers])]
  end function pack_sample

  pure function unpack_sample(values, layout) result(p)
    real(dp), intent(in) :: values(:)
    type(sample_layout_t), intent(in) :: layout
    type(continuum_sample_t) :: p
    integer :: next
    p%level = nint(values(1))
    p%offset_index = nint(values(2))
    p%beads = nint(values(3))
    p%iterations = nint(values(4))
    p%converged = nint(values(5))
    p%seconds = values(6)
    p%residual = values(7)
    p%bead_diameter = values(8)
    p%offset = values(9:11)
    p%friction = reshape(values(12:47), [6, 6])
    p%moments = unpacked_moments(values(48:60))
    next = sample_numbers + 1
    if (layout%flow) then
      p%grand = reshape(values(next:next + flow_numbers - 1), shape(p%grand))
      next = next + flow_numbers
    end if
    if (layout%controlled) then
      p%full = values(next) > 0.5_dp
      p%control = reshape(values(next + 1:next + 36), [6, 6])
      next = next + control_numbers
    end if
    if (layout%flow .and. layout%controlled) p%control_grand = reshape(values(next:next + flow_numbers - 1), shape(p%grand))
  end function unpack_sample


end module beadmob_continuum_job
