!> Tests src/operators/block_table.f90; also src/multipole/lattice_symmetry.f90.
!> CTest: test_block_table_np1 and test_block_table_np2 (the program keeps the test's name, test_block_table).
!> The lattice block table against direct quadrature: blocks obtained from canonical displacements
!> through the lattice symmetries (D_Q A(c) D_Q^T) and the transpose rule A(-d) = A(d)^T must equal
!> the pair block computed directly by quadrature at that displacement (an independent evaluation:
!> the quadrature rule is aligned with each displacement), to 1e-13 of the largest entry; and the
!> transforms D_Q must be orthogonal. L = 1, 2, 3. The compact table (canonical blocks only, what
!> the FFT operator forms its slabs from) must give every block of the box, whole
!> (lattice_block) and entry by entry through the rows of D_Q without zeros
!> (lattice_block_entries), equal to the expanded table to 1e-14 of the largest entry. Every
!> canonical block of a 7 x 5 x 4 box (from the axial table, theory.md T15) equals the direct
!> quadrature to 1e-13.
program test_block_table
#include "petsc/finclude/petscsys.h"
  use petscsys
  use beadmob_kinds, only: dp, i8
  use beadmob_testing
  use beadmob_errors, only: error_t
  use beadmob_strings, only: str
  use beadmob_multipole_basis, only: multipole_basis_t, make_multipole_basis
  use beadmob_pair_blocks, only: pair_block
  use beadmob_lattice_symmetry, only: n_symmetries, basis_transforms
  use beadmob_block_table, only: block_table_t, make_block_table, table_block_index, lattice_block, lattice_block_entries
  implicit none
  type(test_suite_t) :: suite
  type(multipole_basis_t) :: basis
  type(block_table_t) :: table, compact
  type(error_t) :: err
  PetscErrorCode :: ierr
  real(dp) :: centres(3, 5)
  real(dp), allocatable :: direct(:, :), transforms(:, :, :), identity(:, :)
  integer :: order, i, j, s, k, worst_symmetry, d(3), a, b
  real(dp) :: worst, orthogonality, worst_whole, worst_entries, largest
  integer, allocatable :: rows(:), columns(:)
  real(dp), allocatable :: entries(:)

  PetscCallA(PetscInitialize(ierr))
  suite = start_tests('test_block_table')
  ! Five beads spanning a 4 x 3 x 3 box, off the origin.
  centres = reshape([3, 7, -2, 6, 8, -1, 4, 9, 0, 3, 7, 0, 5, 9, -2], [3, 5]) * 1.0_dp
  do order = 1, 3
    basis = make_multipole_basis(order, max(order - 2, 0))
    allocate (transforms(basis%size, basis%size, n_symmetries), identity(basis%size, basis%size))
    call basis_transforms(basis, transforms)
    identity = 0.0_dp
    do k = 1, basis%size
      identity(k, k) = 1.0_dp
    end do
    orthogonality = 0.0_dp
    do s = 1, n_symmetries
      orthogonality = max(orthogonality, maxval(abs(matmul(transpose(transforms(:, :, s)), transforms(:, :, s)) &
                                                    - identity)))
    end do
    call check(suite, orthogonality < 1.0e-13_dp, 'L = ' // str(order) // ': every D_Q orthogonal')
    call make_block_table(PETSC_COMM_WORLD, basis, centres, 1_i8, 5_i8, table, err)
    call check(suite, .not. err%failed .and. table%on_lattice, 'L = ' // str(order) // ': lattice table built')
    allocate (direct(basis%size, basis%size))
    worst = 0.0_dp
    worst_symmetry = 0
    do i = 1, 5
      do j = 1, 5
        if (i == j) cycle
        call pair_block(basis, centres(:, i) - centres(:, j), direct)
        k = table_block_index(table, table%lattice(:, i) - table%lattice(:, j))
        worst = max(worst, maxval(abs(table%blocks(:, :, k) - direct)) / maxval(abs(direct)))
      end do
    end do
    call check(suite, worst < 1.0e-13_dp, 'L = ' // str(order) // ': table block = direct quadrature block, ' // &
               'largest relative difference ' // str(worst))
    call make_block_table(PETSC_COMM_WORLD, basis, centres, 1_i8, 5_i8, compact, err, expand=.false.)
    call check_canonical_blocks(order)
    call check(suite, .not. err%failed .and. .not. allocated(compact%blocks), 'L = ' // str(order) // &
               ': compact table built without the box')
    rows = [((a, a = 1, basis%size), b = 1, basis%size)]
    columns = [((b, a = 1, basis%size), b = 1, basis%size)]
    allocate (entries(size(rows)))
    worst_whole = 0.0_dp
    worst_entries = 0.0_dp
    largest = maxval(abs(table%blocks))
    do k = -table%span(3), table%span(3)
      do j = -table%span(2), table%span(2)
        do i = -table%span(1), table%span(1)
          d = [i, j, k]
          direct = table%blocks(:, :, table_block_index(table, d))
          worst_whole = max(worst_whole, maxval(abs(lattice_block(compact, d) - direct)))
          call lattice_block_entries(compact, d, rows, columns, entries)
          worst_entries = max(worst_entries, maxval(abs(reshape(entries, [basis%size, basis%size]) - direct)))
        end do
      end do
    end do
    call check(suite, worst_whole < 1.0e-14_dp * largest, 'L = ' // str(order) // ': compact lattice_block = ' // &
               'expanded table, largest relative difference ' // str(worst_whole / largest))
    call check(suite, worst_entries < 1.0e-14_dp * largest, 'L = ' // str(order) // ': compact entries = ' // &
               'expanded table, largest relative difference ' // str(worst_entries / largest))
    deallocate (direct, transforms, identity, entries)
  end do
  call finish_tests(suite)
  PetscCallA(PetscFinalize(ierr))

contains

  !> Every canonical block of a 7 x 5 x 4 box (touching to farthest pairs, the blocks the FFT
  !> operator forms its kernel from; computed from the axial table) against pair_block's direct
  !> quadrature aligned with that displacement, to 1e-13 of the block's largest entry.
  subroutine check_canonical_blocks(order)
    integer, intent(in) :: order
    type(block_table_t) :: box_table
    real(dp) :: corners(3, 2), worst_canonical, quadrature(basis%size, basis%size)
    integer :: c
    corners(:, 1) = [0.0_dp, 0.0_dp, 0.0_dp]
    corners(:, 2) = [7.0_dp, 5.0_dp, 4.0_dp]
    call make_block_table(PETSC_COMM_WORLD, basis, corners, 1_i8, 2_i8, box_table, err, expand=.false.)
    worst_canonical = 0.0_dp
    do c = 1, size(box_table%canonical_blocks, 3)
      call pair_block(basis, real(canonical_of(box_table, c), dp), quadrature)
      worst_canonical = max(worst_canonical, maxval(abs(box_table%canonical_blocks(:, :, c) - quadrature)) &
                            / maxval(abs(quadrature)))
    end do
    call check(suite, .not. err%failed .and. size(box_table%canonical_blocks, 3) == 94 .and. &
               worst_canonical < 1.0e-13_dp, 'L = ' // str(order) // ': all ' // &
               str(size(box_table%canonical_blocks, 3)) // ' canonical blocks of a 7 x 5 x 4 box = direct ' // &
               'quadrature, largest relative difference ' // str(worst_canonical))
  end subroutine check_canonical_blocks

  !> The canonical displacement numbered c in the table.
  function canonical_of(box_table, c) result(displacement)
    type(block_table_t), intent(in) :: box_table
    integer, intent(in) :: c
    integer :: displacement(3)
    displacement = findloc(box_table%canonical_id, c) - 1
  end function canonical_of
end program test_block_table
