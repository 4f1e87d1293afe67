!> What the moment control costs a continuum job's bookkeeping (docs/theory.md T18, "Filling the
!> budget"): a fill decision weighs 6 quantities (fill_variance_parts), a result forms 41 (the 36
!> mobility entries and 5 coefficients; a flow job 115 more). moment_control_shift regresses all
!> of them at once, sharing the Gram matrix, its factors and the leverages of each of its 34 ridge
!> parameters; one quantity per call, as until 2026-11-29, refactors them for each. Both ways are
!> timed here side by side in one process on synthetic samples (7 levels, one sample in four
!> full, moments that explain part of the scatter), as the median of 9 timings of 20 repetitions.
!> Usage: build/bench/moment_control_cost > bench/continuum/moment_control_cost.md
module moment_control_cost_timing
  use beadmob_kinds, only: dp
  use beadmob_continuum_fill, only: fill_variance_parts
  use beadmob_moment_control, only: moment_control_shift
  implicit none
  private
  public :: time_both
  integer, parameter :: levels = 7, repetitions = 20, timings = 9

contains

  subroutine time_both(n, quantities)
    integer, intent(in) :: n, quantities
    real(dp) :: features(10, n), x(quantities, n), y(quantities, n), h(levels), body(10), r
    real(dp) :: paired(quantities, levels), per_control(quantities, levels), shifts(quantities, n), factors(quantities)
    real(dp) :: seconds(timings, 2), started, finished
    logical :: full(n)
    integer :: level(n), s, q, k, rep, way
    h = [(0.1_dp * 2.0_dp**(-k / 3.0_dp), k = 0, levels - 1)]
    body = 0.5_dp
    do s = 1, n
      level(s) = modulo(s, levels) + 1
      full(s) = modulo(s, 4) == 1
      do k = 1, 10
        call random_number(r)
        features(k, s) = r
      end do
      do q = 1, quantities
        call random_number(r)
        x(q, s) = 1.0_dp + 0.1_dp * h(level(s)) + 0.01_dp * q * features(modulo(q, 10) + 1, s) + 1.0e-3_dp * r
      end do
    end do
    y = x
    ! way 1: one quantity per call; way 2: all at once. Alternated, so that both see the same load.
    do k = 1, timings
      do way = 1, 2
        call cpu_time(started)
        do rep = 1, repetitions
          if (way == 2) then
            call work(1, quantities)
          else
            do q = 1, quantities
              call work(q, q)
            end do
          end if
        end do
        call cpu_time(finished)
        seconds(k, way) = (finished - started) / repetitions
      end do
    end do
    print '("| ", i0, " | ", i0, " | ", a, " | ", f0.3, " | ", f0.3, " | ", f0.2, " |")', n, quantities, &
      merge('fill decision  ', 'result''s shifts', quantities == 6), 1.0e3_dp * median(seconds(:, 1)), &
      1.0e3_dp * median(seconds(:, 2)), median(seconds(:, 1)) / median(seconds(:, 2))

  contains

    !> A fill decision's variance parts (6 quantities) or a result's moment shifts (41), of the
    !> quantities first..last in one call.
    subroutine work(first, last)
      integer, intent(in) :: first, last
      if (quantities == 6) then
        call fill_variance_parts(h, y(first:last, :), x(first:last, :), full, level, features, body, .true., &
                                 paired(first:last, :), per_control(first:last, :))
      else
        call moment_control_shift(x(first:last, :), level, features, body, shifts(first:last, :), factors(first:last))
      end if
    end subroutine work
  end subroutine time_both

  real(dp) function median(values)
    real(dp), intent(in) :: values(:)
    real(dp) :: sorted(size(values)), swap
    integer :: i, j
    sorted = values
    do i = 2, size(sorted)
      do j = i, 2, -1
        if (sorted(j - 1) <= sorted(j)) exit
        swap = sorted(j)
        sorted(j) = sorted(j - 1)
        sorted(j - 1) = swap
      end do
    end do
    median = sorted((size(sorted) + 1) / 2)
  end function median

end module moment_control_cost_timing

program moment_control_cost
  use moment_control_cost_timing, only: time_both
  implicit none
  integer, parameter :: sample_counts(3) = [100, 300, 1000], quantity_counts(2) = [6, 41]
  integer :: i, j

  print '(a)', '# The moment control per quantity and for all quantities at once'
  print '(a)', ''
  print '(a)', 'Written by `build/bench/moment_control_cost` (bench/continuum/moment_control_cost.f90); ms per call,'
  print '(a)', 'median of 9 timings of 20 repetitions, one process on this machine.'
  print '(a)', ''
  print '(a)', '| samples | quantities | what | one quantity per call (ms) | all at once (ms) | ratio |'
  print '(a)', '|---|---|---|---|---|---|'
  do i = 1, size(sample_counts)
    do j = 1, size(quantity_counts)
      call time_both(sample_counts(i), quantity_counts(j))
    end do
  end do

end program moment_control_cost
