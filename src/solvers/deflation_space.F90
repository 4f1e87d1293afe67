!> A coarse space for the CG solves of the motions: deflation by the preconditioned right-hand
!> sides (theory.md T11, "Deflation by the right-hand sides").
!>
!> The iterations of a rigid-motion solve are spent on the collective modes of the body, the
!> large eigenvalues of B A (T11), and the six right-hand sides of one body excite the same ones.
!> With Z = [B c_1 ... B c_k] (the first Krylov vectors of the systems), E = Z^T A Z and W = A Z,
!> deflated CG (Saad, Yeung, Erhel and Guyomarc'h, SIAM J. Sci. Comput. 21 (2000) 1909) starts
!> from x0 with Z^T (b - A x0) = 0 and keeps every search direction A-orthogonal to Z,
!>   p <- z - Z E^+ W^T z + beta p,
!> so each system iterates on the operator with the coarse space removed; its largest
!> eigenvalue falls (35.9 -> 10.6 on a 306-bead random body, the smallest stays), and each
!> system needs fewer iterations, for one product of A with the k vectors of Z. The test of a
!> system is unchanged (its preconditioned residual against ||B b||).
!>
!> The eigenvalue estimate: the Lanczos coefficients of a deflated solve describe the deflated
!> operator. Its smallest eigenvalue is B A's, its largest is not, so the extremes are also taken
!> from the coarse space itself: the Rayleigh quotients of B A on span Z, from E v = mu G v with
!> G = Z^T B^-1 Z = [c_i . B c_j] (largest 35.1 against 35.9 there). Both are Ritz values of B A,
!> inside its spectrum; a solve that the coarse space alone converges (no iteration, as with an
!> exact preconditioner) has only these.
module beadmob_deflation_space
#include "petsc/finclude/petscksp.h"
  use petscksp
  use beadmob_kinds, only: dp
  use beadmob_lapack, only: dsyev
  use beadmob_multipole_operator, only: multipole_operator_t
  implicit none
  private
  public :: deflation_space_t, make_deflation_space, deflate_start, project_directions, destroy_deflation_space

  type :: deflation_space_t
    integer :: size = 0
    Vec, allocatable :: basis(:)         ! Z
    Vec, allocatable :: image(:)         ! W = A Z
    real(dp), allocatable :: coarse_inverse(:, :)   ! E^+ (the pseudo-inverse of Z^T A Z)
    !> The extreme Rayleigh quotients of B A on span Z
    real(dp) :: smallest = 0.0_dp, largest = 0.0_dp
  end type deflation_space_t

  !> Eigenvalues below this fraction of the largest are dropped from E and G (dependent or zero
  !> right-hand sides).
  real(dp), parameter :: relative_cutoff = 1.0e-12_dp

contains

  !> Collective. Z = B b_j for the j where `chosen` (A: op's product, B: pc), W = A Z in one
  !> batched product, E^+ and the coarse eigenvalue estimate.
  subroutine make_deflation_space(op, pc, b, chosen, space)
    class(multipole_operator_t), intent(inout) :: op
    PC, intent(in) :: pc
    Vec, intent(in) :: b(:)
    logical, intent(in) :: chosen(:)
    type(deflation_space_t), intent(out) :: space
    Vec, allocatable :: sources(:)
    real(dp), allocatable :: coarse(:, :), gram(:, :), row(:)
    integer :: k, n
    PetscErrorCode :: ierr

    n = count(chosen)
    space%size = n
    if (n == 0) return
    sources = pack(b, chosen)
    allocate (space%basis(n), space%image(n), coarse(n, n), gram(n, n), row(n))
    do k = 1, n
      PetscCallA(VecDuplicate(sources(k), space%basis(k), ierr))
      PetscCallA(VecDuplicate(sources(k), space%image(k), ierr))
      PetscCallA(PCApply(pc, sources(k), space%basis(k), ierr))
    end do
    call op%apply_many(space%basis, space%image)
    do k = 1, n
      PetscCallA(VecMDot(space%basis(k), n, space%image, row, ierr))
      coarse(k, :) = row
      PetscCallA(VecMDot(sources(k), n, space%basis, row, ierr))
      gram(k, :) = row
    end do
    coarse = 0.5_dp * (coarse + transpose(coarse))   ! symmetric up to rounding
    gram = 0.5_dp * (gram + transpose(gram))
    space%coarse_inverse = pseudo_inverse(coarse)
    call coarse_extremes(coarse, gram, space%smallest, space%largest)
  end subroutine make_deflation_space

  !> Collective. x <- x + Z E^+ Z^T r and r <- r - W E^+ Z^T r for each system: then Z^T r = 0.
  subroutine deflate_start(space, x, r)
    type(deflation_space_t), intent(in) :: space
    Vec, intent(in) :: x(:), r(:)   ! PETSc handles: the vectors behind them are updated
    real(dp) :: overlap(space%size, size(x))
    integer :: j
    PetscErrorCode :: ierr
    if (space%size == 0) return
    call overlaps(r, [(.true., j=1, size(x))], space%basis, overlap)
    do j = 1, size(x)
      overlap(:, j) = matmul(space%coarse_inverse, overlap(:, j))
      PetscCallA(VecMAXPY(x(j), space%size, overlap(:, j), space%basis, ierr))
      PetscCallA(VecMAXPY(r(j), space%size, -overlap(:, j), space%image, ierr))
    end do
  end subroutine deflate_start

  !> Collective. p(j) <- p(j) - Z E^+ W^T z(j) for the systems in `mask`: the part of the
  !> preconditioned residual z along the coarse space taken out of the search direction
  !> p = z + beta p (p A-orthogonal to Z).
  subroutine project_directions(space, z, p, mask)
    type(deflation_space_t), intent(in) :: space
    Vec, intent(in) :: z(:), p(:)   ! PETSc handles: the vectors behind p are updated
    logical, intent(in) :: mask(:)
    real(dp) :: overlap(space%size, size(z))
    integer :: j
    PetscErrorCode :: ierr
    if (space%size == 0) return
    call overlaps(z, mask, space%image, overlap)
    do j = 1, size(z)
      if (.not. mask(j)) cycle
      overlap(:, j) = -matmul(space%coarse_inverse, overlap(:, j))
      PetscCallA(VecMAXPY(p(j), space%size, overlap(:, j), space%basis, ierr))
    end do
  end subroutine project_directions

  !> Collective. result(:, j) = [v(j) . against(k)]_k for the v(j) in `mask`, one reduction for
  !> all (PETSc's split-phase VecMDotBegin / VecMDotEnd, as lockstep_cg.F90's dots).
  subroutine overlaps(v, mask, against, result)
    Vec, intent(in) :: v(:), against(:)
    logical, intent(in) :: mask(:)
    real(dp), intent(inout), contiguous :: result(:, :)   ! columns stay in place until VecMDotEnd
    integer :: j
    PetscErrorCode :: ierr
    do j = 1, size(v)
      if (mask(j)) then
        PetscCallA(VecMDotBegin(v(j), size(against), against, result(:, j), ierr))
      end if
    end do
    do j = 1, size(v)
      if (mask(j)) then
        PetscCallA(VecMDotEnd(v(j), size(against), against, result(:, j), ierr))
      end if
    end do
  end subroutine overlaps

  subroutine destroy_deflation_space(space)
    type(deflation_space_t), intent(inout) :: space
    integer :: k
    PetscErrorCode :: ierr
    do k = 1, space%size
      PetscCallA(VecDestroy(space%basis(k), ierr))
      PetscCallA(VecDestroy(space%image(k), ierr))
    end do
    space%size = 0
  end subroutine destroy_deflation_space

  !> The pseudo-inverse of a symmetric positive semi-definite matrix (eigenvalues below the
  !> cutoff dropped).
  function pseudo_inverse(matrix) result(inverse)
    real(dp), intent(in) :: matrix(:, :)
    real(dp) :: inverse(size(matrix, 1), size(matrix, 1))
    real(dp) :: vectors(size(matrix, 1), size(matrix, 1)), values(size(matrix, 1))
    integer :: k
    call eigen(matrix, vectors, values)
    inverse = 0
    do k = 1, size(values)
      if (values(k) > relative_cutoff * maxval(values)) &
        inverse = inverse + spread(vectors(:, k), 2, size(values)) * spread(vectors(:, k), 1, size(values)) / values(k)
    end do
  end function pseudo_inverse

  !> The extreme mu of coarse v = mu gram v on the range of gram (gram positive semi-definite;
  !> 0 and 0 when it is zero).
  subroutine coarse_extremes(coarse, gram, smallest, largest)
    real(dp), intent(in) :: coarse(:, :), gram(:, :)
    real(dp), intent(out) :: smallest, largest
    real(dp) :: vectors(size(gram, 1), size(gram, 1)), values(size(gram, 1))
    real(dp), allocatable :: half(:, :), reduced(:, :), reduced_vectors(:, :), reduced_values(:), kept_values(:)
    logical :: kept(size(gram, 1))
    integer :: k, m
    smallest = 0
    largest = 0
    call eigen(gram, vectors, values)
    kept = values > relative_cutoff * maxval(values)
    m = count(kept)
    if (m == 0) return
    kept_values = pack(values, kept)
    half = vectors(:, pack([(k, k=1, size(values))], kept))
    do k = 1, m   ! columns scaled by g^-1/2: the reduced problem is a plain one
      half(:, k) = half(:, k) / sqrt(kept_values(k))
    end do
    reduced = matmul(transpose(half), matmul(coarse, half))
    allocate (reduced_vectors(m, m), reduced_values(m))
    call eigen(0.5_dp * (reduced + transpose(reduced)), reduced_vectors, reduced_values)
    smallest = minval(reduced_values)
    largest = maxval(reduced_values)
  end subroutine coarse_extremes

  !> Eigenvalues (ascending) and eigenvectors of a symmetric matrix (LAPACK dsyev).
  subroutine eigen(matrix, vectors, values)
    real(dp), intent(in) :: matrix(:, :)
    real(dp), intent(out) :: vectors(:, :), values(:)
    real(dp) :: work(max(1, 3 * size(matrix, 1)) + 64)
    integer :: n, info
    n = size(matrix, 1)
    vectors = matrix
    call dsyev('V', 'U', n, vectors, n, values, work, size(work), info)
    if (info /= 0) values = 0
  end subroutine eigen
end module beadmob_deflation_space
