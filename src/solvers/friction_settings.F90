!> The settings of a friction job (what the library computes and how), and the command-line
!> options that set the solver's part of them. The driver fills them from the input
!> (input_config.f90) and the command line; the library's own defaults are here.
module beadmob_friction_settings
#include "petsc/finclude/petscsys.h"
  use petscsys
  use beadmob_kinds, only: dp
  use beadmob_job_defaults, only: default_multipole_order, default_lubrication, default_lubrication_cutoff, &
                                  default_krylov_rtol, default_pfft_stencil, default_pfft_near_radius
  implicit none
  private
  public :: friction_settings_t, operator_option

  type :: friction_settings_t
    integer :: order = default_multipole_order   ! L
    integer :: potential_order = max(default_multipole_order - 2, 0)   ! L2 (docs/theory.md T3)
    logical :: lubrication = default_lubrication
    real(dp) :: lubrication_cutoff = default_lubrication_cutoff   ! pairs with centre distance <= cutoff (d)
    !> 'direct', 'fft', 'pfft' or 'auto' (the faster one for the job, see choose_operator)
    character(len=16) :: operator_name = 'auto'
    !> The precorrected-FFT operator's interpolation points per axis and exact-pair radius (d)
    integer :: pfft_stencil = default_pfft_stencil
    real(dp) :: pfft_near_radius = default_pfft_near_radius
    !> FFTW planner of the FFT operator: 'measure' (faster products) or 'estimate' (bitwise
    !> reproducible from run to run)
    character(len=16) :: fft_planner = 'measure'
    !> Pairs within this distance (d) enter the near-field preconditioning matrix; with no pairs
    !> (radius < 1 and no clusters) the preconditioner is the single-bead PCSHELL instead.
    real(dp) :: near_field_radius = 0.0_dp
    !> Pairs within the same cube of this edge (lattice cells) enter it too; 0 = none.
    integer :: near_field_cluster = 0
    logical :: bead_forces = .false.   ! keep the force and torque of every bead for every motion
    !> Shell model: only the beads within this many layers of the surface (0 = all beads).
    integer :: shell_layers = 0
    !> Krylov relative tolerance of the six solves (-ksp_rtol overrides it)
    real(dp) :: krylov_rtol = default_krylov_rtol
    !> Derive the motions that symmetries of the bead set give from others instead of solving them
    logical :: use_symmetry = .true.
    !> The rigid motions to compute (U_x U_y U_z W_x W_y W_z); friction entries between two left
    !> out are NaN
    logical :: motions(6) = .true.
    !> HDF5 table cache of the lattice blocks and the lubrication corrections ('' = none, see
    !> table_cache.f90): a cached run gives the same numbers to the last bit.
    character(len=1024) :: cache_file = ''
    !> Rank 0 prints progress lines (phases, solves). Off in the library; the driver sets it from
    !> &run progress and -quiet (operator_option).
    logical :: progress = .false.
    !> Checkpoint of the solved motions ('' = none; the driver: '<output>.checkpoint.h5'), see
    !> checkpoint_file.f90
    character(len=1024) :: checkpoint_file = ''
    !> The input part of the checkpoint's key: the effective input without the switches that
    !> change no number (input_config.f90, effective_input_text)
    character(len=:), allocatable :: checkpoint_input
    !> Test option -stop_after_solves k: stop with an error after the k-th solve has been saved
    !> (0 = never; -1: given but not a number >= 1, an error)
    integer :: stop_after_solves = 0
    !> The companion solve of order L - 1 on the same beads (theory.md T14), from which the
    !> driver estimates the truncation error of order L; needs L >= 2 and all six motions. Off in
    !> the library; the driver sets it from &hydrodynamics error_estimate (default on).
    logical :: companion = .false.
  end type friction_settings_t

contains

  !> The PETSc command-line options of the friction job: -operator direct|fft|auto (default
  !> auto), -fft_planner measure|estimate, -near_field_radius R (d), -near_field_cluster C
  !> (lattice cells), -quiet (no progress lines: settings%progress = .false., else .true.; the
  !> driver also asks &run progress), -stop_after_solves K (a test of the checkpoint: stop after
  !> the K-th solve is saved), -geometry_only (skip the friction job) and -accuracy TARGET (its text, read
  !> by the caller, and accuracy_given; rtol_given: whether -ksp_rtol is set too, which would
  !> override the tolerance the target chooses).
  subroutine operator_option(settings, geometry_only, accuracy, accuracy_given, rtol_given)
    type(friction_settings_t), intent(inout) :: settings
    logical, intent(out) :: geometry_only
    character(len=*), intent(out), optional :: accuracy
    logical, intent(out), optional :: accuracy_given, rtol_given
    character(len=16) :: value
    PetscBool :: found
    PetscReal :: radius
    PetscInt :: edge
    PetscErrorCode :: ierr
    PetscCallA(PetscOptionsGetString(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-operator', value, found, ierr))
    if (found) settings%operator_name = value
    PetscCallA(PetscOptionsGetReal(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-near_field_radius', radius, found, ierr))
    if (found) settings%near_field_radius = radius
    PetscCallA(PetscOptionsGetReal(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-pfft_near_radius', radius, found, ierr))
    if (found) settings%pfft_near_radius = radius
    PetscCallA(PetscOptionsGetInt(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-pfft_stencil', edge, found, ierr))
    if (found) settings%pfft_stencil = int(edge)
    PetscCallA(PetscOptionsGetInt(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-near_field_cluster', edge, found, ierr))
    if (found) settings%near_field_cluster = int(edge)
    PetscCallA(PetscOptionsGetString(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-fft_planner', value, found, ierr))
    if (found) settings%fft_planner = value
    PetscCallA(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-quiet', found, ierr))
    settings%progress = .not. found
    PetscCallA(PetscOptionsGetInt(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-stop_after_solves', edge, found, ierr))
    if (found) settings%stop_after_solves = merge(int(edge), -1, edge >= 1)
    PetscCallA(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-geometry_only', found, ierr))
    geometry_only = found
    if (present(accuracy)) then
      accuracy = ''
      PetscCallA(PetscOptionsGetString(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-accuracy', accuracy, found, ierr))
      if (present(accuracy_given)) accuracy_given = found
    end if
    if (present(rtol_given)) then
      PetscCallA(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-ksp_rtol', found, ierr))
      rtol_given = found
    end if
  end subroutine operator_option
end module beadmob_friction_settings
