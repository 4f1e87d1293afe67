!> The mirror-parity classes of the FFT operator's fields (theory.md T4, "Mirror classes"). A
!> bead set symmetric under the mirrors M_f, M_m of the fast and the middle FFT axis splits
!> every field x into four classes c = (s_f, s_m), P_c x = x on the class where
!>   x_i(M_a r) = s_a D_a(i) x_i(r)   (D_a: the mirror's sign of unknown i, find_mirror_signs),
!> and the operator maps each class to itself (A commutes with the mirrors). A class is fixed by
!> its values on the fundamental beads (l_a >= the centre along both axes); its product runs on
!> the mirror transform (mirror_transform.f90) of those sites only.
!>
!> Here, per bead: which side of each mirror it lies on and how many beads share its fundamental
!> site; the fold x -> the data planes of class c, (P_c x) on the fundamental sites, as one
!> scatter-add of x times a sign and 1 / (beads sharing the site); the unfold, every bead's value
!> from its fundamental site times the same sign; and the test which class a vector is in
!> (the solves' right-hand sides and iterates are each in one class: then one class product
!> instead of four), by the mirror images of the vector.
module beadmob_mirror_classes
#include "petsc/finclude/petscvec.h"
  use petscvec
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_mirror_transform, only: mirror_transform_t, n_classes, class_signs, fundamental_site
  implicit none
  private
  public :: mirror_classes_t, make_mirror_classes, destroy_mirror_classes, classes_of, fold_class, &
            unfold_class

  type :: mirror_classes_t
    integer :: nb = 0
    integer(i8) :: n_local = 0
    MPI_Comm :: comm
    integer, allocatable :: side(:)              ! local bead: bit 0 beyond the fast mirror, bit 1 the middle
    real(dp), allocatable :: weight(:)           ! local bead: 1 / beads sharing its fundamental site
    real(dp), allocatable :: field_sign(:, :)    ! (unknown, 1:2): D_f, D_m
    VecScatter :: fold                           ! bead vector -> data planes (fundamental sites)
    VecScatter :: image(2)                       ! bead vector -> each bead's mirror image's values
    Vec :: work
    logical :: created = .false.
  end type mirror_classes_t

  !> A vector within this of one class (relative, in the 2-norm) is taken as that class: the
  !> part of the other classes dropped is far below any solver tolerance.
  real(dp), parameter :: class_tolerance = 1.0e-12_dp

contains

  !> Collective. The classes of the beads first_bead .. first_bead + n_local - 1 of `lattice`
  !> (FFT axis a is lattice axis axes(a)), nb unknowns per bead in slots `slot`, whose mirror
  !> signs are field_sign(slot, 1:2); `slab` is the PETSc vector of the data planes of t.
  subroutine make_mirror_classes(comm, lattice, axes, first_bead, n_local, slot, field_sign, t, slab, mc, err)
    MPI_Comm, intent(in) :: comm
    integer, intent(in) :: lattice(:, :), axes(3), slot(:)
    integer(i8), intent(in) :: first_bead, n_local
    real(dp), intent(in) :: field_sign(:, :)
    type(mirror_transform_t), intent(in) :: t
    Vec, intent(in) :: slab
    type(mirror_classes_t), intent(inout) :: mc
    type(error_t), intent(inout) :: err
    PetscErrorCode :: ierr
    PetscInt :: vector_start, vector_end, first_row
    PetscInt, allocatable :: sites(:), rows(:), images(:)
    integer, allocatable :: bead_at(:, :, :)
    integer(i8), allocatable :: all_info(:, :)
    integer(i8) :: info(3), i, bead, site
    integer :: nb, a, k, l(3), j(2), owner, n_ranks, axis, image(3), side, failed
    IS :: from, to
    Vec :: template

    nb = size(slot)
    mc%nb = nb
    mc%comm = comm
    mc%n_local = n_local
    allocate (mc%side(n_local), mc%weight(n_local), mc%field_sign(nb, 2))
    do a = 1, nb
      mc%field_sign(a, :) = field_sign(slot(a), :)   ! by unknown
    end do
    call MPI_Comm_size(comm, n_ranks, ierr)
    PetscCallA(VecGetOwnershipRange(slab, vector_start, vector_end, ierr))
    info = [int(vector_start, i8), int(t%first_plane, i8), int(t%planes, i8)]
    allocate (all_info(3, 0:n_ranks - 1))
    call MPI_Allgather(info, 3, MPI_INTEGER8, all_info, 3, MPI_INTEGER8, comm, ierr)
    ! Every bead by its lattice site (for the mirror images).
    allocate (bead_at(0:t%data(1) - 1, 0:t%data(2) - 1, 0:t%data(3) - 1))
    bead_at = 0
    do bead = 1, size(lattice, 2)
      l = lattice(axes, bead)
      bead_at(l(1), l(2), l(3)) = int(bead)
    end do

    allocate (sites(n_local * nb), rows(n_local * nb), images(n_local * nb * 2))
    first_row = int((first_bead - 1) * nb)
    do i = 1, n_local
      bead = first_bead + i - 1
      l = lattice(axes, bead)   ! fast, middle, slow
      side = 0
      mc%weight(i) = 1.0_dp
      do axis = 1, 2
        call fundamental_site(l(axis), t%data(axis), j(axis), k)
        if (k > 0) side = side + axis   ! bit axis - 1
        if (k >= 0) mc%weight(i) = mc%weight(i) / 2
      end do
      mc%side(i) = side
      owner = -1
      do a = 0, n_ranks - 1
        if (l(3) >= all_info(2, a) .and. l(3) < all_info(2, a) + all_info(3, a)) owner = a
      end do
      if (owner < 0 .or. bead_at(t%data(1) - 1 - l(1), l(2), l(3)) == 0 .or. &
          bead_at(l(1), t%data(2) - 1 - l(2), l(3)) == 0) then
        call raise(err, 'internal error: bead ' // str(bead) // ' has no data plane or no mirror image')
        exit
      end if
      ! The row of (plane, middle slot), then the field's place in it (mirror_transform.f90).
      site = all_info(1, owner) + t%row * (j(2) + int(t%half(2), i8) * (l(3) - all_info(2, owner)))
      do axis = 1, 2
        image = l
        image(axis) = t%data(axis) - 1 - l(axis)
        images((axis - 1) * n_local * nb + (i - 1) * nb + 1:(axis - 1) * n_local * nb + i * nb) = &
          [(int((bead_at(image(1), image(2), image(3)) - 1) * nb + a - 1), a = 1, nb)]
      end do
      do a = 1, nb
        sites((i - 1) * nb + a) = int(site + t%field_base(slot(a)) + j(1) * t%field_step(slot(a)))
        rows((i - 1) * nb + a) = first_row + int((i - 1) * nb + a - 1)
      end do
    end do
    ! Agreed before the collective scatters: every rank goes on, or none.
    failed = merge(1, 0, err%failed)
    call MPI_Allreduce(MPI_IN_PLACE, failed, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
    if (failed /= 0) then
      if (.not. err%failed) call raise(err, 'the mirror classes could not be set up on another rank')
      return
    end if
    PetscCallA(VecCreateMPI(comm, int(n_local * nb), PETSC_DETERMINE, template, ierr))
    PetscCallA(ISCreateGeneral(comm, int(n_local * nb), rows, PETSC_COPY_VALUES, from, ierr))
    PetscCallA(ISCreateGeneral(comm, int(n_local * nb), sites, PETSC_COPY_VALUES, to, ierr))
    PetscCallA(VecScatterCreate(template, from, slab, to, mc%fold, ierr))
    PetscCallA(ISDestroy(to, ierr))
    do axis = 1, 2
      rows = images((axis - 1) * n_local * nb + 1:axis * n_local * nb)
      PetscCallA(ISCreateGeneral(comm, int(n_local * nb), rows, PETSC_COPY_VALUES, to, ierr))
      ! image(axis): the values at the images (to) into this bead's own rows (from).
      PetscCallA(VecScatterCreate(template, to, template, from, mc%image(axis), ierr))
      PetscCallA(ISDestroy(to, ierr))
    end do
    PetscCallA(ISDestroy(from, ierr))
    mc%work = template
    mc%created = .true.
  end subroutine make_mirror_classes

  subroutine destroy_mirror_classes(mc)
    type(mirror_classes_t), intent(inout) :: mc
    PetscErrorCode :: ierr
    if (.not. mc%created) return
    PetscCallA(VecScatterDestroy(mc%fold, ierr))
    PetscCallA(VecScatterDestroy(mc%image(1), ierr))
    PetscCallA(VecScatterDestroy(mc%image(2), ierr))
    PetscCallA(VecDestroy(mc%work, ierr))
    mc%created = .false.
  end subroutine destroy_mirror_classes

  !> Collective. The classes x is in: one if x is within class_tolerance of it, else all four.
  subroutine classes_of(mc, x, classes, n)
    type(mirror_classes_t), intent(inout) :: mc
    Vec, intent(in) :: x
    integer, intent(out) :: classes(n_classes), n
    PetscErrorCode :: ierr
    PetscScalar, pointer :: own(:), mirrored(:)
    real(dp) :: local(5), total(5), s(2)
    integer :: axis, c
    integer(i8) :: i, e
    local = 0.0_dp
    PetscCallA(VecGetArrayReadF90(x, own, ierr))
    do axis = 1, 2
      PetscCallA(VecScatterBegin(mc%image(axis), x, mc%work, INSERT_VALUES, SCATTER_FORWARD, ierr))
      PetscCallA(VecScatterEnd(mc%image(axis), x, mc%work, INSERT_VALUES, SCATTER_FORWARD, ierr))
      PetscCallA(VecGetArrayReadF90(mc%work, mirrored, ierr))
      ! ||x - M_a x||^2 and ||x + M_a x||^2, (M_a x)_i = D_a(i) x_i(image)
      e = 0
      do i = 1, mc%n_local
        local(2 * axis - 1) = local(2 * axis - 1) + sum((own(e + 1:e + mc%nb) &
                                                         - mc%field_sign(:, axis) * mirrored(e + 1:e + mc%nb))**2)
        local(2 * axis) = local(2 * axis) + sum((own(e + 1:e + mc%nb) + mc%field_sign(:, axis) * mirrored(e + 1:e + mc%nb))**2)
        e = e + mc%nb
      end do
      PetscCallA(VecRestoreArrayReadF90(mc%work, mirrored, ierr))
    end do
    local(5) = sum(own**2)
    PetscCallA(VecRestoreArrayReadF90(x, own, ierr))
    call MPI_Allreduce(local, total, 5, MPI_DOUBLE_PRECISION, MPI_SUM, mc%comm, ierr)
    ! even along axis a: x = M_a x; odd: x = -M_a x (each difference is 4 ||part||^2)
    do axis = 1, 2
      s(axis) = 0
      if (total(2 * axis - 1) <= (2 * class_tolerance)**2 * total(5)) s(axis) = 1
      if (total(2 * axis) <= (2 * class_tolerance)**2 * total(5)) s(axis) = -1
    end do
    if (total(5) == 0) then   ! zero: any one class
      s = 1
    end if
    if (all(s /= 0)) then
      n = 1
      do c = 1, n_classes
        if (all(class_signs(c) == nint(s))) classes(1) = c
      end do
    else
      n = n_classes
      classes = [(c, c = 1, n_classes)]
    end if
  end subroutine classes_of

  !> Collective. The data planes `slab` (zeroed here) <- P_c x on the fundamental sites.
  subroutine fold_class(mc, x, class, slab)
    type(mirror_classes_t), intent(inout) :: mc
    Vec, intent(in) :: x
    integer, intent(in) :: class
    Vec, intent(in) :: slab
    PetscErrorCode :: ierr
    PetscScalar, pointer :: from(:), to(:)
    integer(i8) :: i, e
    real(dp) :: signs(mc%nb, 0:3)
    call side_signs(mc, class, signs)
    PetscCallA(VecGetArrayReadF90(x, from, ierr))
    PetscCallA(VecGetArrayF90(mc%work, to, ierr))
    e = 0
    do i = 1, mc%n_local
      to(e + 1:e + mc%nb) = mc%weight(i) * signs(:, mc%side(i)) * from(e + 1:e + mc%nb)
      e = e + mc%nb
    end do
    PetscCallA(VecRestoreArrayF90(mc%work, to, ierr))
    PetscCallA(VecRestoreArrayReadF90(x, from, ierr))
    PetscCallA(VecZeroEntries(slab, ierr))
    PetscCallA(VecScatterBegin(mc%fold, mc%work, slab, ADD_VALUES, SCATTER_FORWARD, ierr))
    PetscCallA(VecScatterEnd(mc%fold, mc%work, slab, ADD_VALUES, SCATTER_FORWARD, ierr))
  end subroutine fold_class

  !> Collective. y = (or += when adding) the bead values of class c from the data planes `slab`.
  subroutine unfold_class(mc, slab, class, y, adding)
    type(mirror_classes_t), intent(inout) :: mc
    Vec, intent(in) :: slab
    integer, intent(in) :: class
    Vec, intent(in) :: y
    logical, intent(in) :: adding
    PetscErrorCode :: ierr
    PetscScalar, pointer :: from(:), to(:)
    integer(i8) :: i, e
    real(dp) :: signs(mc%nb, 0:3)
    call side_signs(mc, class, signs)
    PetscCallA(VecScatterBegin(mc%fold, slab, mc%work, INSERT_VALUES, SCATTER_REVERSE, ierr))
    PetscCallA(VecScatterEnd(mc%fold, slab, mc%work, INSERT_VALUES, SCATTER_REVERSE, ierr))
    PetscCallA(VecGetArrayReadF90(mc%work, from, ierr))
    PetscCallA(VecGetArrayF90(y, to, ierr))
    e = 0
    do i = 1, mc%n_local
      if (adding) then
        to(e + 1:e + mc%nb) = to(e + 1:e + mc%nb) + signs(:, mc%side(i)) * from(e + 1:e + mc%nb)
      else
        to(e + 1:e + mc%nb) = signs(:, mc%side(i)) * from(e + 1:e + mc%nb)
      end if
      e = e + mc%nb
    end do
    PetscCallA(VecRestoreArrayF90(y, to, ierr))
    PetscCallA(VecRestoreArrayReadF90(mc%work, from, ierr))
  end subroutine unfold_class

  !> signs(:, side): the factor of a bead's unknowns relative to its fundamental site in class c,
  !> the product of s_a D_a over the mirrors it lies beyond.
  pure subroutine side_signs(mc, class, signs)
    type(mirror_classes_t), intent(in) :: mc
    integer, intent(in) :: class
    real(dp), intent(out) :: signs(:, 0:)
    integer :: s(2), side
    s = class_signs(class)
    do side = 0, 3
      signs(:, side) = 1.0_dp
      if (iand(side, 1) /= 0) signs(:, side) = signs(:, side) * s(1) * mc%field_sign(:, 1)
      if (iand(side, 2) /= 0) signs(:, side) = signs(:, side) * s(2) * mc%field_sign(:, 2)
    end do
  end subroutine side_signs
end module beadmob_mirror_classes
