!> Numerical health of a 6x6 friction matrix zeta (rows F, T; columns U, Omega): every entry
!> finite, symmetric (the Galerkin friction is, theory.md T5-T6), positive definite (the
!> dissipation U.zeta.U > 0 of any rigid motion, Happel & Brenner 1965, sec. 5-2) and not
!> ill-conditioned. Written to the result file and warned about on stderr (docs/stress_tests.md).
!> The condition number uses the units of the run (eta = 1, lengths in d, reference point the
!> centre of mass): translation and rotation blocks scale differently, so elongated bodies have
!> a large but physical condition number (1.8e5 for a chain of 1000 beads, growing as N^2).
module beadmob_friction_diagnostics
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use beadmob_kinds, only: dp
  use beadmob_lapack, only: dsyev
  implicit none
  private
  public :: friction_diagnostics_t, diagnose_friction, friction_warning, condition_threshold, asymmetry_threshold

  !> Above this 2-norm condition number the friction is flagged: its inverse, the mobility,
  !> then carries relative errors of 1e12 * 1e-16 = 1e-4 from rounding alone.
  real(dp), parameter :: condition_threshold = 1.0e12_dp
  !> Above this ||zeta - zeta^T||_F / ||zeta||_F the friction is flagged as asymmetric: the
  !> variational friction is symmetric to rounding (measured <= 1e-15), whatever the solver error.
  real(dp), parameter :: asymmetry_threshold = 1.0e-8_dp

  type :: friction_diagnostics_t
    logical :: finite = .false.              ! every entry finite (nothing else computed otherwise)
    !> Eigenvalues of the symmetric part (zeta + zeta^T) / 2, ascending.
    real(dp) :: eigenvalues(6) = 0.0_dp
    !> max |lambda| / min |lambda| of the symmetric part; huge(1.0_dp) when singular or not finite.
    real(dp) :: condition_number = huge(1.0_dp)
    real(dp) :: asymmetry = 0.0_dp           ! ||zeta - zeta^T||_F / ||zeta||_F (0 for zeta = 0)
    logical :: positive_definite = .false.   ! smallest eigenvalue of the symmetric part > 0
    logical :: symmetric = .false.           ! asymmetry <= asymmetry_threshold
    logical :: well_conditioned = .false.    ! condition_number <= condition_threshold
  end type friction_diagnostics_t

contains

  !> Local and deterministic: every rank holds the same replicated friction, so every rank gets
  !> the same diagnostics.
  function diagnose_friction(friction) result(diag)
    real(dp), intent(in) :: friction(6, 6)
    type(friction_diagnostics_t) :: diag
    real(dp) :: symmetric_part(6, 6), work(64), scale, smallest
    integer :: info

    ! Checked first: LAPACK and the norms below would turn a NaN into traps or garbage.
    diag%finite = all(ieee_is_finite(friction))
    if (.not. diag%finite) return

    scale = norm2(friction)
    if (scale > 0.0_dp) diag%asymmetry = norm2(friction - transpose(friction)) / scale
    diag%symmetric = diag%asymmetry <= asymmetry_threshold

    symmetric_part = 0.5_dp * (friction + transpose(friction))
    call dsyev('N', 'U', 6, symmetric_part, 6, diag%eigenvalues, work, size(work), info)
    if (info /= 0) then   ! no convergence of the QR iteration: report as unknown, i.e. flagged
      diag%eigenvalues = 0.0_dp
      return
    end if
    diag%positive_definite = diag%eigenvalues(1) > 0.0_dp
    smallest = minval(abs(diag%eigenvalues))
    if (smallest > 0.0_dp) diag%condition_number = maxval(abs(diag%eigenvalues)) / smallest
    diag%well_conditioned = diag%condition_number <= condition_threshold
  end function diagnose_friction

  !> '' when the friction is healthy, else one line naming every problem of `what` (e.g.
  !> 'the friction matrix'), for 'beadmob: warning: ' on stderr.
  function friction_warning(diag, what) result(text)
    type(friction_diagnostics_t), intent(in) :: diag
    character(len=*), intent(in) :: what
    character(len=:), allocatable :: text
    character(len=16) :: number
    text = ''
    if (.not. diag%finite) then
      text = what // ' has non-finite entries (the mobility is undefined)'
      return
    end if
    if (.not. diag%positive_definite) then
      write (number, '(es10.3)') diag%eigenvalues(1)
      call append('is not positive definite (smallest eigenvalue ' // trim(adjustl(number)) // ')')
    end if
    if (.not. diag%well_conditioned) then
      write (number, '(es10.3)') diag%condition_number
      call append('is ill-conditioned (condition number ' // trim(adjustl(number)) // ' > 1e12)')
    end if
    if (.not. diag%symmetric) then
      write (number, '(es10.3)') diag%asymmetry
      call append('is not symmetric (relative asymmetry ' // trim(adjustl(number)) // ' > 1e-8)')
    end if

  contains

    subroutine append(problem)
      character(len=*), intent(in) :: problem
      if (len(text) == 0) then
        text = what // ' ' // problem
      else
        text = text // ' and ' // problem
      end if
    end subroutine append
  end function friction_warning
end module beadmob_friction_diagnostics
