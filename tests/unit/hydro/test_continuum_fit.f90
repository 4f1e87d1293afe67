!> Tests src/hydro/ellipsoid_friction.f90 and src/hydro/continuum_fit.f90.
!> CTest: test_continuum_fit_np1 and test_continuum_fit_np2.
!> Carlson's integrals against his published test values (B. C. Carlson, "Numerical computation
!> of real or complex elliptic integrals", Numer. Algorithms 10 (1995) 13-26, section 3), the
!> ellipsoid friction against the sphere (Stokes: 6 pi a, 8 pi a^3) and the prolate spheroid's
!> closed forms (Happel & Brenner 1965, sec. 4-30; Kim & Karrila 1991, table 3.4), turned into
!> another frame; the extrapolation recovers a quadratic exactly and bounds a noisy one, and two
!> levels whose offsets all gave the same beads (zero scatter) do not pin it. fill_budget's choice
!> (src/hydro/continuum_fill.f90) against the variance of an interpolating quadratic's value at 0,
!> sum_k a_k^2 s_k^2 with the Lagrange weights a_k = prod_{j /= k} h_j / (h_j - h_k); the fill's
!> level variances with the moment control: a scatter the moments explain is not seen.
program test_continuum_fit
  use beadmob_kinds, only: dp
  use beadmob_testing, only: test_suite_t, start_tests, finish_tests, check, check_close
  use beadmob_ellipsoid_friction, only: ellipsoid_friction, carlson_rf, carlson_rd
  use beadmob_continuum_fit, only: continuum_value_t, extrapolate_to_zero, level_mean, controlled_level_mean, &
                                   intercept_variance
  use beadmob_continuum_fill, only: next_fill_level, fill_variance_parts
  implicit none
  real(dp), parameter :: pi = acos(-1.0_dp)
  type(test_suite_t) :: suite
  type(continuum_value_t) :: fit
  real(dp) :: friction(6, 6), identity(3, 3), rotation(3, 3), a, b, e, l, axial, transverse, h(5), y(5), se(5)
  real(dp) :: mean, error, h7(7), y7(7), se7(7), h3(3), per_control(1, 3)
  type(continuum_value_t) :: shared_scatter
  integer :: k
  integer, parameter :: n_fill = 48
  real(dp) :: features(10, n_fill), x_fill(n_fill), paired3(1, 3), per_control3(1, 3), level_means(3), level_errors(3)
  logical :: full_fill(n_fill)
  integer :: level_fill(n_fill), s, j

  suite = start_tests('test_continuum_fit')
  call check_close(suite, carlson_rf(1.0_dp, 2.0_dp, 0.0_dp), 1.3110287771461_dp, 1.0e-12_dp, 'R_F(1, 2, 0)')
  call check_close(suite, carlson_rf(2.0_dp, 3.0_dp, 4.0_dp), 0.58408284167715_dp, 1.0e-12_dp, 'R_F(2, 3, 4)')
  call check_close(suite, carlson_rd(0.0_dp, 2.0_dp, 1.0_dp), 1.7972103521034_dp, 1.0e-12_dp, 'R_D(0, 2, 1)')
  call check_close(suite, carlson_rd(2.0_dp, 3.0_dp, 4.0_dp), 0.16510527294261_dp, 1.0e-12_dp, 'R_D(2, 3, 4)')

  identity = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], [3, 3])
  friction = ellipsoid_friction([2.5_dp, 2.5_dp, 2.5_dp], identity)
  do k = 1, 3
    call check_close(suite, friction(k, k), 6.0_dp * pi * 2.5_dp, 1.0e-12_dp, 'sphere: translation 6 pi a')
    call check_close(suite, friction(k + 3, k + 3), 8.0_dp * pi * 2.5_dp**3, 1.0e-12_dp, 'sphere: rotation 8 pi a^3')
  end do
  call check(suite, maxval(abs(friction(1:3, 4:6))) == 0.0_dp, 'sphere: no coupling')

  ! Prolate spheroid, semi-axes a > b = b along x: eccentricity e, L = ln((1 + e) / (1 - e)).
  a = 4.0_dp
  b = 1.5_dp
  e = sqrt(1.0_dp - (b / a)**2)
  l = log((1.0_dp + e) / (1.0_dp - e))
  axial = 16.0_dp * pi * a * e**3 / ((1.0_dp + e**2) * l - 2.0_dp * e)
  transverse = 32.0_dp * pi * a * e**3 / (2.0_dp * e + (3.0_dp * e**2 - 1.0_dp) * l)
  ! The same body with its long axis along z (a rotation about y by 90 degrees).
  rotation = reshape([0.0_dp, 0.0_dp, -1.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp], [3, 3])
  friction = ellipsoid_friction([a, b, b], rotation)
  call check_close(suite, friction(3, 3), axial, 1.0e-12_dp, 'prolate: axial translation (long axis turned to z)')
  call check_close(suite, friction(1, 1), transverse, 1.0e-12_dp, 'prolate: transverse translation')
  call check(suite, abs(friction(1, 3)) < 1.0e-12_dp * axial, 'prolate: principal frame kept')

  ! A quadratic in h is its own continuum limit; the error bar is at rounding.
  h = [0.1_dp, 0.125_dp, 0.16_dp, 0.2_dp, 0.25_dp]
  y = 2.0_dp + 3.0_dp * h - 5.0_dp * h**2
  se = 1.0e-3_dp
  fit = extrapolate_to_zero(h, y, se, 0.0_dp)
  call check_close(suite, fit%value, 2.0_dp, 1.0e-12_dp, 'quadratic: intercept')
  call check_close(suite, fit%slope, 3.0_dp, 1.0e-9_dp, 'quadratic: slope')
  call check(suite, abs(fit%reduced_value - 2.0_dp) < 1.0e-12_dp, 'quadratic: the reduced fit agrees')
  ! Five levels foresee the h^3 term as c^2 / b times the quadratic's intercept of h^3: (25 / 3)
  ! 4.5353e-3 (numpy.linalg.lstsq of h^3 on [1, h, h^2]: 0.037794229503904826), below the line's
  ! distance 0.0825 (numpy.polyfit of the three finest levels), which only caps it.
  call check_close(suite, fit%next_term, 0.037794229503904826_dp, 1.0e-9_dp, 'quadratic: the foreseen h^3 term')
  call check(suite, fit%error >= fit%next_term .and. fit%next_term < abs(fit%linear_value - 2.0_dp), &
             'quadratic: the error bar holds the foreseen h^3 term, below the line''s distance')
  ! Four levels foresee nothing: the line's distance is the model spread.
  fit = extrapolate_to_zero(h(1:4), y(1:4), se(1:4), 0.0_dp)
  call check(suite, fit%next_term == huge(1.0_dp) .and. fit%error >= abs(fit%linear_value - 2.0_dp) .and. &
             abs(fit%linear_value - 2.0_dp) > 1.0e-3_dp, 'quadratic, 4 levels: the error bar holds the line''s distance')
  ! Noise of +-se around a cubic: the bar must hold the truth (2) and stay of the noise's size.
  y = 2.0_dp + 3.0_dp * h - 5.0_dp * h**2 + 4.0_dp * h**3 + 1.0e-3_dp * [1.0_dp, -1.0_dp, 0.5_dp, 1.0_dp, -0.5_dp]
  fit = extrapolate_to_zero(h, y, se, 0.0_dp)
  call check(suite, abs(fit%value - 2.0_dp) <= fit%error, 'noisy cubic: the error bar holds the truth')
  call check(suite, fit%error < 0.1_dp, 'noisy cubic: the error bar is of the noise''s size')
  ! Seven levels scattering +-4e-3 about a quadratic whose offsets' standard errors say 1e-3, two of
  ! them with zero scatter (a lattice resonance: every offset the same beads). With the excess
  ! variance shared by all levels (random effects) those two weigh as the others: the fit moves by
  ! a small part of its bar, where weights 1 / s_k^2 alone (floored at a fifth of the median s_k)
  ! would weigh them 25 times as much and move the intercept by 0.028, a third of the bar.
  h7 = 0.1_dp * 2.0_dp**([(k, k = 0, 6)] / 3.0_dp)
  y7 = 2.0_dp + 3.0_dp * h7 - 5.0_dp * h7**2 + 1.0e-3_dp * [2.0_dp, -3.0_dp, 4.0_dp, -2.0_dp, 3.0_dp, -4.0_dp, 2.0_dp]
  se7 = 1.0e-3_dp
  shared_scatter = extrapolate_to_zero(h7, y7, se7, 0.0_dp)
  se7(2:3) = 0.0_dp
  fit = extrapolate_to_zero(h7, y7, se7, 0.0_dp)
  call check(suite, abs(fit%value - 2.0_dp) <= fit%error, 'resonant levels: the error bar holds the truth')
  call check(suite, abs(fit%value - shared_scatter%value) < 0.01_dp * shared_scatter%error, &
             'resonant levels: two zero-scatter levels do not pin the fit')
  call check(suite, abs(fit%error / shared_scatter%error - 1.0_dp) < 0.05_dp, &
             'resonant levels: nor do they shrink the bar')
  ! A geometric series 2 / (1 - h) = 2 (1 + h + h^2 + h^3 + ...) on seven levels up to h = 0.4:
  ! the quadratic misses its h^3 and higher terms; the foreseen h^3 term (c^2 / b of the fitted
  ! b, c) must not fall short of that miss, nor the bar of the truth.
  fit = extrapolate_to_zero(h7, 2.0_dp / (1.0_dp - h7), [(1.0e-6_dp, k = 1, 7)], 0.0_dp)
  call check(suite, fit%next_term >= abs(fit%value - 2.0_dp) .and. abs(fit%value - 2.0_dp) <= fit%error, &
             'geometric series: the foreseen h^3 term and the error bar hold the truth')
  ! An entry that symmetry makes zero in every sample: value and bar 0, no overflow of its weights.
  fit = extrapolate_to_zero(h7, [(0.0_dp, k = 1, 7)], [(0.0_dp, k = 1, 7)], 0.0_dp)
  call check(suite, fit%value == 0.0_dp .and. fit%error < 1.0e-100_dp, 'vanishing entry: value and bar 0')
  call level_mean([1.0_dp, 2.0_dp, 3.0_dp, 4.0_dp], mean, error)
  call check_close(suite, mean, 2.5_dp, 1.0e-15_dp, 'level mean')
  call check_close(suite, error, sqrt(5.0_dp / 3.0_dp / 4.0_dp), 1.0e-15_dp, 'level standard error')
  ! The control variate (theory.md T18). A control that differs from y by a constant on the two
  ! paired samples: y - x has no scatter, so the level's mean is that constant plus the controls'
  ! mean over all six, with the standard error of that mean alone (sd / sqrt(6)).
  call controlled_level_mean([11.0_dp, 14.0_dp], [1.0_dp, 4.0_dp], [1.0_dp, 4.0_dp, 2.0_dp, 3.0_dp, 5.0_dp, 6.0_dp], &
                             mean, error)
  call check_close(suite, mean, 10.0_dp + 3.5_dp, 1.0e-14_dp, 'controlled mean: constant difference')
  call check_close(suite, error, sqrt(17.5_dp / 5.0_dp / 6.0_dp), 1.0e-14_dp, &
                   'controlled mean: the standard error of the controls'' mean')
  ! A control that carries no information (the same value on every sample): the plain mean of y
  ! and its standard error.
  call controlled_level_mean([1.0_dp, 2.0_dp, 3.0_dp, 4.0_dp], [7.0_dp, 7.0_dp, 7.0_dp, 7.0_dp], [(7.0_dp, k = 1, 9)], &
                             mean, error)
  call check_close(suite, mean, 2.5_dp, 1.0e-14_dp, 'controlled mean: a constant control changes nothing')
  call check_close(suite, error, sqrt(5.0_dp / 3.0_dp / 4.0_dp), 1.0e-14_dp, &
                   'controlled mean: nor its standard error')

  ! Three levels at h = 1, 2, 3: the quadratic interpolates them, a = (3, -3, 1), so the intercept's
  ! variance is 9 s_1^2 + 9 s_2^2 + s_3^2 (none below the floor of a fifth of the median).
  h3 = [1.0_dp, 2.0_dp, 3.0_dp]
  call check_close(suite, intercept_variance(h3, [0.1_dp, 0.2_dp, 0.3_dp]), 9 * 0.01_dp + 9 * 0.04_dp + 0.09_dp, &
                   1.0e-12_dp, 'intercept variance: the Lagrange weights of three levels')
  ! One more control sample on level k lowers it by a_k^2 v (1/4 - 1/5) with four samples per level
  ! and the same per-sample variance v: levels 1 and 2 (a^2 = 9) before level 3 (a^2 = 1); the
  ! first of equal gains; per second, the cheaper; none where it is not affordable or capped.
  per_control(1, :) = 0.04_dp
  call check(suite, next_fill_level(h3, 0.0_dp * per_control, per_control, [4, 4, 4], [1.0_dp, 1.0_dp, 1.0_dp], &
                                    10.0_dp, 64) == 1, 'fill: the largest Lagrange weight, the first of two equal')
  call check(suite, next_fill_level(h3, 0.0_dp * per_control, per_control, [4, 4, 4], [1.0_dp, 0.5_dp, 1.0_dp], &
                                    10.0_dp, 64) == 2, 'fill: the same gain for half the seconds')
  call check(suite, next_fill_level(h3, 0.0_dp * per_control, per_control, [4, 4, 4], [1.0_dp, 1.0_dp, 0.1_dp], &
                                    10.0_dp, 64) == 3, 'fill: a ninth of the gain for a tenth of the seconds')
  call check(suite, next_fill_level(h3, 0.0_dp * per_control, per_control, [64, 64, 4], [1.0_dp, 1.0_dp, 1.0_dp], &
                                    10.0_dp, 64) == 3, 'fill: no level beyond its cap')
  call check(suite, next_fill_level(h3, 0.0_dp * per_control, per_control, [4, 4, 4], [1.0_dp, 1.0_dp, 1.0_dp], &
                                    0.5_dp, 64) == 0, 'fill: nothing that does not fit the seconds left')
  call check(suite, next_fill_level(h3, 0.0_dp * per_control, per_control, [4, 4, 4], [0.0_dp, -1.0_dp, 1.0_dp], &
                                    10.0_dp, 64) == 3, 'fill: no level of unknown cost')
  call check(suite, next_fill_level(h3, per_control, 0.0_dp * per_control, [4, 4, 4], [1.0_dp, 1.0_dp, 1.0_dp], &
                                    10.0_dp, 64) == 0, 'fill: nothing where control samples cannot help')

  ! The fill's level variances (fill_variance_parts): 16 samples on each of three levels, every
  ! fourth full, whose controls x = 1 + 0.02 f_1 follow their first moment feature f_1 exactly (the
  ! features deterministic and not collinear, the body's 0) and whose full values equal them
  ! (var(y - x) = 0). Without the moment control a level's per-control part is the sample variance
  ! of its x over the extrapolated value squared; with it, the regression takes the whole scatter
  ! (a linear value is recovered exactly, test_moment_control), and the fill sees none.
  do s = 1, n_fill
    level_fill(s) = (s - 1) / 16 + 1
    full_fill(s) = modulo(s, 4) == 1
    do j = 1, 10
      features(j, s) = sin(1.3_dp * s * j + 0.7_dp * j**2)
    end do
    x_fill(s) = 1.0_dp + 0.02_dp * features(1, s)
  end do
  call fill_variance_parts(h3, reshape(x_fill, [1, n_fill]), reshape(x_fill, [1, n_fill]), full_fill, level_fill, &
                           features, [(0.0_dp, j = 1, 10)], .false., paired3, per_control3)
  do k = 1, 3
    call level_mean(pack(x_fill, level_fill == k), level_means(k), level_errors(k))
  end do
  fit = extrapolate_to_zero(h3, level_means, level_errors, 0.0_dp)
  do k = 1, 3
    associate (x_level => pack(x_fill, level_fill == k))
      call check_close(suite, per_control3(1, k) * fit%value**2, sum((x_level - sum(x_level) / 16)**2) / 15, 1.0e-12_dp, &
                       'fill variances: without the moment control, the level''s scatter of its controls')
    end associate
  end do
  call check(suite, all(paired3 == 0.0_dp), 'fill variances: no paired part where y = x')
  call fill_variance_parts(h3, reshape(x_fill, [1, n_fill]), reshape(x_fill, [1, n_fill]), full_fill, level_fill, &
                           features, [(0.0_dp, j = 1, 10)], .true., paired3, per_control3)
  call check(suite, maxval(per_control3) < 1.0e-20_dp, &
             'fill variances: with the moment control, no scatter the moments explain')
  call finish_tests(suite)
end program test_continuum_fit
