!> Tests src/geometry/shell_model.f90.
!> CTest: test_shell_model_np1 and test_shell_model_np2 (the program keeps the test's name, test_shell_model).
!> The shell model's surface layers (src/geometry/shell_model.f90) on bead sets whose layers are
!> counted by hand: an n x n x n block has (n - 2k + 2)^3 - (n - 2k)^3 beads in layer k (the cube
!> shells), a line and a plate are all surface, and a bead set shifted by a non-integer offset has
!> the same layers.
program test_shell_model
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t
  use beadmob_shell_model, only: surface_depth, shell_mask
  use beadmob_testing
  implicit none
  type(test_suite_t) :: suite
  integer, allocatable :: depth(:)
  logical, allocatable :: keep(:)
  type(error_t) :: err
  real(dp), allocatable :: block(:, :)
  integer :: k

  suite = start_tests('test_shell_model')

  block = block_of([7, 7, 7])
  call surface_depth(block, depth)
  do k = 1, 4
    call check_equal(suite, count(depth == k), (7 - 2 * k + 2)**3 - max(7 - 2 * k, 0)**3, &
                     '7^3 block: beads in layer ' // achar(iachar('0') + k))
  end do
  call check(suite, all(depth >= 1 .and. depth <= 4), '7^3 block: every bead has a layer 1..4')

  ! Off the origin by a non-integer offset: only lattice neighbourhood matters.
  call surface_depth(block + 1.0e6_dp + 0.25_dp, depth)
  call check_equal(suite, count(depth == 1), 7**3 - 5**3, 'shifted block: same surface layer')

  call surface_depth(block_of([9, 1, 1]), depth)
  call check(suite, all(depth == 1), 'a line of beads is all surface')
  call surface_depth(block_of([6, 5, 1]), depth)
  call check(suite, all(depth == 1), 'a plate one bead thick is all surface')

  call shell_mask(block_of([5, 5, 5]), 1, keep, err)
  call check(suite, .not. err%failed .and. count(keep) == 5**3 - 3**3, '5^3 block, one layer: 98 beads kept')
  call shell_mask(block_of([5, 5, 5]), 2, keep, err)
  call check(suite, .not. err%failed .and. count(keep) == 5**3 - 1, '5^3 block, two layers: all but the centre')
  call shell_mask(block_of([5, 5, 5]), 0, keep, err)
  call check(suite, err%failed .and. index(err%message, 'shell_layers must be >= 1') > 0, &
             'shell_mask refuses 0 layers with a message')

  call finish_tests(suite)

contains

  !> Beads at the integer points of an n(1) x n(2) x n(3) block.
  function block_of(n) result(centres)
    integer, intent(in) :: n(3)
    real(dp), allocatable :: centres(:, :)
    integer :: i, j, l, b
    allocate (centres(3, product(n)))
    b = 0
    do l = 0, n(3) - 1
      do j = 0, n(2) - 1
        do i = 0, n(1) - 1
          b = b + 1
          centres(:, b) = real([i, j, l], dp)
        end do
      end do
    end do
  end function block_of
end program test_shell_model
