!> Preconditioned CG on several systems A x_j = b_j at once (theory.md T6, "All motions
!> at once"). Each system keeps its own Krylov space, so its iterates are those PETSc's KSPCG
!> makes when it solves the systems one at a time: the same recurrences, the preconditioned
!> residual norm ||B r|| and KSPConvergedDefault's test (relative to ||B b||, absolute and
!> divergence tolerances, the iteration limit), the same KSPConvergedReason codes and the same
!> Lanczos tridiagonal for the extreme eigenvalues of B A. What differs is the order of the work:
!> each iteration applies A to the search directions of every system still running in one
!> batched product (multipole_operator_t%apply_many; the FFT operator streams its kernel once for
!> all), and their dot products and norms share one reduction (PETSc's split-phase VecDotBegin /
!> VecDotEnd). PETSc 3.18's KSPMatSolve would solve the columns of a dense right-hand side one
!> KSPSolve after another for KSPCG, with none of this. Given a coarse space (deflation_space.F90)
!> the systems run deflated CG instead: the same test, fewer iterations, other iterates.
module beadmob_lockstep_cg
#include "petsc/finclude/petscksp.h"
  use petscksp
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use beadmob_kinds, only: dp
  use beadmob_lapack, only: dsyev
  use beadmob_multipole_operator, only: multipole_operator_t
  use beadmob_deflation_space, only: deflation_space_t, deflate_start, project_directions
  implicit none
  private
  public :: krylov_limits_t, solve_lockstep, finished_interface, finishing_interface

  !> KSP's tolerances (KSPGetTolerances).
  type :: krylov_limits_t
    real(dp) :: rtol = 1.0e-5_dp, abstol = 1.0e-50_dp, dtol = 1.0e5_dp
    integer :: max_iterations = 10000
  end type krylov_limits_t

  abstract interface
    !> Collective: system j has stopped after `iterations` with `reason` (KSPConvergedReason);
    !> largest, smallest: the extreme eigenvalues of B A from its Lanczos coefficients (0 when it
    !> made no iteration). Setting stop ends the whole solve, the systems still running unfinished.
    subroutine finished_interface(j, iterations, reason, largest, smallest, stop)
      import :: dp
      integer, intent(in) :: j, iterations, reason
      real(dp), intent(in) :: largest, smallest
      logical, intent(inout) :: stop
    end subroutine finished_interface
    !> Collective: the systems js converge in this iteration (their x final), before `finished`
    !> is called for each: what the caller does with all of them (their true residuals, one
    !> batched product) it can do here at once.
    subroutine finishing_interface(js)
      integer, intent(in) :: js(:)
    end subroutine finishing_interface
  end interface

  !> Lanczos coefficients kept per system at most (the eigenvalue estimate then uses the first).
  integer, parameter :: max_lanczos = 100000

contains

  !> Collective. Solves A x_j = b_j (A: op's product, B: the preconditioner pc, which must be SPD)
  !> for every j, from x_j as given when nonzero_guess, else from zero; `finished` is called for
  !> each system as it stops, in the order they stop (several in one iteration: ascending j).
  !> stopped: a call of `finished` asked to stop. `finishing`, if given, is called first with all
  !> the systems that converge in one iteration. With `deflation` (deflation_space.F90) every
  !> system is deflated by its coarse space: the start x + Z E^+ Z^T r, the search directions
  !> A-orthogonal to Z, and the extreme eigenvalues reported those of the Lanczos coefficients and
  !> of the coarse space together.
  subroutine solve_lockstep(op, pc, b, x, nonzero_guess, limits, finished, stopped, deflation, finishing)
    class(multipole_operator_t), intent(inout) :: op
    PC, intent(in) :: pc
    Vec, intent(in) :: b(:), x(:)
    logical, intent(in) :: nonzero_guess
    type(krylov_limits_t), intent(in) :: limits
    procedure(finished_interface) :: finished
    logical, intent(out) :: stopped
    type(deflation_space_t), intent(in), optional :: deflation
    procedure(finishing_interface), optional :: finishing
    Vec :: r(size(b)), z(size(b)), p(size(b)), w(size(b))
    real(dp), dimension(size(b)) :: norm, beta, beta_old, step, curvature, curvature_old, scale, tolerance, norm0
    real(dp), allocatable :: diagonal(:, :), off_diagonal(:, :)
    logical :: running(size(b)), deflating
    integer :: iterations(size(b)), n, j, i
    PetscErrorCode :: ierr

    n = size(b)
    deflating = .false.
    if (present(deflation)) deflating = deflation%size > 0
    stopped = .false.
    allocate (diagonal(min(limits%max_iterations, max_lanczos), n), off_diagonal(min(limits%max_iterations, max_lanczos), n))
    diagonal = 0
    off_diagonal = 0
    do j = 1, n
      PetscCallA(VecDuplicate(b(j), r(j), ierr))
      PetscCallA(VecDuplicate(b(j), z(j), ierr))
      PetscCallA(VecDuplicate(b(j), p(j), ierr))
      PetscCallA(VecDuplicate(b(j), w(j), ierr))
    end do
    running = .true.
    iterations = 0
    ! Defined before their first use (an ordered test of an undefined number traps in Debug).
    beta = 0
    beta_old = 1
    step = 1
    scale = 0
    curvature = 0
    norm = 0
    norm0 = 0

    ! r = b - A x (or b), deflated, z = B r, ||z||; the test's reference ||B b|| (KSPConvergedDefault).
    if (nonzero_guess) then
      call op%apply_many(x, w)
      do j = 1, n
        PetscCallA(VecWAXPY(r(j), -1.0_dp, w(j), b(j), ierr))
      end do
    else
      do j = 1, n
        PetscCallA(VecZeroEntries(x(j), ierr))
        PetscCallA(VecCopy(b(j), r(j), ierr))
      end do
    end if
    if (nonzero_guess .or. deflating) then
      do j = 1, n
        PetscCallA(PCApply(pc, b(j), w(j), ierr))
      end do
      call norms(w, running, norm0)
    end if
    if (deflating) call deflate_start(deflation, x, r)
    do j = 1, n
      PetscCallA(PCApply(pc, r(j), z(j), ierr))
    end do
    call norms(z, running, norm)
    if (.not. (nonzero_guess .or. deflating)) norm0 = norm
    where (norm0 == 0) norm0 = norm   ! a zero right-hand side with a nonzero guess
    tolerance = max(limits%rtol * norm0, limits%abstol)
    call test(0)
    if (.not. stopped) call dots(z, r, running, beta)

    do i = 0, limits%max_iterations - 1
      if (stopped .or. .not. any(running)) exit
      do j = 1, n
        if (.not. running(j)) cycle
        iterations(j) = i + 1
        if (beta(j) == 0) then
          call finish(j, KSP_CONVERGED_ATOL)
        else if (i > 0 .and. beta(j) * beta_old(j) < 0) then
          call finish(j, KSP_DIVERGED_INDEFINITE_PC)
        else if (i == 0) then
          PetscCallA(VecCopy(z(j), p(j), ierr))   ! p = z
          scale(j) = 0
        else
          scale(j) = beta(j) / beta_old(j)
          if (i < max_lanczos) off_diagonal(i + 1, j) = sqrt(abs(scale(j))) / step(j)
          PetscCallA(VecAYPX(p(j), scale(j), z(j), ierr))   ! p = z + scale p
        end if
        if (stopped) exit
      end do
      if (stopped) exit
      if (.not. any(running)) exit
      if (deflating) call project_directions(deflation, z, p, running)   ! one reduction for all
      call op%apply_many(pack(p, running), pack(w, running))   ! w = A p, all at once
      curvature_old = curvature
      call dots(p, w, running, curvature)
      beta_old = beta
      do j = 1, n
        if (.not. running(j)) cycle
        if (curvature(j) == 0 .or. (i > 0 .and. curvature(j) * curvature_old(j) <= 0)) then
          call finish(j, KSP_DIVERGED_INDEFINITE_MAT)
          if (stopped) exit
          cycle
        end if
        step(j) = beta(j) / curvature(j)
        if (i < max_lanczos) diagonal(i + 1, j) = sqrt(abs(scale(j))) * off_diagonal(i + 1, j) + 1 / step(j)
        PetscCallA(VecAXPY(x(j), step(j), p(j), ierr))     ! x += step p
        PetscCallA(VecAXPY(r(j), -step(j), w(j), ierr))    ! r -= step w
        PetscCallA(PCApply(pc, r(j), z(j), ierr))          ! z = B r
      end do
      if (stopped) exit
      call norms(z, running, norm)
      call test(i + 1)
      if (stopped) exit
      call dots(z, r, running, beta)
    end do
    do j = 1, n
      if (stopped) exit
      if (running(j)) then
        iterations(j) = limits%max_iterations
        call finish(j, KSP_DIVERGED_ITS)
      end if
    end do
    do j = 1, n
      PetscCallA(VecDestroy(r(j), ierr))
      PetscCallA(VecDestroy(z(j), ierr))
      PetscCallA(VecDestroy(p(j), ierr))
      PetscCallA(VecDestroy(w(j), ierr))
    end do

  contains

    !> KSPConvergedDefault after `iteration` iterations, for every running system.
    subroutine test(iteration)
      integer, intent(in) :: iteration
      integer :: k
      logical :: converging(n)
      converging = running .and. ieee_is_finite(norm) .and. norm <= tolerance
      if (present(finishing) .and. any(converging)) call finishing(pack([(k, k = 1, n)], converging))
      do k = 1, n
        if (.not. running(k)) cycle
        iterations(k) = iteration
        if (.not. ieee_is_finite(norm(k))) then
          call finish(k, KSP_DIVERGED_NANORINF)
        else if (converging(k)) then
          call finish(k, merge(KSP_CONVERGED_ATOL, KSP_CONVERGED_RTOL, norm(k) < limits%abstol))
        else if (norm(k) >= limits%dtol * norm0(k)) then
          call finish(k, KSP_DIVERGED_DTOL)
        end if
        if (stopped) return
      end do
    end subroutine test

    !> System k stops with reason `why`: its eigenvalue estimate, then the caller's `finished`.
    subroutine finish(k, why)
      integer, intent(in) :: k, why
      real(dp) :: largest, smallest
      running(k) = .false.
      call lanczos_extremes(diagonal(:, k), off_diagonal(:, k), min(iterations(k), max_lanczos), largest, smallest)
      if (deflating) then   ! the coarse space's Ritz values too (deflation_space.F90)
        if (smallest > 0) then
          smallest = min(smallest, deflation%smallest)
        else
          smallest = deflation%smallest
        end if
        largest = max(largest, deflation%largest)
      end if
      call finished(k, iterations(k), why, largest, smallest, stopped)
    end subroutine finish
  end subroutine solve_lockstep

  !> Collective. result(j) = ||v(j)||_2 for the systems in `mask`, one reduction for all.
  subroutine norms(v, mask, result)
    Vec, intent(in) :: v(:)
    logical, intent(in) :: mask(:)
    real(dp), intent(inout) :: result(:)
    integer :: j
    PetscErrorCode :: ierr
    do j = 1, size(v)
      if (mask(j)) then
        PetscCallA(VecNormBegin(v(j), NORM_2, result(j), ierr))
      end if
    end do
    do j = 1, size(v)
      if (mask(j)) then
        PetscCallA(VecNormEnd(v(j), NORM_2, result(j), ierr))
      end if
    end do
  end subroutine norms

  !> Collective. result(j) = u(j) . v(j) for the systems in `mask`, one reduction for all.
  subroutine dots(u, v, mask, result)
    Vec, intent(in) :: u(:), v(:)
    logical, intent(in) :: mask(:)
    real(dp), intent(inout) :: result(:)
    integer :: j
    PetscErrorCode :: ierr
    do j = 1, size(u)
      if (mask(j)) then
        PetscCallA(VecDotBegin(u(j), v(j), result(j), ierr))
      end if
    end do
    do j = 1, size(u)
      if (mask(j)) then
        PetscCallA(VecDotEnd(u(j), v(j), result(j), ierr))
      end if
    end do
  end subroutine dots

  !> The extreme eigenvalues of CG's Lanczos tridiagonal (diagonal(1:m), off_diagonal(2:m)), as
  !> KSPComputeExtremeSingularValues gives them for KSPCG; 0 and 0 for m = 0.
  subroutine lanczos_extremes(diagonal, off_diagonal, m, largest, smallest)
    real(dp), intent(in) :: diagonal(:), off_diagonal(:)
    integer, intent(in) :: m
    real(dp), intent(out) :: largest, smallest
    real(dp), allocatable :: t(:, :), eigenvalues(:), work(:)
    integer :: k, info
    largest = 0
    smallest = 0
    if (m < 1) return
    allocate (t(m, m), eigenvalues(m), work(max(1, 3 * m)))
    t = 0
    do k = 1, m
      t(k, k) = diagonal(k)
      if (k > 1) then
        t(k - 1, k) = off_diagonal(k)
        t(k, k - 1) = off_diagonal(k)
      end if
    end do
    call dsyev('N', 'U', m, t, m, eigenvalues, work, size(work), info)
    if (info /= 0) return
    largest = eigenvalues(m)
    smallest = eigenvalues(1)
  end subroutine lanczos_extremes
end module beadmob_lockstep_cg
