!> The samples' bead moments as control variates of a continuum level's mean (docs/theory.md T18,
!> "Moment control"). Over uniformly random lattice offsets (and turns) the expected sum over the
!> nodes inside a body of any function, times d^3, is that function's integral over the body: the
!> mean volume, first and second moments of a level's bead models are the body's, known exactly.
!> Each sample's deviation of its moments from the body's is therefore a control variate with a
!> known mean, and regressing the samples' values on it removes the part of the offsets' scatter
!> that the moments explain, without moving what the level's mean estimates. The equivalent
!> ellipsoid's correction (continuum_job) already removes what an ellipsoid of those moments would
!> explain; the regression learns the body's own sensitivities, which serves bodies that are no
!> ellipsoid (a cross whose arms gain or lose a layer of beads with the offset).
!>
!> The regression is pooled over the levels (the sensitivities are the body's; a level's mean
!> differs from another's by a few per cent, so one absolute sensitivity serves all, and an entry
!> whose mean nears zero at some level stays well posed),
!> ridge-regularised over standardised features (turned or elongated bodies make the moments nearly
!> collinear), its ridge parameter, or no regression, chosen by the smallest leave-one-out error.
!> scripts/beadmob_post/continuum_bar.py (moment_control_shift) replays it.
module beadmob_moment_control
  use beadmob_kinds, only: dp
  use beadmob_lapack, only: dpotrf, dpotri
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  implicit none
  private
  public :: moment_features, body_moment_features, moment_control_shift, n_moment_features

  !> Volume, first moments (3), second moments (6 distinct).
  integer, parameter :: n_moment_features = 10
  !> A regression needs this many samples beyond the levels per feature (else none).
  integer, parameter :: samples_per_feature = 3
  !> The ridge parameters tried: 0 and 10^(-6 + j/4), j = 0..32, times the mean diagonal of the
  !> standardised features' Gram matrix.
  integer, parameter :: n_ridge = 34

contains

  !> Features of bead moments (volume, first 3, second 9 column-major about the origin:
  !> body_moments_t's order): the volume, the first and the six distinct second moments about the
  !> body's centroid c (each still a sum over the beads, so its mean over offsets is the body's),
  !> relative to the body's volume V and radius of gyration r (V, V r, V r^2); moments(13, S) ->
  !> features(10, S). About c they do not change when the body is moved.
  pure function moment_features(moments, body) result(features)
    real(dp), intent(in) :: moments(:, :), body(13)
    real(dp) :: features(n_moment_features, size(moments, 2))
    integer, parameter :: first_index(6) = [1, 2, 3, 1, 1, 2], second_index(6) = [1, 2, 3, 2, 3, 3]
    real(dp) :: volume, centroid(3), gyration2, body_second(3, 3), second
    integer :: i, j, q, s
    volume = body(1)
    centroid = body(2:4) / volume
    body_second = reshape(body(5:13), [3, 3])
    gyration2 = (body_second(1, 1) + body_second(2, 2) + body_second(3, 3) - volume * sum(centroid**2)) / volume / 3.0_dp
    features(1, :) = moments(1, :) / volume
    do i = 1, 3
      features(1 + i, :) = (moments(1 + i, :) - moments(1, :) * centroid(i)) / (volume * sqrt(gyration2))
    end do
    do q = 1, 6
      i = first_index(q)
      j = second_index(q)
      do s = 1, size(moments, 2)
        ! sum (x - c)_i (x - c)_j = S_ij - F_i c_j - c_i F_j + N c_i c_j
        second = moments(4 + i + 3 * (j - 1), s) - moments(1 + i, s) * centroid(j) - centroid(i) * moments(1 + j, s) + &
                 moments(1, s) * centroid(i) * centroid(j)
        features(4 + q, s) = second / (volume * gyration2)
      end do
    end do
  end function moment_features

  !> The body's own features (moment_features of its moments): where the fitted shift is evaluated.
  pure function body_moment_features(body) result(features)
    real(dp), intent(in) :: body(13)
    real(dp) :: features(n_moment_features)
    features = reshape(moment_features(reshape(body, [13, 1]), body), [n_moment_features])
  end function body_moment_features

  !> Each sample's shift, to subtract from its value (and its control's), and the factor on the
  !> level means' variances (the degrees of freedom the regression took), for every quantity at
  !> once. targets(T, S): each quantity known on every sample (the control, order L - 1, where there
  !> are control samples); level(S); features(10, S) and the body's (moment_features). Each target's
  !> deviations from their level's mean are regressed on the features' deviations from theirs,
  !> with its own ridge; the Gram matrix, its factors and the leverages of each ridge are the
  !> features' and serve every target (a fill decision weighs 6 quantities, a result 41 or more).
  pure subroutine moment_control_shift(targets, level, features, body_features, shifts, variance_factors)
    real(dp), intent(in) :: targets(:, :), features(:, :), body_features(:)
    integer, intent(in) :: level(:)
    real(dp), intent(out) :: shifts(size(targets, 1), size(targets, 2)), variance_factors(size(targets, 1))
    real(dp) :: centred(size(features, 1), size(targets, 2)), deviations(size(targets, 2), size(targets, 1))
    real(dp) :: feature_scale(size(features, 1)), beta(size(features, 1), size(targets, 1))
    real(dp) :: best_error(size(targets, 1)), parameters(size(targets, 1)), loo_error(size(targets, 1))
    real(dp), allocatable :: a(:, :), gram(:, :), inverse(:, :), leverage(:), coefficients(:, :), residuals(:, :)
    real(dp) :: unit, ridge, dof
    logical :: used(size(features, 1)), chosen(size(targets, 2)), regressed(size(targets, 1))
    logical :: finite(size(targets, 1)), better(size(targets, 1))
    integer :: s, p, k, levels, j, i, info, q, t

    s = size(targets, 2)
    shifts = 0.0_dp
    variance_factors = 1.0_dp
    centred = 0.0_dp
    deviations = 0.0_dp
    levels = 0
    do k = minval(level), maxval(level)
      chosen = level == k
      if (.not. any(chosen)) cycle
      levels = levels + 1
      do i = 1, size(features, 1)
        centred(i, :) = merge(features(i, :) - sum(features(i, :), mask=chosen) / count(chosen), centred(i, :), chosen)
      end do
      do t = 1, size(targets, 1)
        deviations(:, t) = merge(targets(t, :) - sum(targets(t, :), mask=chosen) / count(chosen), deviations(:, t), &
                                 chosen)
      end do
    end do
    if (s - levels < samples_per_feature * size(features, 1)) return
    ! A target with a non-finite value is not regressed (its columns kept out of the products).
    finite = [(all(ieee_is_finite(deviations(:, t))), t = 1, size(targets, 1))]
    do t = 1, size(targets, 1)
      if (.not. finite(t)) deviations(:, t) = 0.0_dp
    end do
    feature_scale = sqrt(sum(centred**2, dim=2) / s)
    used = feature_scale > 1e-14_dp * max(abs(body_features), 1.0_dp)
    p = count(used)
    if (p == 0) return
    allocate (a(s, p), gram(p, p), inverse(p, p), leverage(s), coefficients(p, size(targets, 1)), &
              residuals(s, size(targets, 1)))
    q = 0
    do i = 1, size(features, 1)
      if (.not. used(i)) cycle
      q = q + 1
      a(:, q) = centred(i, :) / feature_scale(i)
    end do
    gram = matmul(transpose(a), a)
    unit = sum([(gram(i, i), i = 1, p)]) / p
    best_error = sum(deviations**2, dim=1)   ! no regression
    regressed = .false.
    parameters = 0.0_dp
    beta = 0.0_dp
    do j = 1, n_ridge
      ridge = 0.0_dp
      if (j > 1) ridge = 10.0_dp**(-6.0_dp + 0.25_dp * (j - 2))
      inverse = gram
      do i = 1, p
        inverse(i, i) = inverse(i, i) + ridge * unit
      end do
      call dpotrf('L', p, inverse, p, info)
      if (info /= 0) cycle
      call dpotri('L', p, inverse, p, info)
      if (info /= 0) cycle
      do i = 1, p   ! dpotri fills the lower triangle
        inverse(i, i + 1:) = inverse(i + 1:, i)
      end do
      leverage = sum(matmul(a, inverse) * a, dim=2)
      if (any(1.0_dp - leverage < 1e-8_dp)) cycle
      ! Leave-one-out errors in closed form: residual / (1 - leverage).
      coefficients = matmul(inverse, matmul(transpose(a), deviations))
      residuals = deviations - matmul(a, coefficients)
      loo_error = sum((residuals / spread(1.0_dp - leverage, 2, size(targets, 1)))**2, dim=1)
      better = finite .and. loo_error < best_error
      where (better)
        best_error = loo_error
        parameters = sum(leverage)
      end where
      do t = 1, size(targets, 1)
        if (better(t)) beta(1:p, t) = coefficients(:, t)
      end do
      regressed = regressed .or. better
    end do
    dof = s - levels
    q = 0
    do i = 1, size(features, 1)
      if (.not. used(i)) cycle
      q = q + 1
      do t = 1, size(targets, 1)
        if (regressed(t)) shifts(t, :) = shifts(t, :) + (features(i, :) - body_features(i)) * beta(q, t) / feature_scale(i)
      end do
    end do
    where (regressed) variance_factors = dof / max(dof - parameters, 1.0_dp)
  end subroutine moment_control_shift

end module beadmob_moment_control
