!> The FFT operator's kernel spectrum from one octant of displacements (theory.md T4, "The
!> kernel's transform"). Each lattice mirror M_a (axis a) maps the basis onto ± itself, D_a
!> diagonal (find_mirror_signs), so every kernel entry K_st(d) is even or odd in each component
!> d_a: K_st(M_a d) = q_a K_st(d), q_a = D_a(s) D_a(t). Along an axis of n sites the DFT of an
!> even line is real and that of an odd line imaginary, both fixed by its n/2 + 1 values
!> d_a = 0 .. n/2, and the spectrum has the same parity in k_a. So the three passes of the 3-D
!> transform each run on the octant (n_a/2 + 1 points per axis), each line extended to its n
!> sites by its parity and transformed by a real FFT, keeping the real or imaginary part; after
!> the three axes the entry is i^m times the value, m the number of odd axes. The entries are
!> independent: each rank transforms its own share of them over the whole octant, and one
!> all-to-all per round gives every rank all entries at its own spectrum lines. Against the
!> whole box split over the ranks: an eighth of the sites formed and transformed, and no
!> transposes.
module beadmob_kernel_spectrum
  use, intrinsic :: iso_c_binding
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_fftw
  use beadmob_progress, only: progress_line, progress_seconds
  use beadmob_block_table, only: block_table_t, entry_terms_t, make_entry_terms, entries_by_terms
  use beadmob_lattice_symmetry, only: canonical_displacement
  use beadmob_counting_sort, only: counting_sort
  use mpi, only: MPI_Allgather, MPI_Allreduce, MPI_Alltoallv, MPI_Comm_rank, MPI_Comm_size, MPI_IN_PLACE, &
                 MPI_INTEGER, MPI_INTEGER8, MPI_DOUBLE_PRECISION, MPI_MIN, MPI_MAX, MPI_Wtime
  implicit none
  private
  public :: kernel_octant_t, kernel_spectrum

  !> What the kernel's spectrum is: its box, the lattice axis of each FFT dimension, and its
  !> packed entries (the unknowns of entry e are row(e), column(e); parity(e, a) its parity
  !> along FFT dimension a).
  type :: kernel_octant_t
    integer :: box(3) = 1                  ! padded sizes: fast, middle, slow
    integer :: axes(3) = [1, 2, 3]         ! lattice axis of each FFT dimension
    integer(C_INTPTR_T) :: first_line = 0, lines = 0   ! this rank's middle-axis frequencies
    integer, allocatable :: row(:), column(:)
    integer, allocatable :: parity(:, :)   ! (entries, 3): +1 even, -1 odd
  end type kernel_octant_t

  !> Lines transformed by one FFTW call.
  integer, parameter :: chunk_lines = 256
  !> Entries per rank and round at most.
  integer, parameter :: max_round_entries = 16
  !> Doubles of scratch the transform allocates for itself when the one it is given holds fewer
  !> entries per round (64 MiB).
  integer(i8), parameter :: own_scratch_doubles = 8388608_i8

contains

  !> Collective. kernel(e, g) = scale * (the real part of K^_e, or for an entry odd under
  !> inversion the imaginary part) at this rank's frequencies g ([lines][k_slow <= n_slow/2]
  !> [k_fast <= n_fast/2], the fast index first), from the compact block table. `scratch`: memory
  !> the rounds may use (the operator's FFT buffer, not yet needed); a scratch of its own (up to
  !> 64 MiB, or one entry per rank) where that holds more entries per round. reporting (rank 0):
  !> a progress line about every quarter of the entries, timed from `start` (MPI_Wtime).
  subroutine kernel_spectrum(comm, table, octant, scale, scratch, kernel, err, reporting, start)
    integer, intent(in) :: comm
    type(block_table_t), intent(in) :: table
    type(kernel_octant_t), intent(in) :: octant
    real(dp), intent(in) :: scale
    real(dp), intent(inout), target, contiguous :: scratch(:)
    real(dp), intent(out) :: kernel(:, :)
    type(error_t), intent(inout) :: err
    logical, intent(in) :: reporting
    real(dp), intent(in) :: start
    integer :: m(3), n_entries, n_ranks, rank, per_rank, round, n_rounds, mine, first_mine, q, ierr, count_q, first_q, b, &
               failed, done, wanted
    integer(i8) :: points, kept, per_entry, g, offset, count_limit
    integer(C_INTPTR_T) :: my_lines(2)
    integer(C_INTPTR_T), allocatable :: all_lines(:, :)
    integer, allocatable :: send_counts(:), send_offsets(:), receive_counts(:), receive_offsets(:)
    real(dp), allocatable :: factor(:)
    real(dp), allocatable, target :: own_scratch(:)
    real(dp), pointer, contiguous :: values(:, :), sent(:), received(:), room(:)
    integer(i8), allocatable :: by_block(:)
    integer, allocatable :: block_of(:), symmetry_of(:)

    call MPI_Comm_size(comm, n_ranks, ierr)
    call MPI_Comm_rank(comm, rank, ierr)
    m = octant%box / 2 + 1
    points = product(int(m, i8))
    n_entries = size(octant%row)
    kept = int(m(3), i8) * m(1)   ! values of one middle-axis line
    my_lines = [octant%first_line, octant%lines]
    allocate (all_lines(2, 0:n_ranks - 1))
    call MPI_Allgather(my_lines, 2, MPI_INTEGER8, all_lines, 2, MPI_INTEGER8, comm, ierr)
    ! Agreed on by the ranks: every rank leaves, or none.
    failed = merge(1, 0, size(kernel, 2) /= octant%lines * kept .and. octant%lines > 0)
    call MPI_Allreduce(MPI_IN_PLACE, failed, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
    if (failed /= 0) then
      call raise(err, 'internal error: the FFT kernel is not sized for its spectrum lines on some rank')
      return
    end if
    ! Doubles per entry a rank holds in a round: its octant values, what it sends (every rank's
    ! lines) and what it receives (its lines, from every rank).
    per_entry = points + octant%box(2) * kept + n_ranks * octant%lines * kept
    per_rank = int(min(int(max_round_entries, i8), size(scratch, kind=i8) / per_entry))
    ! Fewer, larger rounds where a small scratch of its own does it: each round costs an
    ! all-to-all and a pass of plans (ring_1mm: 17 rounds in its FFT buffer, 5 in 64 MiB).
    wanted = int(min(int(max_round_entries, i8), own_scratch_doubles / per_entry))
    ! MPI counts and offsets are default integers.
    count_limit = int(huge(1), i8) / (max(int(octant%box(2), i8), n_ranks * octant%lines) * kept)
    per_rank = int(min(int(per_rank, i8), count_limit))
    wanted = int(min(int(wanted, i8), count_limit))
    call MPI_Allreduce(MPI_IN_PLACE, per_rank, 1, MPI_INTEGER, MPI_MIN, comm, ierr)
    call MPI_Allreduce(MPI_IN_PLACE, wanted, 1, MPI_INTEGER, MPI_MIN, comm, ierr)
    room => scratch
    wanted = max(wanted, 1)
    if (per_rank < wanted) then
      allocate (own_scratch(per_entry * wanted), stat=failed)
      call MPI_Allreduce(MPI_IN_PLACE, failed, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
      if (failed == 0) then
        per_rank = wanted
        room => own_scratch
      else if (per_rank < 1) then
        call raise(err, 'could not allocate the FFT kernel''s scratch (' // str(8.0_dp * per_entry * wanted / 1.0e9_dp) // &
                   ' GB per rank)')
        return
      else if (allocated(own_scratch)) then   ! not on every rank: the given scratch it is
        deallocate (own_scratch)
      end if
    end if
    ! The entries of a round side by side at each point: every pass reads and writes them together.
    values(1:per_rank, 1:points) => room(1:points * per_rank)
    sent => room(points * per_rank + 1:(points + octant%box(2) * kept) * per_rank)
    received => room((points + octant%box(2) * kept) * per_rank + 1:per_entry * per_rank)
    allocate (send_counts(0:n_ranks - 1), send_offsets(0:n_ranks - 1), receive_counts(0:n_ranks - 1), &
              receive_offsets(0:n_ranks - 1), factor(per_rank))

    n_rounds = (n_entries - 1) / (per_rank * n_ranks) + 1
    call order_by_block(table, octant, by_block, block_of, symmetry_of)
    do round = 0, n_rounds - 1
      first_mine = round * per_rank * n_ranks + rank * per_rank + 1
      mine = max(0, min(per_rank, n_entries - first_mine + 1))
      if (mine > 0) then
        call fill_octant(table, octant, first_mine, mine, by_block, block_of, symmetry_of, values)
        call transform_octant(octant, octant%parity(first_mine:first_mine + mine - 1, :), values)
      end if
      ! To each rank its lines of my entries ([line][k_slow][k_fast][entry]); from each rank its
      ! entries at my lines, written into the kernel frequency by frequency.
      do q = 0, n_ranks - 1
        send_counts(q) = int(mine * all_lines(2, q) * kept)
        receive_counts(q) = int(entries_of(q) * octant%lines * kept)
      end do
      send_offsets(0) = 0
      receive_offsets(0) = 0
      do q = 1, n_ranks - 1
        send_offsets(q) = send_offsets(q - 1) + send_counts(q - 1)
        receive_offsets(q) = receive_offsets(q - 1) + receive_counts(q - 1)
      end do
      do q = 0, n_ranks - 1
        call pack_lines(octant, all_lines(:, q), first_mine, mine, values, sent(send_offsets(q) + 1:))
      end do
      call MPI_Alltoallv(sent, send_counts, send_offsets, MPI_DOUBLE_PRECISION, received, receive_counts, &
                         receive_offsets, MPI_DOUBLE_PRECISION, comm, ierr)
      do q = 0, n_ranks - 1
        count_q = entries_of(q)
        if (count_q == 0) cycle
        first_q = round * per_rank * n_ranks + q * per_rank + 1
        do b = 1, count_q
          factor(b) = scale * final_sign(octant%parity(first_q + b - 1, :))
        end do
        offset = receive_offsets(q)
        do g = 1, octant%lines * kept
          kernel(first_q:first_q + count_q - 1, g) = factor(1:count_q) * received(offset + 1:offset + count_q)
          offset = offset + count_q
        end do
      end do
      done = min((round + 1) * per_rank * n_ranks, n_entries)
      call progress_line(reporting .and. 4 * done / n_entries /= 4 * (done - per_rank * n_ranks) / n_entries, &
                         'FFT kernel: ' // str(done) // ' of ' // str(n_entries) // ' entries transformed (' // &
                         progress_seconds(MPI_Wtime() - start) // ' s)')
    end do

  contains

    !> The entries rank q transforms in this round.
    integer function entries_of(q)
      integer, intent(in) :: q
      entries_of = max(0, min(per_rank, n_entries - (round * per_rank * n_ranks + q * per_rank)))
    end function entries_of
  end subroutine kernel_spectrum

  !> The octant's points (1-based, fast index first) in the order of their canonical blocks
  !> (block_of(p), 0 for d = 0 and beyond the span; symmetry_of(p) the lattice symmetry that makes
  !> p of its block), so that filling reads each block once per round while it is in cache for
  !> every point it serves: in the octant's own order the blocks come in no order, and reading them
  !> was most of the kernel's set-up (the 1e6-bead sphere: 10 of its 20 s).
  subroutine order_by_block(table, octant, by_block, block_of, symmetry_of)
    type(block_table_t), intent(in) :: table
    type(kernel_octant_t), intent(in) :: octant
    integer(i8), allocatable, intent(out) :: by_block(:)
    integer, allocatable, intent(out) :: block_of(:), symmetry_of(:)
    integer :: m(3), i, j, k, d(3), c(3), s, n_blocks
    integer(i8) :: p, points
    integer(i8), allocatable :: starts(:)
    m = octant%box / 2 + 1
    points = product(int(m, i8))
    n_blocks = size(table%canonical_blocks, 3)
    allocate (by_block(points), block_of(points), symmetry_of(points), starts(0:n_blocks + 1))
    p = 0
    do k = 0, m(3) - 1
      do j = 0, m(2) - 1
        do i = 0, m(1) - 1
          p = p + 1
          d(octant%axes) = [i, j, k]
          block_of(p) = 0
          symmetry_of(p) = 1
          if (any(d > table%span) .or. all(d == 0)) cycle
          call canonical_displacement(d, c, s)
          block_of(p) = table%canonical_id(c(1), c(2), c(3))
          symmetry_of(p) = s
        end do
      end do
    end do
    call counting_sort(block_of, n_blocks, by_block, starts)
  end subroutine order_by_block

  !> values(b, p) = entry first + b - 1 of the lattice block at octant point p (zero at d = 0 and
  !> beyond the span), the points in the order of their blocks (order_by_block).
  subroutine fill_octant(table, octant, first, count, by_block, block_of, symmetry_of, values)
    type(block_table_t), intent(in) :: table
    type(kernel_octant_t), intent(in) :: octant
    integer, intent(in) :: first, count, block_of(:), symmetry_of(:)
    integer(i8), intent(in) :: by_block(:)
    real(dp), intent(out) :: values(:, :)
    integer(i8) :: q, p
    type(entry_terms_t) :: terms
    call make_entry_terms(table, octant%row(first:first + count - 1), octant%column(first:first + count - 1), terms)
    do q = 1, size(by_block, kind=i8)
      p = by_block(q)
      if (block_of(p) == 0) then
        values(1:count, p) = 0.0_dp
      else
        call entries_by_terms(terms, symmetry_of(p), table%canonical_blocks(:, :, block_of(p)), values(1:count, p))
      end if
    end do
  end subroutine fill_octant

  !> The entries' octant values -> their spectrum on the octant of frequencies, axis by axis:
  !> each line extended to the n sites of its axis by its entry's parity (parity(b, axis)), a
  !> real FFT, and the real (even) or imaginary (odd) part of frequencies 0 .. n/2 kept in its place.
  !> A chunk holds whole spatial lines, the `count` entries of each side by side, so that every
  !> point's entries are read and written together (they are adjacent in values).
  subroutine transform_octant(octant, parity, values)
    type(kernel_octant_t), intent(in) :: octant
    integer, intent(in) :: parity(:, :)
    real(dp), intent(inout) :: values(:, 0:)
    integer :: m(3), a, n, j, b, count, per_chunk, in_chunk, c0, l
    integer(i8) :: stride, lines, line, first(chunk_lines), point
    type(C_PTR) :: plan, line_memory, spectrum_memory
    real(C_DOUBLE), pointer :: extended(:, :)
    complex(C_DOUBLE_COMPLEX), pointer :: spectrum(:, :)
    type(fftw_iodim) :: dims(1), many(1)

    m = octant%box / 2 + 1
    count = size(parity, 1)
    per_chunk = max(chunk_lines / count, 1)   ! spatial lines per FFTW call
    do a = 1, 3
      n = octant%box(a)
      stride = product(int(m(1:a - 1), i8))
      lines = product(int(m, i8)) / m(a)
      line_memory = fftw_alloc_real(int(n, C_SIZE_T) * per_chunk * count)
      spectrum_memory = fftw_alloc_real(2_C_SIZE_T * (n / 2 + 1) * per_chunk * count)
      call c_f_pointer(line_memory, extended, [n, per_chunk * count])
      call c_f_pointer(spectrum_memory, spectrum, [n / 2 + 1, per_chunk * count])
      dims(1) = fftw_iodim(n, 1, 1)
      many(1) = fftw_iodim(per_chunk * count, n, n / 2 + 1)
      plan = fftw_plan_guru_dft_r2c(1, dims, 1, many, line_memory, spectrum_memory, FFTW_ESTIMATE)
      extended = 0.0_dp   ! a short last chunk transforms columns it does not read back
      in_chunk = 0
      do line = 0, lines - 1
        in_chunk = in_chunk + 1
        ! The line's first point: (inner, outer) around axis a.
        first(in_chunk) = mod(line, stride) + (line / stride) * stride * m(a)
        c0 = (in_chunk - 1) * count
        do j = 0, m(a) - 1
          point = first(in_chunk) + j * stride
          extended(j + 1, c0 + 1:c0 + count) = values(1:count, point)
        end do
        do b = 1, count
          do j = m(a), n - 1
            extended(j + 1, c0 + b) = parity(b, a) * extended(n - j + 1, c0 + b)
          end do
        end do
        if (in_chunk == per_chunk .or. line == lines - 1) then
          call fftw_execute(plan)
          do l = 1, in_chunk
            c0 = (l - 1) * count
            do j = 0, m(a) - 1
              point = first(l) + j * stride
              do b = 1, count
                if (parity(b, a) > 0) then
                  values(b, point) = real(spectrum(j + 1, c0 + b), dp)
                else
                  values(b, point) = aimag(spectrum(j + 1, c0 + b))
                end if
              end do
            end do
          end do
          in_chunk = 0
        end if
      end do
      call fftw_destroy_plan(plan)
      call fftw_free(line_memory)
      call fftw_free(spectrum_memory)
    end do
  end subroutine transform_octant

  !> sent <- the spectrum of `count` entries (first ...) at the lines (first, count) = line_range
  !> of one rank, [line][k_slow][k_fast][entry]; a line k > n/2 is the mirror of n - k times the
  !> entry's middle-axis parity.
  subroutine pack_lines(octant, line_range, first, count, values, sent)
    type(kernel_octant_t), intent(in) :: octant
    integer(C_INTPTR_T), intent(in) :: line_range(2)
    integer, intent(in) :: first, count
    real(dp), intent(in) :: values(:, :)
    real(dp), intent(out) :: sent(:)
    integer :: m(3), slow, fast, k_middle, source
    integer(i8) :: line, next, from
    real(dp) :: signs(count)
    m = octant%box / 2 + 1
    next = 0
    do line = 0, line_range(2) - 1
      k_middle = int(line_range(1) + line)
      source = min(k_middle, octant%box(2) - k_middle)
      signs = 1.0_dp
      if (k_middle > octant%box(2) / 2) signs = octant%parity(first:first + count - 1, 2)
      do slow = 0, m(3) - 1
        from = int(m(1), i8) * (source + int(m(2), i8) * slow)
        do fast = 1, m(1)
          sent(next + 1:next + count) = signs * values(1:count, from + fast)
          next = next + count
        end do
      end do
    end do
  end subroutine pack_lines

  !> K^ = i^m v for m odd axes: its real part (m even) or imaginary part (m odd) is v for m = 0, 1
  !> and -v for m = 2, 3.
  pure real(dp) function final_sign(parity)
    integer, intent(in) :: parity(:)   ! assumed shape: a row of octant%parity is passed without a copy
    final_sign = merge(1.0_dp, -1.0_dp, count(parity < 0) < 2)
  end function final_sign
end module beadmob_kernel_spectrum
