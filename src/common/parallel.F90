!> The run context (MPI communicator, rank, size) and the collective error check that
!> keeps ranks from diverging: every rank calls `agree_on_error` at the same point; if any
!> rank failed, all ranks receive the first failing rank's message and fail together.
module beadmob_parallel
  use mpi
  use beadmob_kinds, only: i8
  use beadmob_strings, only: str
  use beadmob_errors, only: error_t
  implicit none
  private
  public :: run_context_t, make_run_context, agree_on_error, broadcast_text, block_range, even_shares

  type :: run_context_t
    integer :: comm = MPI_COMM_WORLD
    integer :: rank = 0
    integer :: n_ranks = 1
    integer :: ranks_on_node = 1   ! ranks sharing this rank's node (and its memory)
  end type run_context_t

  integer, parameter :: message_length = 2048

contains

  function make_run_context(comm) result(ctx)
    integer, intent(in) :: comm
    type(run_context_t) :: ctx
    integer :: ierr, node_comm
    ctx%comm = comm
    call MPI_Comm_rank(comm, ctx%rank, ierr)
    call MPI_Comm_size(comm, ctx%n_ranks, ierr)
    call MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, ctx%rank, MPI_INFO_NULL, node_comm, ierr)
    if (ierr == MPI_SUCCESS) then
      call MPI_Comm_size(node_comm, ctx%ranks_on_node, ierr)
      call MPI_Comm_free(node_comm, ierr)
    end if
  end function make_run_context

  !> Collective: afterwards `err` is failed on every rank if it was failed on any rank,
  !> with the message of the lowest failing rank.
  subroutine agree_on_error(ctx, err)
    type(run_context_t), intent(in) :: ctx
    type(error_t), intent(inout) :: err
    integer :: my_flag, first_failing, ierr
    character(len=message_length) :: buffer

    my_flag = huge(1)
    if (err%failed) my_flag = ctx%rank
    call MPI_Allreduce(my_flag, first_failing, 1, MPI_INTEGER, MPI_MIN, ctx%comm, ierr)
    if (first_failing == huge(1)) return
    buffer = ''
    if (ctx%rank == first_failing) buffer = err%message
    call MPI_Bcast(buffer, message_length, MPI_CHARACTER, first_failing, ctx%comm, ierr)
    ! Every rank reports the same message, so the root rank can print it.
    err%failed = .true.
    err%message = trim(buffer)
    if (first_failing /= 0) err%message = err%message // ' (rank ' // str(first_failing) // ')'
  end subroutine agree_on_error

  !> Broadcast a deferred-length string from the root rank to all ranks.
  subroutine broadcast_text(ctx, text)
    type(run_context_t), intent(in) :: ctx
    character(len=:), allocatable, intent(inout) :: text
    integer :: length, ierr
    if (ctx%rank == 0) length = len(text)
    call MPI_Bcast(length, 1, MPI_INTEGER, 0, ctx%comm, ierr)
    if (ctx%rank /= 0) then
      if (allocated(text)) deallocate (text)
      allocate (character(len=length) :: text)
    end if
    if (length > 0) call MPI_Bcast(text, length, MPI_CHARACTER, 0, ctx%comm, ierr)
  end subroutine broadcast_text

  !> Contiguous block partition of n items over the ranks: this rank owns
  !> items first..first+count-1 (1-based); the first mod(n, size) ranks get one more.
  subroutine block_range(ctx, n, first, count)
    type(run_context_t), intent(in) :: ctx
    integer(i8), intent(in) :: n
    integer(i8), intent(out) :: first, count
    integer(i8) :: base, extra
    base = n / ctx%n_ranks
    extra = mod(n, int(ctx%n_ranks, i8))
    count = base
    if (ctx%rank < extra) count = count + 1
    first = 1 + ctx%rank * base + min(int(ctx%rank, i8), extra)
  end subroutine block_range

  !> n items in contiguous, nearly equal shares over n_ranks ranks (the first mod(n, n_ranks)
  !> ranks one more): counts(r), offsets(r) for r = 0 .. n_ranks - 1, as MPI_Allgatherv takes them.
  pure subroutine even_shares(n, n_ranks, counts, offsets)
    integer, intent(in) :: n, n_ranks
    integer, allocatable, intent(out) :: counts(:), offsets(:)
    integer :: r
    allocate (counts(0:n_ranks - 1), offsets(0:n_ranks - 1))
    do r = 0, n_ranks - 1
      counts(r) = n / n_ranks + merge(1, 0, r < mod(n, n_ranks))
    end do
    offsets(0) = 0
    do r = 1, n_ranks - 1
      offsets(r) = offsets(r - 1) + counts(r - 1)
    end do
  end subroutine even_shares
end module beadmob_parallel
