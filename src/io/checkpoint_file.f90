!> The checkpoint of a friction job (nothing lost at a wall-time limit): every
!> Krylov solution q of a rigid motion, saved as soon as its solve has finished, so that a job
!> killed by a batch system resumes from the motions it has already solved. One HDF5 file next to
!> the result, '<output>.checkpoint.h5', written collectively with parallel HDF5:
!>   /        attributes format = 'beadmob-checkpoint', format_version, key (text), key_digest
!>            (FNV-1a 64 of the key, hex), n_beads (beads in the solve), unknowns_per_bead
!>   /<motion> float64 (nb, N) (Fortran order; C readers see (N, nb)): q in global bead order, so
!>            any number of ranks can read it; attributes iterations, converged_reason,
!>            true_relative_residual of the solve that made it
!> The key lists everything q depends on (the numbers-only effective input, the beads, the
!> operator, the Krylov method, preconditioner and tolerances used): a file is used only when
!> its key equals the run's exactly, so a changed input never reuses stale saves. Every save
!> writes the whole file to '<checkpoint>.tmp' and renames it over the checkpoint: a kill while
!> writing leaves the previous checkpoint whole.
module beadmob_checkpoint_file
  use hdf5, only: hid_t, h5lexists_f, h5dopen_f, h5dclose_f
  use mpi, only: MPI_Barrier, MPI_Bcast, MPI_LOGICAL
  use beadmob_file_system, only: rename_file, remove_file
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t, agree_on_error
  use beadmob_hdf5_support, only: h5_create_parallel, h5_open_parallel_readonly, h5_close_file, write_attribute, &
                                  write_distributed_columns, read_distributed_columns, read_text_attribute, &
                                  read_int_attribute, read_real_attribute
  implicit none
  private
  public :: checkpoint_suffix, saved_solve_t, checkpoint_writer_t, begin_checkpoint, write_checkpoint_motion, &
            commit_checkpoint, open_checkpoint, read_checkpoint_motion, close_checkpoint, remove_checkpoint, &
            fnv1a_hex, reals_digest
  public :: checkpoint_missing, checkpoint_matches, checkpoint_other_key

  character(len=*), parameter :: checkpoint_format = 'beadmob-checkpoint'
  integer, parameter :: checkpoint_format_version = 1
  character(len=*), parameter :: checkpoint_suffix = '.checkpoint.h5'
  character(len=*), parameter :: temporary_suffix = '.tmp'
  !> What open_checkpoint found.
  integer, parameter :: checkpoint_missing = 0, checkpoint_matches = 1, checkpoint_other_key = 2

  !> What a saved motion carries besides q: the record of the solve that made it.
  type :: saved_solve_t
    integer :: iterations = 0
    integer :: converged_reason = 0
    real(dp) :: true_relative_residual = 0.0_dp
  end type saved_solve_t

  !> A checkpoint being written (the temporary file, open on every rank).
  type :: checkpoint_writer_t
    character(len=:), allocatable :: path, temporary
    integer(hid_t) :: file_id = -1
  end type checkpoint_writer_t

  !> FNV-1a, 64 bits: offset basis and prime, split in 32-bit halves so that every product fits
  !> an integer(i8) without overflow (Fortran integers do not wrap by definition).
  integer(i8), parameter :: basis_high = int(z'CBF29CE4', i8), basis_low = int(z'84222325', i8)
  integer(i8), parameter :: low_mask = int(z'FFFFFFFF', i8)

contains

  !> Collective. Create the temporary file of a new checkpoint of `path` with its key.
  subroutine begin_checkpoint(ctx, path, key, n_beads, unknowns_per_bead, writer, err)
    type(run_context_t), intent(in) :: ctx
    character(len=*), intent(in) :: path, key
    integer(i8), intent(in) :: n_beads
    integer, intent(in) :: unknowns_per_bead
    type(checkpoint_writer_t), intent(out) :: writer
    type(error_t), intent(inout) :: err
    writer%path = path
    writer%temporary = path // temporary_suffix
    call h5_create_parallel(ctx, writer%temporary, writer%file_id, err)
    call agree_on_error(ctx, err)
    if (err%failed) then
      writer%file_id = -1
      return
    end if
    call write_attribute(writer%file_id, 'format', checkpoint_format, err)
    call write_attribute(writer%file_id, 'format_version', checkpoint_format_version, err)
    call write_attribute(writer%file_id, 'key', key, err)
    call write_attribute(writer%file_id, 'key_digest', fnv1a_hex(key), err)
    call write_attribute(writer%file_id, 'n_beads', n_beads, err)
    call write_attribute(writer%file_id, 'unknowns_per_bead', unknowns_per_bead, err)
  end subroutine begin_checkpoint

  !> Collective. Motion `name`: this rank's columns first..first+size(block,2)-1 of q, (nb, N).
  subroutine write_checkpoint_motion(writer, name, block, first, n_beads, solve, err)
    type(checkpoint_writer_t), intent(in) :: writer
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: block(:, :)
    integer(i8), intent(in) :: first, n_beads
    type(saved_solve_t), intent(in) :: solve
    type(error_t), intent(inout) :: err
    integer(hid_t) :: dataset
    integer :: status
    if (writer%file_id < 0) return
    call write_distributed_columns(writer%file_id, name, block, first, n_beads, err)
    call h5dopen_f(writer%file_id, name, dataset, status)
    if (status < 0) then
      call raise(err, 'cannot reopen dataset ' // name)
      return
    end if
    call write_attribute(dataset, 'iterations', solve%iterations, err)
    call write_attribute(dataset, 'converged_reason', solve%converged_reason, err)
    call write_attribute(dataset, 'true_relative_residual', solve%true_relative_residual, err)
    call h5dclose_f(dataset, status)
  end subroutine write_checkpoint_motion

  !> Collective. Close the temporary file and rename it over the checkpoint (rank 0); on any
  !> failure the temporary file is removed and the old checkpoint, if any, stays as it was.
  subroutine commit_checkpoint(ctx, writer, err)
    type(run_context_t), intent(in) :: ctx
    type(checkpoint_writer_t), intent(inout) :: writer
    type(error_t), intent(inout) :: err
    integer :: ierr
    if (writer%file_id >= 0) call h5_close_file(writer%file_id, err)
    writer%file_id = -1
    call agree_on_error(ctx, err)
    ! Every rank's part is on disk before the name changes.
    call MPI_Barrier(ctx%comm, ierr)
    if (ctx%rank == 0) then
      if (err%failed) then
        call remove_file(writer%temporary)
      else if (.not. rename_file(writer%temporary, writer%path)) then
        call raise(err, "cannot rename '" // writer%temporary // "' to '" // writer%path // "'")
        call remove_file(writer%temporary)
      end if
    end if
    call agree_on_error(ctx, err)
  end subroutine commit_checkpoint

  !> Collective. Open the checkpoint `path` if it exists (outcome checkpoint_missing when not),
  !> and compare its key with the run's: checkpoint_matches (then file_id is open, the caller
  !> reads motions and closes it) or checkpoint_other_key (closed). An unreadable or foreign file
  !> raises `err` (closed), the same on every rank.
  subroutine open_checkpoint(ctx, path, key, file_id, outcome, err)
    type(run_context_t), intent(in) :: ctx
    character(len=*), intent(in) :: path, key
    integer(hid_t), intent(out) :: file_id
    integer, intent(out) :: outcome
    type(error_t), intent(inout) :: err
    character(len=:), allocatable :: format, stored
    logical :: exists
    integer :: version, ierr
    type(error_t) :: ignored

    file_id = -1
    outcome = checkpoint_missing
    ! Rank 0 looks: every rank must take the same branch into the collective open.
    if (ctx%rank == 0) inquire (file=path, exist=exists)
    call MPI_Bcast(exists, 1, MPI_LOGICAL, 0, ctx%comm, ierr)
    if (.not. exists) return
    call h5_open_parallel_readonly(ctx, path, file_id, err)
    if (.not. err%failed) call read_text_attribute(file_id, 'format', format, err)
    if (.not. err%failed) then
      if (format /= checkpoint_format) call raise(err, "not a beadmob checkpoint (format '" // format // "')")
    end if
    if (.not. err%failed) call read_int_attribute(file_id, 'format_version', version, err)
    if (.not. err%failed) then
      if (version /= checkpoint_format_version) call raise(err, 'format_version ' // str(version) // &
                                                           ', this beadmob reads ' // str(checkpoint_format_version))
    end if
    if (.not. err%failed) call read_text_attribute(file_id, 'key', stored, err)
    call agree_on_error(ctx, err)
    if (.not. err%failed) then
      outcome = merge(checkpoint_matches, checkpoint_other_key, stored == key)
    end if
    if (outcome /= checkpoint_matches .and. file_id >= 0) then
      call h5_close_file(file_id, ignored)
      file_id = -1
    end if
  end subroutine open_checkpoint

  !> Collective. Motion `name` from an open, matching checkpoint into this rank's columns of q:
  !> found = .false. when it was not saved. A damaged dataset raises `err` (on this rank: the
  !> caller agrees).
  subroutine read_checkpoint_motion(file_id, name, block, first, n_beads, found, solve, err)
    integer(hid_t), intent(in) :: file_id
    character(len=*), intent(in) :: name
    real(dp), intent(inout) :: block(:, :)
    integer(i8), intent(in) :: first, n_beads
    logical, intent(out) :: found
    type(saved_solve_t), intent(out) :: solve
    type(error_t), intent(inout) :: err
    integer(hid_t) :: dataset
    integer :: status
    call h5lexists_f(file_id, name, found, status)
    if (status < 0) then
      found = .false.
      call raise(err, 'cannot look up motion ' // name)
    end if
    if (.not. found .or. err%failed) return
    call read_distributed_columns(file_id, name, block, first, n_beads, err)
    if (err%failed) return
    call h5dopen_f(file_id, name, dataset, status)
    call read_int_attribute(dataset, 'iterations', solve%iterations, err)
    call read_int_attribute(dataset, 'converged_reason', solve%converged_reason, err)
    call read_real_attribute(dataset, 'true_relative_residual', solve%true_relative_residual, err)
    call h5dclose_f(dataset, status)
  end subroutine read_checkpoint_motion

  !> Collective. Close what open_checkpoint opened.
  subroutine close_checkpoint(file_id, err)
    integer(hid_t), intent(inout) :: file_id
    type(error_t), intent(inout) :: err
    if (file_id >= 0) call h5_close_file(file_id, err)
    file_id = -1
  end subroutine close_checkpoint

  !> Remove the checkpoint and a temporary file left next to it (call on one rank); absent
  !> files are no error: the run's results are in the result file by now.
  subroutine remove_checkpoint(path)
    character(len=*), intent(in) :: path
    call remove_file(path)
    call remove_file(path // temporary_suffix)
  end subroutine remove_checkpoint

  !> 64-bit FNV-1a hash of a text, as 16 hexadecimal digits.
  function fnv1a_hex(text) result(hex)
    character(len=*), intent(in) :: text
    character(len=16) :: hex
    integer(i8) :: high, low
    integer :: k
    high = basis_high
    low = basis_low
    do k = 1, len(text)
      call fnv1a_byte(high, low, int(iachar(text(k:k)), i8))
    end do
    write (hex, '(z8.8, z8.8)') high, low
  end function fnv1a_hex

  !> FNV-1a of the bit patterns of `values` (every byte), as 16 hexadecimal digits: the same
  !> numbers give the same digest, any changed bit another one (with 2^-64 odds of a collision).
  function reals_digest(values) result(hex)
    real(dp), intent(in) :: values(:, :)
    character(len=16) :: hex
    integer(i8) :: high, low, bits
    integer :: i, j, byte
    high = basis_high
    low = basis_low
    do j = 1, size(values, 2)
      do i = 1, size(values, 1)
        bits = transfer(values(i, j), bits)
        do byte = 0, 7
          call fnv1a_byte(high, low, ibits(bits, 8 * byte, 8))
        end do
      end do
    end do
    write (hex, '(z8.8, z8.8)') high, low
  end function reals_digest

  !> One FNV-1a step on the hash (high, low): xor the byte, multiply by the prime 2^40 + 435
  !> modulo 2^64. h * 2^40 adds low * 2^8 to the high half; h * 435 is done per half with carry.
  pure subroutine fnv1a_byte(high, low, byte)
    integer(i8), intent(inout) :: high, low
    integer(i8), intent(in) :: byte
    integer(i8) :: low_product
    low = ieor(low, byte)
    low_product = low * 435_i8
    high = iand(high * 435_i8 + ishft(low_product, -32) + ishft(iand(low, int(z'FFFFFF', i8)), 8), low_mask)
    low = iand(low_product, low_mask)
  end subroutine fnv1a_byte
end module beadmob_checkpoint_file
