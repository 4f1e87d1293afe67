!> The settings of a friction job, one type with one set of defaults (job_defaults.f90): what the
!> library computes and how. The input's &hydrodynamics group (input_config.f90) fills its first
!> part, the command line (driver/command_line.F90, one table of options) the second, and the
!> driver the last; the library (solvers/) reads it as it stands.
module beadmob_friction_settings
  use beadmob_kinds, only: dp
  use beadmob_job_defaults, only: default_multipole_order, default_lubrication, default_lubrication_cutoff, &
                                  default_krylov_rtol, default_pfft_stencil, default_pfft_near_radius, &
                                  default_shell_layers, unset_int
  implicit none
  private
  public :: friction_settings_t, automatic_shell_layers

  type :: friction_settings_t
    ! --- The input's &hydrodynamics group (docs/input.md) ---
    !> The group is present: compute the friction and mobility of the model
    logical :: enabled = .false.
    !> Multipole truncation order L (job_defaults.f90 says why each default is what it is)
    integer :: multipole_order = default_multipole_order
    !> Highest degree of the sigma = 2 (potential) multipole family, L2; the input's default is
    !> max(L - 2, 0), which gives the 2L(L+2) unknowns per bead of the paper's L = 2 (theory.md T3)
    integer :: potential_order = max(default_multipole_order - 2, 0)
    !> The pairwise lubrication correction, for pairs with centre distance <= cutoff (d)
    logical :: lubrication = default_lubrication
    real(dp) :: lubrication_cutoff = default_lubrication_cutoff
    !> The body in an ambient linear flow too (theory.md T19): the five strain problems beside the
    !> six motions, their grand resistance and the free body's response per unit strain
    logical :: flow = .false.
    !> Keep the force and torque of every bead for every motion (36 numbers a bead)
    logical :: bead_forces = .false.
    !> HDF5 table cache of the lattice blocks and the lubrication corrections ('' = none, see
    !> table_cache.f90): a cached run gives the same numbers to the last bit. The driver puts the
    !> environment's BEADMOB_CACHE here when the input names none.
    character(len=1024) :: cache_file = ''
    !> Shell model: only the beads within this many layers of the surface (0 = all beads).
    !> unset_int: automatic_shell_layers, resolved by the plan (job_plan.f90), which knows the beads
    integer :: shell_layers = unset_int
    !> Krylov relative tolerance of the solves (-ksp_rtol overrides it)
    real(dp) :: krylov_rtol = default_krylov_rtol
    !> The rigid motions to compute (U_x U_y U_z W_x W_y W_z) as the input names them, and as
    !> switches; friction entries between two left out are NaN
    character(len=64) :: motions_text = 'all'
    logical :: motions(6) = .true.
    !> Derive the motions that symmetries of the bead set give from others instead of solving them
    logical :: use_symmetry = .true.
    !> The error bar: the companion solve of order L - 1 on the same beads (theory.md T14), from
    !> which the driver estimates the truncation error of order L; needs L >= 2 and all six
    !> motions. Off in the library; the driver turns it on up to default_estimate_order and for an
    !> accuracy target when the input does not say (error_estimate_given).
    logical :: error_estimate = .false.
    logical :: error_estimate_given = .false.
    !> Target relative error of the mobility coefficients (0 = none): the cheapest settings the
    !> committed benchmark data say reach it choose L, the shell and the Krylov tolerance
    !> (accuracy_choice.f90)
    real(dp) :: accuracy = 0.0_dp
    !> The input sets multipole_order, potential_order, shell_layers or krylov_rtol itself (then an
    !> accuracy target, which chooses them, is refused)
    logical :: choices_given = .false.

    ! --- The command line (driver/command_line.F90) ---
    !> 'direct', 'fft', 'pfft' or 'auto' (the faster one for the job, job_plan.f90)
    character(len=16) :: operator_name = 'auto'
    !> The precorrected-FFT operator's interpolation points per axis and exact-pair radius (d)
    integer :: pfft_stencil = default_pfft_stencil
    real(dp) :: pfft_near_radius = default_pfft_near_radius
    !> -pfft_near_radius was given: the plan keeps it whatever accuracy the job asks for
    logical :: pfft_near_radius_given = .false.
    !> Rows of the exact far field that measure the pfft operator's error (operator_error.F90;
    !> 0: as many as its budget allows)
    integer :: operator_error_rows = 0
    !> FFTW planner of the FFT operators: 'measure' (faster products, after trial transforms that
    !> cost about fifteen products unless remembered), 'estimate' (bitwise reproducible from run to
    !> run) or 'auto': measure where the plans are remembered (a table cache), else estimate
    !> (bench/side_by_side/fft_planner.md)
    character(len=16) :: fft_planner = 'auto'
    !> The FFT operator's products by mirror class where the bead set has two lattice mirror
    !> planes (fft_operator.F90); false (-fft_whole_box): always on the whole padded box
    logical :: fft_mirror_classes = .true.
    !> Products on the whole operator of every rank, a batch dealt out to the ranks
    !> (replicated_operator.F90): 'yes' or 'no' (job_plan.f90's choose_replication says why not
    !> by default)
    character(len=8) :: replicate_products = 'no'
    !> Solve the motions one KSPSolve after another (KSP's monitors and every Krylov option then
    !> apply) instead of together (lockstep_cg.F90, when the Krylov method is CG)
    logical :: solve_apart = .false.
    !> Motions solved together are deflated by the coarse space of their preconditioned
    !> right-hand sides where their solves can share directions (deflation_space.F90); false
    !> (-solve_undeflated): plain CG
    logical :: deflation = .true.
    !> Pairs within this distance (d) enter the near-field preconditioning matrix; with no pairs
    !> (radius < 1 and no clusters) the preconditioner is the single-bead PCSHELL instead.
    real(dp) :: near_field_radius = 0.0_dp
    !> Pairs within the same cube of this edge (lattice cells) enter it too; 0 = none.
    integer :: near_field_cluster = 0
    !> -accuracy gave the target (it overrides the input's)
    logical :: accuracy_on_command_line = .false.
    !> PETSc's -ksp_rtol is given (it overrides krylov_rtol), and its value
    logical :: krylov_rtol_on_command_line = .false.
    real(dp) :: ksp_rtol_value = 0.0_dp
    !> Test option -stop_after_solves k: stop with an error after the k-th solve has been saved
    !> (0 = never; -1: given but not a number >= 1, an error)
    integer :: stop_after_solves = 0
    !> Rank 0 prints progress lines (phases, solves). Off in the library; the driver: &run
    !> progress and not -quiet.
    logical :: progress = .false.

    ! --- The driver ---
    !> Checkpoint of the solved motions ('' = none; the driver: '<output>.checkpoint.h5'), see
    !> checkpoint_file.f90
    character(len=1024) :: checkpoint_file = ''
    !> The input part of the checkpoint's key: the effective input without the switches that
    !> change no number (input_config.f90, effective_input_text)
    character(len=:), allocatable :: checkpoint_input
    !> The continuum job's control problem on the same beads (docs/theory.md T18, "Control
    !> samples"), > 0: the order L - 1 problem is solved first, from zero, at this Krylov tolerance
    !> (its friction the companion's), and the order-L solves start from its solutions (fewer
    !> iterations). 0: none (an error_estimate companion is solved after order L, from its part).
    real(dp) :: control_rtol = 0.0_dp
  end type friction_settings_t

contains

  !> The shell when nothing chose one: one surface layer for beads on the lattice (on the
  !> Pareto front of every benchmark shape, job_defaults.f90), else the full model (the shell
  !> needs the lattice, and bead forces need every bead).
  pure integer function automatic_shell_layers(on_lattice, bead_forces)
    logical, intent(in) :: on_lattice, bead_forces
    automatic_shell_layers = merge(default_shell_layers, 0, on_lattice .and. .not. bead_forces)
  end function automatic_shell_layers
end module beadmob_friction_settings
