!> Where the rest of a continuum job's time budget goes (docs/theory.md T18, "Filling the
!> budget"). A level's controlled mean has the variance var(y - x) / n + v_x / m (m samples, n of
!> them full; continuum_fit.f90), and with controls that follow the samples closely the second
!> part is nearly all of it (bench/continuum/nonconvex_rtol5.md: 10 to 100 times the first on a
!> bent rod). One more control sample on level k divides it by (m_k + 1) / m_k, for the seconds
!> one costs there: coarse levels are cheap and scatter most, the finest carry the extrapolation.
!> The next sample goes where it lowers the extrapolated values' variance most per second. The
!> levels' excess tau^2 of the fit is left out: estimated from the level means, it takes an
!> undersampled level's chance deviation for scatter no sample lowers, and would stop buying the
!> samples that show it is chance (bench/continuum/nonconvex_fill_moment_control.md).
module beadmob_continuum_fill
  use beadmob_kinds, only: dp
  use beadmob_continuum_fit, only: continuum_value_t, controlled_level_mean, extrapolate_to_zero, intercept_variance
  use beadmob_moment_control, only: moment_control_shift
  implicit none
  private
  public :: next_fill_level, total_intercept_variance, fill_variance_parts

contains

  !> The level (1..K) of the next control sample, or 0 when none may take one (its cost unknown,
  !> costs(k) <= 0; more than seconds_left; cap samples already) or none would lower the variance.
  !> paired(q, k) and per_control(q, k): the two parts of quantity q's variance on level k
  !> (controlled_variance_parts), each relative to the quantity's value squared, so that every
  !> quantity counts alike; counts(k): the level's samples m_k; costs(k): seconds per control sample.
  pure integer function next_fill_level(h, paired, per_control, counts, costs, seconds_left, cap) result(best)
    real(dp), intent(in) :: h(:), paired(:, :), per_control(:, :), costs(:), seconds_left
    integer, intent(in) :: counts(:), cap
    real(dp) :: now, gain, best_gain
    integer :: k, more(size(h))
    best = 0
    best_gain = 0.0_dp
    now = total_intercept_variance(h, paired, per_control, counts)
    do k = 1, size(h)
      if (costs(k) <= 0.0_dp .or. costs(k) > seconds_left .or. counts(k) >= cap) cycle
      more = counts
      more(k) = more(k) + 1
      gain = (now - total_intercept_variance(h, paired, per_control, more)) / costs(k)
      if (gain > best_gain) then
        best = k
        best_gain = gain
      end if
    end do
  end function next_fill_level

  !> Sum over the quantities q of the variance of the quadratic's intercept (intercept_variance)
  !> with level variances paired(q, k) + per_control(q, k) / counts(k).
  pure real(dp) function total_intercept_variance(h, paired, per_control, counts) result(total)
    real(dp), intent(in) :: h(:), paired(:, :), per_control(:, :)
    integer, intent(in) :: counts(:)
    integer :: q
    total = 0.0_dp
    do q = 1, size(paired, 1)
      total = total + intercept_variance(h, sqrt(paired(q, :) + per_control(q, :) / counts))
    end do
  end function total_intercept_variance

  !> The quantities' variance parts on every level as the job's level means form them
  !> (continuum_values): y(T, S) their order-L values (read on full samples only), x(T, S) their
  !> order L - 1 controls, full(S), level(S) in 1..K; with use_moments the moment control's shift
  !> subtracted from both and its variance factor on both parts (features(10, S),
  !> body_features(10): moment_features). paired(T, K), per_control(T, K), each quantity's
  !> relative to its extrapolated value squared.
  pure subroutine fill_variance_parts(h, y, x, full, level, features, body_features, use_moments, paired, per_control)
    real(dp), intent(in) :: h(:), y(:, :), x(:, :), features(:, :), body_features(:)
    logical, intent(in) :: full(:), use_moments
    integer, intent(in) :: level(:)
    real(dp), intent(out) :: paired(size(y, 1), size(h)), per_control(size(y, 1), size(h))
    real(dp) :: shift(size(y, 1), size(y, 2)), factor(size(y, 1)), means(size(h)), errors(size(h))
    type(continuum_value_t) :: fit
    logical :: on_level(size(y, 2))
    integer :: k, q
    shift = 0.0_dp
    factor = 1.0_dp
    if (use_moments) call moment_control_shift(x, level, features, body_features, shift, factor)
    do q = 1, size(y, 1)
      associate (yq => y(q, :) - shift(q, :), xq => x(q, :) - shift(q, :))
        do k = 1, size(h)
          on_level = level == k
          call controlled_level_mean(pack(yq, on_level .and. full), pack(xq, on_level .and. full), pack(xq, on_level), &
                                     means(k), errors(k), paired(q, k), per_control(q, k))
        end do
      end associate
      fit = extrapolate_to_zero(h, means, errors * sqrt(factor(q)), 0.0_dp)
      paired(q, :) = factor(q) * paired(q, :) / fit%value**2
      per_control(q, :) = factor(q) * per_control(q, :) / fit%value**2
    end do
  end subroutine fill_variance_parts
end module beadmob_continuum_fill
