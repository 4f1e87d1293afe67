!> The defaults of a friction job, declared once: its settings (friction_settings.f90, which the
!> input's &hydrodynamics group and the command line fill) start from these, and the marker of a
!> number left to the program.
module beadmob_job_defaults
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: unset_real, unset_int, is_set
  public :: default_multipole_order, default_lubrication, default_lubrication_cutoff, default_krylov_rtol, &
            default_shell_layers, default_estimate_order, default_pfft_stencil, default_pfft_near_radius

  !> Markers of a number the input leaves to the program (is_set tells them apart).
  real(dp), parameter :: unset_real = -huge(1.0_dp)
  integer, parameter :: unset_int = -huge(1)

  interface is_set
    module procedure is_set_real, is_set_int
  end interface is_set

  !> Multipole truncation order L (L = 1: force and torque per bead, the RPY level; the paper: 2).
  integer, parameter :: default_multipole_order = 2
  !> Off by default: for dense bead bodies the pairwise rigid-doublet correction overcorrects the
  !> friction several-fold, and without it L = 2 reproduces the paper's Table tab_mob_num
  !> (bench/paper_table/paper_table.md, docs/theory.md T9).
  logical, parameter :: default_lubrication = .false.
  !> Pairs of beads with centre distance <= cutoff (units of d) get the lubrication correction.
  real(dp), parameter :: default_lubrication_cutoff = 2.0_dp
  !> Relative tolerance of the Krylov solves. The friction is variational: its error is ~ the
  !> square of this (theory.md T5, bench/accuracy/solver_tolerance.md), far below the L = 2 truncation error.
  real(dp), parameter :: default_krylov_rtol = 1.0e-3_dp
  !> The default shell: one surface layer. On the benchmark (bench/accuracy/accuracy.md) it is on the
  !> Pareto front of every tuning shape, about 20 % cheaper than the full model, and its largest
  !> error against L = 3 (2.7e-3) is that of the full model (2.8e-3): at L = 2 the interior beads
  !> add truncation error (their contacts) and next to nothing to the rigid-body friction.
  integer, parameter :: default_shell_layers = 1
  !> The error bar is on by default up to this order: its companion's cost grows towards the
  !> order-L solve's with L (unknowns per bead (L - 1)/L), 1.2x the run at L = 2 and 3.
  integer, parameter :: default_estimate_order = 4
  !> The precorrected-FFT operator of off-lattice beads (pfft_operator.F90): interpolation points
  !> per axis and the radius (d) within which pairs are exact (bench/offlattice/offlattice.md: error and cost).
  integer, parameter :: default_pfft_stencil = 4
  real(dp), parameter :: default_pfft_near_radius = 3.0_dp
contains

  elemental logical function is_set_real(value)
    real(dp), intent(in) :: value
    is_set_real = value /= unset_real
  end function is_set_real

  elemental logical function is_set_int(value)
    integer, intent(in) :: value
    is_set_int = value /= unset_int
  end function is_set_int
end module beadmob_job_defaults
