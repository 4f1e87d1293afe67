!> Tests src/io/table_cache.f90; also the cache keys of src/operators/block_table.f90 and
!> src/lubrication/lubrication.f90, through the friction job (src/solvers/friction_job.F90).
!> CTest: test_table_cache_np1 and test_table_cache_np2 (the program keeps the test's name, test_table_cache).
!> The HDF5 table cache of the lattice blocks and the lubrication corrections (docs/input.md, "Table cache"):
!>  - a run that fills the cache and a run that reads it give the friction of an uncached run to
!>    the last bit (direct operator: no FFTW planner in the way);
!>  - a larger body reuses a smaller one's blocks and computes only the missing ones;
!>  - a cache made at another L is not used, and entries of other L survive an update;
!>  - a file of garbage bytes, a damaged cache and an entry made with other parameters (same
!>    name, other key text, wrong numbers) are not used: correct friction, and the cache is
!>    rewritten usable (the warning lines are checked by the CTest regular expression);
!>  - read/write round trip of both entry kinds.
program test_table_cache
#include "petsc/finclude/petscsys.h"
  use petscsys
  use beadmob_kinds, only: dp, i8
  use beadmob_testing
  use beadmob_errors, only: error_t
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t, make_run_context
  use beadmob_friction_job, only: friction_settings_t, friction_result_t, friction_of_model
  use beadmob_multipole_basis, only: make_multipole_basis
  use beadmob_block_table, only: block_cache_key
  use beadmob_lubrication, only: lubrication_cache_key
  use beadmob_hdf5_support, only: set_hdf5_error_stack
  use beadmob_table_cache, only: cache_key_t, read_cached_blocks, write_cached_blocks, read_cached_lubrication, &
                                 write_cached_lubrication
  implicit none
  type(test_suite_t) :: suite
  type(run_context_t) :: ctx
  PetscErrorCode :: ierr
  real(dp), allocatable :: small(:, :), large(:, :)
  type(friction_result_t) :: plain, first, second, other
  character(len=:), allocatable :: cache, scratch
  integer(i8) :: total

  PetscCallA(PetscInitialize(ierr))
  PetscCallA(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-ksp_rtol', '1e-10', ierr))
  suite = start_tests('test_table_cache')
  ctx = make_run_context(PETSC_COMM_WORLD)
  ! As the driver does: the unusable cache files below each give one warning line, no HDF5 stack.
  call set_hdf5_error_stack(.false.)
  ! One set of files per rank count: the np1 and np2 tests may run at the same time.
  cache = 'table_cache_np' // str(ctx%n_ranks) // '.h5'
  scratch = 'table_cache_scratch_np' // str(ctx%n_ranks) // '.h5'
  call remove_file(cache)
  call remove_file(scratch)

  ! A 3 x 2 x 2 block and a 4 x 3 x 2 block containing it (lattice, spacing d).
  small = lattice_box([3, 2, 2])
  large = lattice_box([4, 3, 2])

  ! Bitwise identity: uncached, cache-filling and cache-reading runs (with lubrication at contact).
  call run(small, 2, .true., '', plain)
  call run(small, 2, .true., cache, first)
  call run(small, 2, .true., cache, second)
  total = plain%computed_blocks
  call check(suite, total > 0 .and. plain%cached_blocks == 0, 'uncached run: ' // str(total) // ' blocks computed')
  call check(suite, first%cached_blocks == 0 .and. first%computed_blocks == total, &
             'empty cache: every block computed, got ' // str(first%computed_blocks))
  call check(suite, second%cached_blocks == total .and. second%computed_blocks == 0, &
             'filled cache: every block read, got ' // str(second%cached_blocks) // ' read, ' // &
             str(second%computed_blocks) // ' computed')
  call check(suite, first%lubrication_table%computed_distances == 1 .and. &
             second%lubrication_table%cached_distances == 1 .and. second%lubrication_table%computed_distances == 0, &
             'lubrication correction computed once, then read')
  call check(suite, all(first%friction == plain%friction), 'cache-filling run: friction bitwise equal to uncached')
  call check(suite, all(second%friction == plain%friction), 'cache-reading run: friction bitwise equal to uncached')
  call check(suite, all(second%multipole_friction == plain%multipole_friction), &
             'cache-reading run: order-L friction bitwise equal to uncached')

  ! A superset body: the small body's blocks are reused, only the missing ones computed.
  call run(large, 2, .false., '', plain)
  call run(large, 2, .false., cache, first)
  call check(suite, first%cached_blocks > 0 .and. first%computed_blocks > 0 .and. &
             first%cached_blocks + first%computed_blocks == plain%computed_blocks, &
             'larger body: ' // str(first%cached_blocks) // ' blocks read, ' // str(first%computed_blocks) // &
             ' computed of ' // str(plain%computed_blocks))
  call check(suite, all(first%friction == plain%friction), 'larger body, partly cached: friction bitwise equal')
  call run(small, 2, .false., cache, second)
  call check(suite, second%cached_blocks == total .and. second%computed_blocks == 0, &
             'the union written back still serves the small body')

  ! Another L: the L = 2 entry is not used, and it survives the L = 1 update.
  call run(small, 1, .true., '', plain)
  call run(small, 1, .true., cache, first)
  call check(suite, first%cached_blocks == 0 .and. first%computed_blocks == plain%computed_blocks .and. &
             first%lubrication_table%cached_distances == 0, 'L = 1 takes nothing from the L = 2 entries')
  call check(suite, all(first%friction == plain%friction), 'L = 1 with an L = 2 cache: friction bitwise equal')
  call run(small, 2, .true., cache, second)
  call check(suite, second%cached_blocks == total .and. second%lubrication_table%cached_distances == 1, &
             'the L = 2 entries survive the L = 1 update')
  call run(small, 1, .false., cache, second)
  call check(suite, second%computed_blocks == 0, 'the L = 1 entry is used at L = 1')

  ! Garbage bytes: a warning, correct friction, and the cache is rewritten usable.
  call run(small, 2, .true., '', plain)
  call write_garbage(scratch, 0, 4096)
  call run(small, 2, .true., scratch, first)
  call check(suite, first%cached_blocks == 0 .and. all(first%friction == plain%friction), &
             'garbage file: nothing read, friction bitwise equal')
  call run(small, 2, .true., scratch, second)
  call check(suite, second%cached_blocks == total .and. all(second%friction == plain%friction), &
             'garbage file replaced by a usable cache')

  ! Damaged data (bytes in the middle of the block data overwritten): detected by the checksums.
  call write_garbage(scratch, -1, 512)
  call run(small, 2, .true., scratch, first)
  call check(suite, first%cached_blocks == 0 .and. all(first%friction == plain%friction), &
             'damaged cache: not used, friction bitwise equal')

  ! An entry with the run's name but another key (and wrong numbers) must not be used.
  call plant_foreign_entry(scratch)
  call run(small, 2, .true., scratch, first)
  call check(suite, first%cached_blocks == 0 .and. first%lubrication_table%cached_distances == 0 .and. &
             all(first%friction == plain%friction), 'entry made with other parameters: not used, friction bitwise equal')
  call run(small, 2, .true., scratch, other)
  call check(suite, other%cached_blocks == total, 'the foreign entry was replaced')

  call check_round_trip()
  call remove_file(scratch)
  call finish_tests(suite)
  PetscCallA(PetscFinalize(ierr))

contains

  !> Integer points of an n(1) x n(2) x n(3) box, shifted off the origin.
  function lattice_box(n) result(centres)
    integer, intent(in) :: n(3)
    real(dp), allocatable :: centres(:, :)
    integer :: i, j, k, b
    allocate (centres(3, product(n)))
    b = 0
    do k = 1, n(3)
      do j = 1, n(2)
        do i = 1, n(1)
          b = b + 1
          centres(:, b) = [i + 10, j - 3, k + 1] * 1.0_dp
        end do
      end do
    end do
  end function lattice_box

  subroutine run(centres, order, lubrication, cache_file, result)
    real(dp), intent(in) :: centres(:, :)
    integer, intent(in) :: order
    logical, intent(in) :: lubrication
    character(len=*), intent(in) :: cache_file
    type(friction_result_t), intent(out) :: result
    type(friction_settings_t) :: settings
    type(error_t) :: err
    settings%multipole_order = order
    settings%potential_order = max(order - 2, 0)
    settings%shell_layers = 0   ! the full model (the library, like the program, would pick a shell)
    settings%lubrication = lubrication
    settings%lubrication_cutoff = 1.0_dp   ! contact pairs only: one exact doublet series
    settings%operator_name = 'direct'      ! no FFTW planner: bitwise reproducible
    settings%cache_file = cache_file
    call friction_of_model(ctx, settings, centres, sum(centres, dim=2) / size(centres, 2), result, err)
    call check(suite, .not. err%failed, 'friction computed (L = ' // str(order) // ', cache ' // cache_file // ')')
    call check(suite, all(result%solves%converged_reason > 0), 'all six solves converged')
  end subroutine run

  subroutine remove_file(path)
    character(len=*), intent(in) :: path
    integer :: unit, status, mpi_err
    if (ctx%rank == 0) then
      open (newunit=unit, file=path, status='old', iostat=status)
      if (status == 0) close (unit, status='delete')
    end if
    call MPI_Barrier(ctx%comm, mpi_err)
  end subroutine remove_file

  !> Rank 0 writes `count` pseudo-random bytes at byte `offset` (0: a new file of garbage; -1: in
  !> the middle of the existing file).
  subroutine write_garbage(path, offset, count)
    character(len=*), intent(in) :: path
    integer, intent(in) :: offset, count
    integer :: unit, status, mpi_err, file_size, at, k
    character(len=count) :: bytes
    do k = 1, count
      bytes(k:k) = achar(mod(37 * k + 11, 256))
    end do
    if (ctx%rank == 0) then
      if (offset == 0) then
        open (newunit=unit, file=path, access='stream', form='unformatted', status='replace', iostat=status)
        at = 1
      else
        open (newunit=unit, file=path, access='stream', form='unformatted', status='old', iostat=status)
        inquire (unit=unit, size=file_size)
        at = file_size / 2
      end if
      call check(suite, status == 0, 'scratch file opened for garbage')
      write (unit, pos=at) bytes
      close (unit)
    end if
    call MPI_Barrier(ctx%comm, mpi_err)
  end subroutine write_garbage

  !> Entries named as the L = 2 run's, with another key text and blocks of ones.
  subroutine plant_foreign_entry(path)
    character(len=*), intent(in) :: path
    type(cache_key_t) :: key
    type(error_t) :: err
    integer :: mpi_err, nb
    real(dp), allocatable :: blocks(:, :, :)
    if (ctx%rank == 0) then
      key = block_cache_key(make_multipole_basis(2, 0))
      key%text = key%text // ' (an older formula)'
      nb = 16
      allocate (blocks(nb, nb, 2))
      blocks = 1.0_dp
      call write_cached_blocks(path, key, reshape([1, 0, 0, 1, 1, 0], [3, 2]), blocks, err)
      call check(suite, .not. err%failed, 'foreign block entry written')
      key = lubrication_cache_key(2, 0)
      key%text = key%text // ' (an older formula)'
      call write_cached_lubrication(path, key, [1.0_dp], reshape([1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp], [4, 1]), err)
      call check(suite, .not. err%failed, 'foreign lubrication entry written')
    end if
    call MPI_Barrier(ctx%comm, mpi_err)
  end subroutine plant_foreign_entry

  !> Both entry kinds read back as written, other entries kept, unknown keys absent.
  subroutine check_round_trip()
    type(cache_key_t) :: key_a, key_b, key_c
    type(error_t) :: err
    integer, allocatable :: displacements(:, :)
    real(dp), allocatable :: blocks(:, :, :), distances(:), corrections(:, :), values(:, :, :)
    integer :: mpi_err, k
    if (ctx%rank == 0) then
      call remove_file_here(scratch)
      key_a = cache_key_t('a', 'key a')
      key_b = cache_key_t('b', 'key b')
      key_c = cache_key_t('c', 'key c')
      values = reshape([(0.5_dp * k, k = 1, 3 * 3 * 2)], [3, 3, 2])
      call write_cached_blocks(scratch, key_a, reshape([2, 1, 0, 3, 3, 3], [3, 2]), values, err)
      call write_cached_lubrication(scratch, key_b, [1.0_dp, sqrt(2.0_dp)], reshape([(1.0_dp * k, k = 1, 8)], [4, 2]), err)
      call write_cached_blocks(scratch, key_c, reshape([1, 1, 1], [3, 1]), values(:, :, 1:1), err)
      call check(suite, .not. err%failed, 'round trip: written')
      call read_cached_blocks(scratch, key_a, 3, displacements, blocks, err)
      call check(suite, .not. err%failed .and. size(displacements, 2) == 2, 'round trip: blocks entry a kept')
      if (size(displacements, 2) == 2) call check(suite, all(displacements == reshape([2, 1, 0, 3, 3, 3], [3, 2])) &
                                                  .and. all(blocks == values), 'round trip: blocks equal')
      call read_cached_lubrication(scratch, key_b, distances, corrections, err)
      call check(suite, .not. err%failed .and. size(distances) == 2, 'round trip: lubrication entry b kept')
      if (size(distances) == 2) call check(suite, all(distances == [1.0_dp, sqrt(2.0_dp)]) .and. &
                                           all(corrections == reshape([(1.0_dp * k, k = 1, 8)], [4, 2])), &
                                           'round trip: corrections equal')
      call read_cached_lubrication(scratch, key_a, distances, corrections, err)
      call check(suite, .not. err%failed .and. size(distances) == 0, 'round trip: no lubrication entry a')
      call read_cached_blocks(scratch, cache_key_t('c', 'key c, other'), 3, displacements, blocks, err)
      call check(suite, err%failed .and. size(displacements, 2) == 0, 'round trip: other key text refused')
      if (err%failed) call check(suite, index(err%message, 'other parameters') > 0, &
                                 'round trip: message names the mismatch: ' // err%message)
    end if
    call MPI_Barrier(ctx%comm, mpi_err)
  end subroutine check_round_trip

  subroutine remove_file_here(path)
    character(len=*), intent(in) :: path
    integer :: unit, status
    open (newunit=unit, file=path, status='old', iostat=status)
    if (status == 0) close (unit, status='delete')
  end subroutine remove_file_here
end program test_table_cache
