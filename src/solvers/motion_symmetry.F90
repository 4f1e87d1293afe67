!> Symmetries of the bead set that save Krylov solves. If a lattice symmetry Q (one of the 48
!> signed axis permutations, about the reference point) maps the bead set onto itself, it maps
!> Stokes solutions to Stokes solutions: the multipoles of unit motion j = s Q(motion i) are
!> q_j = s S_Q q_i, where S_Q moves bead b to its image pi(b) and turns its multipoles by D_Q
!> (lattice_symmetry.f90). A rigid motion (U, W) turns into (Q U, det(Q) Q W) (W is a
!> pseudo-vector). So only one motion per orbit of the six unit motions under the symmetry group
!> is solved: 2 of 6 for a sphere or cube, 4 for a body with a four-fold axis, 6 for a body with
!> mirror planes only (a mirror maps each motion to +-itself).
!> The strains of a linear flow (theory.md T19) turn as tensors: E_k into Q E_k Q^T = sum_l D_lk E_l
!> (D = strain_rotation(Q), no det), so q_m = (S_Q q_k - sum_{l /= m} D_lk q_l) / D_mk once the q_l it
!> needs are known: the off-diagonal strains (xy, xz, yz) go into one another as the axes do, and
!> E_5 follows from E_4 where a symmetry moves the z axis (a sphere: 2 of 5 solved; a four-fold axis
!> z: 4; mirror planes only: 5).
!> The group is found from the bead set, never assumed: every symmetry is checked bead by bead
!> (once, by the job's plan), and every derived solution gets the same true-residual check as a
!> solved one.
module beadmob_motion_symmetry
#include "petsc/finclude/petscvec.h"
  use petscvec
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_spatial_index, only: spatial_index_t, build_spatial_index, beads_within
  use beadmob_lattice_symmetry, only: n_symmetries, symmetry_matrix, basis_transforms
  use beadmob_multipole_basis, only: multipole_basis_t
  use beadmob_linear_flow, only: n_strain_modes, strain_rotation
  implicit none
  private
  public :: motion_symmetry_t, find_symmetry_group, find_motion_symmetry, derive_solution, destroy_motion_symmetry, &
            symmetry_tolerance, solves_needed, n_symmetries, strain_sources, derive_strain_solution

  !> An entry of D(Q) below this is zero (its entries are 0, +-1/2, +-sqrt(3)/2, +-1 up to rounding).
  real(dp), parameter :: strain_entry_tolerance = 1.0e-9_dp

  !> Bead images must land on a bead within this distance (d).
  real(dp), parameter :: symmetry_tolerance = 1.0e-6_dp

  type :: motion_symmetry_t
    !> Symmetries of the bead set about the reference point (1: the identity only)
    integer :: group_order = 1
    !> Per unit motion: 0 = solved, else the solved motion it is derived from, with the sign and
    !> the symmetry index (1..48) of motion = sign * Q(source motion)
    integer :: source(6) = 0, sign(6) = 1, symmetry(6) = 0
    !> coupled(m, n): no symmetry of the group keeps motions m and n each with a different sign,
    !> so their Krylov spaces can share directions (deflation_space.F90)
    logical :: coupled(6, 6) = .true.
    !> D_Q of each derived motion's symmetry (nb, nb, 6), and the bead permutation as a scatter
    real(dp), allocatable :: transform(:, :, :)
    VecScatter :: permute(6)
    !> Per strain (with_strains): 0 = solved, else the strain k it is derived from by the symmetry
    !> strain_symmetry(m); strain_weights(:, m) = column k of D(Q), so that
    !> q_m = (S_Q q_k - sum_{l /= m} strain_weights(l, m) q_l) / strain_weights(m, m)
    integer :: strain_source(n_strain_modes) = 0, strain_symmetry(n_strain_modes) = 0
    real(dp) :: strain_weights(n_strain_modes, n_strain_modes) = 0.0_dp
    real(dp), allocatable :: strain_transform(:, :, :)
    VecScatter :: strain_permute(n_strain_modes)
  end type motion_symmetry_t

contains

  !> Collective. The lattice symmetries (of the n_symmetries signed axis permutations) that map
  !> the bead set `centres` onto itself about reference_point: in_group(s). Each rank checks its
  !> share of the beads; a symmetry is in the group when it holds on every rank.
  subroutine find_symmetry_group(comm, centres, reference_point, in_group, err)
    MPI_Comm, intent(in) :: comm
    real(dp), intent(in) :: centres(:, :), reference_point(3)
    logical, intent(out) :: in_group(n_symmetries)
    type(error_t), intent(inout) :: err
    type(spatial_index_t) :: index
    integer :: s, rank, n_ranks
    integer(i8) :: b, n, first, last, n_found
    integer(i8), allocatable :: found(:)
    PetscErrorCode :: ierr
    in_group = .false.
    call build_spatial_index(centres, index, err)
    if (err%failed) return
    call MPI_Comm_rank(comm, rank, ierr)
    call MPI_Comm_size(comm, n_ranks, ierr)
    n = size(centres, 2, kind=i8)
    first = 1 + (n * rank) / n_ranks
    last = (n * (rank + 1)) / n_ranks
    in_group = .true.
    do s = 1, n_symmetries
      do b = first, last
        call beads_within(index, centres, reference_point + matmul(real(symmetry_matrix(s), dp), &
                                                                   centres(:, b) - reference_point), &
                          symmetry_tolerance, found, n_found)
        if (n_found /= 1) then
          in_group(s) = .false.
          exit
        end if
      end do
    end do
    call MPI_Allreduce(MPI_IN_PLACE, in_group, n_symmetries, MPI_LOGICAL, MPI_LAND, comm, ierr)
  end subroutine find_symmetry_group

  !> Collective. The motions that the symmetry group `in_group` of `centres` (find_symmetry_group,
  !> about reference_point) gives for free, and how: the operator's basis transforms and the bead
  !> permutations of the symmetries used. `template` is a vector of the operator's layout (nb rows
  !> per bead, this rank's beads first..first+n_local-1).
  subroutine find_motion_symmetry(comm, basis, centres, reference_point, in_group, first, n_local, template, symmetry, &
                                  err, with_strains)
    MPI_Comm, intent(in) :: comm
    type(multipole_basis_t), intent(in) :: basis
    real(dp), intent(in) :: centres(:, :), reference_point(3)
    logical, intent(in) :: in_group(n_symmetries)
    integer(i8), intent(in) :: first, n_local
    Vec, intent(in) :: template
    type(motion_symmetry_t), intent(out) :: symmetry
    type(error_t), intent(inout) :: err
    logical, intent(in), optional :: with_strains   ! also the strains' sources (default: no)
    type(spatial_index_t) :: index
    integer(i8), allocatable :: image(:)
    real(dp), allocatable :: all_transforms(:, :, :)
    integer :: motion, m
    PetscErrorCode :: ierr

    symmetry%group_order = count(in_group)
    call orbit_sources(in_group, symmetry%source, symmetry%sign, symmetry%symmetry)
    symmetry%coupled = coupled_motions(in_group)
    if (present(with_strains)) then
      if (with_strains) call strain_sources(in_group, symmetry%strain_source, symmetry%strain_symmetry, &
                                            symmetry%strain_weights)
    end if
    if (all(symmetry%source == 0) .and. all(symmetry%strain_source == 0)) return

    call build_spatial_index(centres, index, err)
    if (err%failed) return
    ! Each rank keeps the images of its own beads only (O(N/P) memory per rank).
    allocate (image(first:first + n_local - 1))
    allocate (all_transforms(basis%size, basis%size, n_symmetries), symmetry%transform(basis%size, basis%size, 6), &
              symmetry%strain_transform(basis%size, basis%size, n_strain_modes))
    call basis_transforms(basis, all_transforms)
    do motion = 1, 6
      if (symmetry%source(motion) == 0) cycle
      symmetry%transform(:, :, motion) = all_transforms(:, :, symmetry%symmetry(motion))
      if (.not. permutation_made(symmetry%symmetry(motion), symmetry%permute(motion))) then
        symmetry%source(motion:) = 0
        symmetry%strain_source = 0
        return
      end if
    end do
    do m = 1, n_strain_modes
      if (symmetry%strain_source(m) == 0) cycle
      symmetry%strain_transform(:, :, m) = all_transforms(:, :, symmetry%strain_symmetry(m))
      if (.not. permutation_made(symmetry%strain_symmetry(m), symmetry%strain_permute(m))) then
        symmetry%strain_source(m:) = 0
        return
      end if
    end do

  contains

    !> The bead permutation of symmetry s as a scatter; .false. (err raised, the same on every
    !> rank) when s does not map the beads onto themselves: not these beads' group, a caller's error.
    logical function permutation_made(s, scatter)
      integer, intent(in) :: s
      VecScatter, intent(out) :: scatter
      permutation_made = maps_onto_itself(symmetry_matrix(s), image)
      call MPI_Allreduce(MPI_IN_PLACE, permutation_made, 1, MPI_LOGICAL, MPI_LAND, comm, ierr)
      if (permutation_made) then
        call make_permutation(image, scatter)
      else
        call raise(err, 'internal: a symmetry of the plan does not map the beads of the solve onto themselves')
      end if
    end function permutation_made

    !> True if Q maps every bead of this rank onto a bead; image_of(b) = that bead.
    logical function maps_onto_itself(q, image_of)
      integer, intent(in) :: q(3, 3)
      integer(i8), intent(out) :: image_of(first:)
      integer(i8), allocatable :: found(:)
      integer(i8) :: b, n_found
      maps_onto_itself = .false.
      do b = first, first + n_local - 1
        call beads_within(index, centres, reference_point + matmul(real(q, dp), centres(:, b) - reference_point), &
                          symmetry_tolerance, found, n_found)
        if (n_found /= 1) return
        image_of(b) = found(1)
      end do
      maps_onto_itself = .true.
    end function maps_onto_itself

    !> The scatter from bead b's rows to bead image(b)'s rows (this rank's beads).
    subroutine make_permutation(image_of, scatter)
      integer(i8), intent(in) :: image_of(:)
      VecScatter, intent(out) :: scatter
      IS :: from, to
      PetscInt, allocatable :: blocks(:)
      PetscInt :: n, first_block
      n = int(n_local)
      first_block = int(first - 1)
      allocate (blocks(size(image_of)))
      blocks = int(image_of - 1)
      PetscCallA(ISCreateStride(comm, n * basis%size, first_block * basis%size, 1, from, ierr))
      PetscCallA(ISCreateBlock(comm, basis%size, n, blocks, PETSC_COPY_VALUES, to, ierr))
      PetscCallA(VecScatterCreate(template, from, template, to, scatter, ierr))
      PetscCallA(ISDestroy(from, ierr))
      PetscCallA(ISDestroy(to, ierr))
    end subroutine make_permutation
  end subroutine find_motion_symmetry

  !> One solved motion per orbit of the group (in_group): the first of it; the others derived from
  !> it, source(m) = the solved motion, motion m = sign(m) Q_symmetry(m) (source(m)).
  pure subroutine orbit_sources(in_group, source, sign, symmetry)
    logical, intent(in) :: in_group(n_symmetries)
    integer, intent(out) :: source(6), sign(6), symmetry(6)
    integer :: motion, s, target, image_sign
    source = 0
    sign = 1
    symmetry = 0
    do motion = 1, 6
      if (source(motion) /= 0) cycle
      do s = 1, n_symmetries
        if (.not. in_group(s)) cycle
        call image_motion(symmetry_matrix(s), motion, target, image_sign)
        if (target > motion .and. source(target) == 0) then
          source(target) = motion
          sign(target) = image_sign
          symmetry(target) = s
        end if
      end do
    end do
  end subroutine orbit_sources

  !> The strains the group in_group gives: mode m (in order) is derived when some symmetry Q of
  !> the group turns an earlier mode k into a combination of m and earlier modes only,
  !> Q E_k Q^T = sum_l D_lk E_l with D_mk /= 0 (source(m) = k, symmetry(m) = Q's index, weights(:, m)
  !> = D(:, k)); else it is solved. Earlier modes are known (solved or derived) when m is derived.
  pure subroutine strain_sources(in_group, source, symmetry, weights)
    logical, intent(in) :: in_group(n_symmetries)
    integer, intent(out) :: source(n_strain_modes), symmetry(n_strain_modes)
    real(dp), intent(out) :: weights(n_strain_modes, n_strain_modes)
    real(dp) :: d(n_strain_modes, n_strain_modes)
    logical :: used(n_strain_modes)
    integer :: m, k, s
    source = 0
    symmetry = 0
    weights = 0.0_dp
    modes: do m = 2, n_strain_modes
      do s = 1, n_symmetries
        if (.not. in_group(s)) cycle
        d = strain_rotation(real(symmetry_matrix(s), dp))
        do k = 1, m - 1
          used = abs(d(:, k)) > strain_entry_tolerance
          if (used(m) .and. .not. any(used(m + 1:))) then
            source(m) = k
            symmetry(m) = s
            weights(:, m) = merge(d(:, k), 0.0_dp, used)
            cycle modes
          end if
        end do
      end do
    end do modes
  end subroutine strain_sources

  !> Collective. Strain m derived (symmetry%strain_source(m) > 0) from the strains' solutions
  !> `solutions` (those it needs already there): q_m = (S_Q q_k - sum_{l /= m} w_l q_l) / w_m.
  subroutine derive_strain_solution(symmetry, m, solutions)
    type(motion_symmetry_t), intent(in) :: symmetry
    integer, intent(in) :: m
    Vec, intent(in) :: solutions(n_strain_modes)   ! PETSc handles: solutions(m) is written
    PetscErrorCode :: ierr
    integer :: l
    associate (w => symmetry%strain_weights(:, m))
    call turn_solution(symmetry%strain_transform(:, :, m), symmetry%strain_permute(m), &
                       solutions(symmetry%strain_source(m)), solutions(m))
    do l = 1, n_strain_modes
      if (l == m .or. w(l) == 0.0_dp) cycle
      PetscCallA(VecAXPY(solutions(m), -w(l), solutions(l), ierr))
    end do
    PetscCallA(VecScale(solutions(m), 1.0_dp / w(m), ierr))
    end associate
  end subroutine derive_strain_solution

  !> coupled(m, n) unless a symmetry of the group maps motion m to sign_m m and n to sign_n n with
  !> sign_m /= sign_n: then A (which commutes with the symmetry) never mixes their solves, the
  !> right-hand side and every Krylov vector of one being even and of the other odd under it.
  pure function coupled_motions(in_group) result(coupled)
    logical, intent(in) :: in_group(n_symmetries)
    logical :: coupled(6, 6)
    integer :: s, m, n, target(6), sign(6)
    coupled = .true.
    do s = 1, n_symmetries
      if (.not. in_group(s)) cycle
      do m = 1, 6
        call image_motion(symmetry_matrix(s), m, target(m), sign(m))
      end do
      do m = 1, 6
        do n = 1, 6
          if (target(m) == m .and. target(n) == n .and. sign(m) /= sign(n)) coupled(m, n) = .false.
        end do
      end do
    end do
  end function coupled_motions

  !> The Krylov solves the `requested` motions need when the motions that the symmetry group
  !> in_group gives are derived (as solve_motions does: a requested derived motion needs its
  !> source; a source left out makes its derived motions solved): the plan's count.
  pure integer function solves_needed(in_group, requested)
    logical, intent(in) :: in_group(n_symmetries), requested(6)
    logical :: computed(6)
    integer :: source(6), sign(6), symmetry(6), motion
    call orbit_sources(in_group, source, sign, symmetry)
    computed = requested
    do motion = 1, 6
      if (requested(motion) .and. source(motion) > 0) computed(source(motion)) = .true.
    end do
    do motion = 1, 6
      if (source(motion) > 0) then
        if (.not. computed(source(motion))) source(motion) = 0
      end if
    end do
    solves_needed = count(computed .and. source == 0)
  end function solves_needed

  !> Unit motion `motion` (1..3 translations, 4..6 rotations) turned by Q is sign * unit motion
  !> `target`: translations turn as vectors, rotations as pseudo-vectors (det Q).
  pure subroutine image_motion(q, motion, target, sign)
    integer, intent(in) :: q(3, 3), motion
    integer, intent(out) :: target, sign
    integer :: axis, row, det
    axis = motion - 3 * ((motion - 1) / 3)
    do row = 1, 3
      if (q(row, axis) /= 0) exit
    end do
    det = q(1, 1) * (q(2, 2) * q(3, 3) - q(2, 3) * q(3, 2)) - q(1, 2) * (q(2, 1) * q(3, 3) - q(2, 3) * q(3, 1)) + &
          q(1, 3) * (q(2, 1) * q(3, 2) - q(2, 2) * q(3, 1))
    sign = q(row, axis)
    target = row
    if (motion > 3) then
      sign = sign * det
      target = row + 3
    end if
  end subroutine image_motion

  !> Collective. derived = sign S_Q source for a derived motion (symmetry%source(motion) > 0).
  subroutine derive_solution(symmetry, motion, source, derived)
    type(motion_symmetry_t), intent(in) :: symmetry
    integer, intent(in) :: motion
    Vec, intent(in) :: source
    Vec, intent(inout) :: derived
    PetscErrorCode :: ierr
    call turn_solution(symmetry%transform(:, :, motion), symmetry%permute(motion), source, derived)
    PetscCallA(VecScale(derived, real(symmetry%sign(motion), dp), ierr))
  end subroutine derive_solution

  !> Collective. turned = S_Q source: each bead's multipoles turned by D_Q (`transform`), then moved
  !> to its image bead (`permute`, the scatter of find_motion_symmetry).
  subroutine turn_solution(transform, permute, source, turned)
    real(dp), intent(in) :: transform(:, :)
    VecScatter, intent(in) :: permute
    Vec, intent(in) :: source
    Vec, intent(in) :: turned   ! a PETSc handle: the vector behind it is written
    Vec :: by_bead
    PetscScalar, pointer :: values(:)
    PetscErrorCode :: ierr
    integer :: nb, i
    nb = size(transform, 1)
    PetscCallA(VecDuplicate(source, by_bead, ierr))
    PetscCallA(VecCopy(source, by_bead, ierr))
    PetscCallA(VecGetArrayF90(by_bead, values, ierr))
    do i = 1, size(values) / nb
      values(nb * (i - 1) + 1:nb * i) = matmul(transform, values(nb * (i - 1) + 1:nb * i))
    end do
    PetscCallA(VecRestoreArrayF90(by_bead, values, ierr))
    PetscCallA(VecScatterBegin(permute, by_bead, turned, INSERT_VALUES, SCATTER_FORWARD, ierr))
    PetscCallA(VecScatterEnd(permute, by_bead, turned, INSERT_VALUES, SCATTER_FORWARD, ierr))
    PetscCallA(VecDestroy(by_bead, ierr))
  end subroutine turn_solution

  subroutine destroy_motion_symmetry(symmetry)
    type(motion_symmetry_t), intent(inout) :: symmetry
    PetscErrorCode :: ierr
    integer :: motion
    do motion = 1, 6
      if (symmetry%source(motion) == 0) cycle
      PetscCallA(VecScatterDestroy(symmetry%permute(motion), ierr))
    end do
    do motion = 1, n_strain_modes
      if (symmetry%strain_source(motion) == 0) cycle
      PetscCallA(VecScatterDestroy(symmetry%strain_permute(motion), ierr))
    end do
    symmetry%source = 0
    symmetry%strain_source = 0
  end subroutine destroy_motion_symmetry
end module beadmob_motion_symmetry
