!> The continuum limit of a ladder of bead models (docs/theory.md T18): one quantity (a
!> mobility entry, a coefficient) known at each level k as the mean over its sub-lattice offsets,
!> with that mean's standard error, is extrapolated to zero bead size h = d by weighted least
!> squares in h and h^2 (measured on spheres and ellipsoids: the offset-averaged, volume- and
!> shape-corrected error of an order-L bead model is smooth in h and vanishes with it,
!> bench/continuum/continuum.md). Where the level means scatter about the quadratic more than their
!> standard errors say, every level's variance gets the same excess tau^2 (a random-effects fit):
!> a level whose offsets happened to agree then no longer pins the fit. The error bar is the
!> quadrature sum of
!>   - twice the fit's standard error of the intercept and
!>   - the model spread: how far the quadratic without the coarsest level lands from the
!>     quadratic, or, if further, the neglected h^3 term: on ladders of five or more levels its
!>     size as the quadratic's own terms foresee it (the next term of their geometric series),
!>     at most, and on shorter ladders exactly, how far the straight line through the three
!>     finest levels lands,
!> plus what the caller knows besides (the continuum volume's own uncertainty).
module beadmob_continuum_fit
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: continuum_value_t, extrapolate_to_zero, level_mean, controlled_level_mean, continuum_result_t
  public :: intercept_variance, controlled_variance_parts

  !> What a continuum job found (written to the result file's /continuum group, docs/output.md):
  !> the ladder, every solved sample, each level's means and the continuum values. Lengths in
  !> the shape's unit, viscosity 1; mobility about the body's centroid, in the input's axes.
  type :: continuum_result_t
    integer :: offsets = 0, moment_fills = 0, multipole_order = 0
    real(dp) :: time_budget = 0.0_dp, estimated_seconds = 0.0_dp, reference_length = 0.0_dp
    !> How the ladder was chosen (time_budget, finest_bead_diameter, checkpoint) and the pilot's
    !> factor on the dry run's estimates (1 without a pilot).
    character(len=:), allocatable :: chosen_by
    !> Where reference_length came from: 'input', 'body' (the body's own extent along the body x
    !> axis) or 'finest level' (the finest level's bead model's outer size).
    character(len=:), allocatable :: reference_length_from
    real(dp) :: calibration = 1.0_dp
    !> Levels the budget's ladder moved coarser once its solved levels showed the rest would overrun.
    integer :: moved_coarser = 0
    real(dp), allocatable :: bead_diameters(:)                  ! per level, coarsest first
    !> The body from the moment fills: volume and its standard error, centroid, the equivalent
    !> ellipsoid's semi-axes and axes (columns).
    real(dp) :: volume = 0.0_dp, volume_error = 0.0_dp, centroid(3) = 0.0_dp
    real(dp) :: semi_axes(3) = 0.0_dp, axes(3, 3) = 0.0_dp
    !> The body's mean moments from the fills (volume, first 3, second 9 column-major; body_moments_t)
    real(dp) :: body_moments(13) = 0.0_dp
    !> Per sample: its level, offset (d), beads, Krylov iterations (sum over its solves), 1 when
    !> every solve converged, largest true relative residual, wall time, ||K - K^T|| / ||K|| of
    !> its friction K; its friction as solved
    !> (36, d units, about its beads' centre of mass) and its corrected mobility (36) and
    !> coefficients (5).
    integer, allocatable :: sample_level(:), sample_beads(:), sample_iterations(:), sample_converged(:)
    real(dp), allocatable :: sample_offset(:, :), sample_residual(:), sample_seconds(:), sample_symmetry_error(:)
    real(dp), allocatable :: sample_friction(:, :), sample_mobility(:, :), sample_coefficients(:, :)
    !> Per sample: the volume, first (3) and second (9, column-major) moments of its beads (shape
    !> units: body_moments_t), from which its correction was made.
    real(dp), allocatable :: sample_moments(:, :)
    !> Per sample: its lattice's axes (9: the columns, input frame; the identity unless
    !> turned_lattices; the body turns about lattice_pivot, its centroid). Its friction and moments
    !> above are turned back into the input's frame.
    logical :: turned_lattices = .false.
    real(dp) :: lattice_pivot(3) = 0.0_dp
    real(dp), allocatable :: sample_lattice_axes(:, :)
    !> With control samples (control_offsets > 0, T18): per sample 1 when solved at the job's
    !> order (its order L - 1 companion beside it), 0 for a control sample (order L - 1 alone: its
    !> sample_friction, sample_mobility and sample_coefficients are NaN); the order L - 1 friction,
    !> corrected mobility and coefficients of every sample, as the order-L ones above.
    integer :: control_offsets = 0
    integer, allocatable :: sample_full(:)
    !> fill_budget bought control samples beyond control_offsets with the rest of the budget (so
    !> levels may hold different numbers of samples: sample_level counts them).
    logical :: filled = .false.
    !> The level means took the samples' bead moments as control variates (moment_control.f90).
    logical :: moment_control = .false.
    real(dp), allocatable :: sample_control_friction(:, :), sample_control_mobility(:, :)
    real(dp), allocatable :: sample_control_coefficients(:, :)
    !> Per level (columns): the mean over its offsets and that mean's standard error.
    real(dp), allocatable :: level_mobility(:, :), level_mobility_error(:, :)
    real(dp), allocatable :: level_coefficients(:, :), level_coefficient_error(:, :)
    !> The continuum values with their error bars; the linear and reduced fits' coefficients.
    real(dp) :: mobility(6, 6) = 0.0_dp, mobility_error(6, 6) = 0.0_dp, friction(6, 6) = 0.0_dp
    !> Per entry: tau of the fit, the level means' scatter about the quadratic beyond their
    !> standard errors (0: none; large against the bar: the means do not follow one smooth law in h)
    real(dp) :: mobility_level_excess(6, 6) = 0.0_dp, coefficient_level_excess(5) = 0.0_dp
    real(dp) :: coefficients(5) = 0.0_dp, coefficient_error(5) = 0.0_dp
    real(dp) :: coefficient_linear(5) = 0.0_dp, coefficient_reduced(5) = 0.0_dp
    !> The foreseen h^3 term's shift of each coefficient's intercept (huge() on short ladders)
    real(dp) :: coefficient_next_term(5) = 0.0_dp
    real(dp) :: coefficient_standard_error(5) = 0.0_dp
    !> A flow job (theory.md T19): per sample its corrected velocity (6 x 5) and stresslet (5 x 5) per
    !> unit strain (columns flattened, about the body's centroid, input axes), per level their means
    !> and standard errors, and the continuum values with their bars
    logical :: flow = .false.
    real(dp), allocatable :: sample_velocity_per_strain(:, :), sample_stresslet_per_strain(:, :)
    !> With control samples as well: their order L - 1 flow response (as sample_control_mobility).
    real(dp), allocatable :: sample_control_velocity_per_strain(:, :), sample_control_stresslet_per_strain(:, :)
    real(dp), allocatable :: level_velocity_per_strain(:, :), level_velocity_per_strain_error(:, :)
    real(dp), allocatable :: level_stresslet_per_strain(:, :), level_stresslet_per_strain_error(:, :)
    real(dp) :: velocity_per_strain(6, 5) = 0.0_dp, velocity_per_strain_error(6, 5) = 0.0_dp
    real(dp) :: stresslet_per_strain(5, 5) = 0.0_dp, stresslet_per_strain_error(5, 5) = 0.0_dp
  end type continuum_result_t

  !> The smallest standard error a level may count with, as a fraction of the median level's.
  real(dp), parameter, public :: standard_error_floor = 0.2_dp
  !> The fewest levels whose quadratic foretells its next term: with five, the quadratic has two
  !> degrees of freedom beyond interpolation, so its b and c are measured, not interpolated.
  integer, parameter, public :: next_term_levels = 5

  !> One quantity's continuum value and the parts of its error bar.
  type :: continuum_value_t
    real(dp) :: value = 0.0_dp          ! intercept of the quadratic fit over all levels
    real(dp) :: standard_error = 0.0_dp ! of that intercept
    real(dp) :: linear_value = 0.0_dp   ! intercept of the line through the three finest levels
    real(dp) :: reduced_value = 0.0_dp  ! intercept of the quadratic without the coarsest level
    !> What the h^3 term the quadratic leaves out would move its intercept by, foreseen from the
    !> fitted b h and c h^2 (huge() on ladders of fewer than next_term_levels levels)
    real(dp) :: next_term = huge(1.0_dp)
    real(dp) :: slope = 0.0_dp          ! d value / d h at h = 0
    real(dp) :: curvature = 0.0_dp      ! the quadratic's coefficient of h^2
    real(dp) :: excess_deviation = 0.0_dp ! tau: how far the level means scatter beyond their standard errors
    real(dp) :: error = 0.0_dp          ! the error bar (module header)
  end type continuum_value_t

contains

  !> Mean over a level's samples and its standard error (sample standard deviation / sqrt(n)).
  pure subroutine level_mean(samples, mean, standard_error)
    real(dp), intent(in) :: samples(:)
    real(dp), intent(out) :: mean, standard_error
    integer :: n
    n = size(samples)
    mean = sum(samples) / n
    standard_error = 0.0_dp
    if (n > 1) standard_error = sqrt(sum((samples - mean)**2) / (n - 1) / n)
  end subroutine level_mean

  !> A level's mean of y with a control variate x (docs/theory.md T18): y and x_paired on the
  !> same n samples (order L and its order L - 1 companion on the same beads), x_all on all m
  !> samples of the level (the n among them). The mean of y - x over the n plus the mean of x over
  !> the m is unbiased for the level's offset average of y, and where y - x scatters far less than
  !> y it has nearly the standard error of x's mean over m; its variance
  !>     var(y - x) / n + (var(x) + 2 cov(y - x, x)) / m,
  !> the covariance from the n pairs (each of the n is one of the m), var(x) from the m.
  !> paired, per_control: the variance's two parts (controlled_variance_parts), if asked for.
  pure subroutine controlled_level_mean(y, x_paired, x_all, mean, standard_error, paired, per_control)
    real(dp), intent(in) :: y(:), x_paired(:), x_all(:)
    real(dp), intent(out) :: mean, standard_error
    real(dp), intent(out), optional :: paired, per_control
    real(dp) :: paired_part, control_part
    mean = sum(y - x_paired) / size(y) + sum(x_all) / size(x_all)
    call controlled_variance_parts(y, x_paired, x_all, paired_part, control_part)
    standard_error = sqrt(paired_part + control_part / size(x_all))
    if (present(paired)) paired = paired_part
    if (present(per_control)) per_control = control_part
  end subroutine controlled_level_mean

  !> The two parts of controlled_level_mean's variance, paired + per_control / m: var(y - x) / n,
  !> which more control samples leave as it is, and max(var(x) + 2 cov(y - x, x), 0), which they
  !> divide (both 0 with fewer than two samples of either kind).
  pure subroutine controlled_variance_parts(y, x_paired, x_all, paired, per_control)
    real(dp), intent(in) :: y(:), x_paired(:), x_all(:)
    real(dp), intent(out) :: paired, per_control
    real(dp) :: difference(size(y)), difference_mean
    integer :: n, m
    n = size(y)
    m = size(x_all)
    paired = 0.0_dp
    per_control = 0.0_dp
    if (n < 2 .or. m < 2) return
    difference = y - x_paired
    difference_mean = sum(difference) / n
    paired = sum((difference - difference_mean)**2) / (n - 1) / n
    per_control = max(sum((x_all - sum(x_all) / m)**2) / (m - 1) + &
                      2.0_dp * sum((difference - difference_mean) * (x_paired - sum(x_paired) / n)) / (n - 1), 0.0_dp)
  end subroutine controlled_variance_parts

  !> The extrapolation of (h_k, mean_k +- standard_error_k), k = 1..K (K >= 3, any order of h);
  !> `extra` is added to the error bar.
  pure function extrapolate_to_zero(h, mean, standard_error, extra) result(fit)
    real(dp), intent(in) :: h(:), mean(:), standard_error(:), extra
    type(continuum_value_t) :: fit
    real(dp) :: weights(size(h)), level_variance(size(h)), coefficients(3), variance, chi2
    integer :: order(size(h)), n
    n = size(h)
    level_variance = floored_variance(standard_error, mean)
    ! Levels that scatter more than that (a lattice resonance, a smooth law the quadratic misses)
    ! share the excess: weights 1 / (s_k^2 + tau^2), whose chi^2 then equals its degrees of freedom.
    fit%excess_deviation = sqrt(excess_variance(h, mean, level_variance))
    weights = 1.0_dp / (level_variance + fit%excess_deviation**2)
    call weighted_polynomial(h, mean, weights, 2, coefficients, variance, chi2)
    fit%value = coefficients(1)
    fit%slope = coefficients(2)
    fit%curvature = coefficients(3)
    fit%standard_error = sqrt(variance)
    ! The three finest levels (smallest h) for the line; all but the coarsest for the reduced fit.
    order = ranks_by_size(h)
    associate (finest => order(1:3))
      call weighted_polynomial(h(finest), mean(finest), weights(finest), 1, coefficients, variance, chi2)
      fit%linear_value = coefficients(1)
    end associate
    fit%reduced_value = fit%value
    if (n > 3) then
      associate (kept => order(1:n - 1))
        call weighted_polynomial(h(kept), mean(kept), weights(kept), 2, coefficients, variance, chi2)
        fit%reduced_value = coefficients(1)
      end associate
    end if
    fit%next_term = next_term_shift(h, weights, fit%slope, fit%curvature)
    ! The fit's noise (2 sigma) and the model's uncertainty (the spread) are independent: their
    ! quadrature sum (docs/theory.md T18, "The error bar").
    fit%error = hypot(2.0_dp * fit%standard_error, model_spread(fit)) + extra
  end function extrapolate_to_zero

  !> The model spread of the error bar (module header): the reduced quadratic's distance, or the
  !> foreseen h^3 term capped by the finest line's distance (the line alone without a foresight).
  pure real(dp) function model_spread(fit)
    type(continuum_value_t), intent(in) :: fit
    model_spread = max(abs(fit%reduced_value - fit%value), min(abs(fit%linear_value - fit%value), fit%next_term))
  end function model_spread

  !> The shift of the quadratic's intercept by the h^3 term it leaves out, |d| kappa_3, with d
  !> foreseen as the series a + b h + c h^2 + d h^3 + ... continues geometrically, d = c^2 / b
  !> (each term the last times c h / b), and kappa_3 the intercept the same weighted quadratic
  !> gives the values h^3 (its bias on a pure h^3). The line through the finest levels, the
  !> spread until 2026-11-29, measures the c h^2 term itself, one order too low: 5-7 times the
  !> true error on the coverage bench (docs/theory.md T18, "The error bar").
  pure real(dp) function next_term_shift(h, weights, b, c)
    real(dp), intent(in) :: h(:), weights(:), b, c
    real(dp) :: coefficients(3), variance, chi2, log_shift
    next_term_shift = huge(1.0_dp)   ! no foresight
    if (size(h) < next_term_levels .or. abs(b) <= tiny(1.0_dp)) return
    call weighted_polynomial(h, h**3, weights, 2, coefficients, variance, chi2)
    if (c == 0.0_dp .or. coefficients(1) == 0.0_dp) then
      next_term_shift = 0.0_dp
      return
    end if
    ! In logarithms: c^2 / b overflows where b nearly vanishes (no foresight then).
    log_shift = 2.0_dp * log(abs(c)) - log(abs(b)) + log(abs(coefficients(1)))
    if (log_shift < log(huge(1.0_dp))) next_term_shift = exp(log_shift)
  end function next_term_shift

  !> The variance of the quadratic's intercept over levels at h with these standard errors (floored
  !> as extrapolate_to_zero floors them; no excess tau^2): what one more sample on a level would
  !> change, before it is solved (continuum_fill.f90).
  pure real(dp) function intercept_variance(h, standard_error)
    real(dp), intent(in) :: h(:), standard_error(:)
    real(dp) :: coefficients(3), chi2
    call weighted_polynomial(h, 0.0_dp * h, 1.0_dp / floored_variance(standard_error, 0.0_dp * h), 2, coefficients, &
                             intercept_variance, chi2)
  end function intercept_variance

  !> The levels' variances s_k^2 as the fit counts them. A few offsets can agree by chance: no
  !> level's standard error counts as less than a fifth of the median level's (nor 1e-9 of its
  !> value), or that level alone would make the fit.
  pure function floored_variance(standard_error, mean) result(level_variance)
    real(dp), intent(in) :: standard_error(:), mean(:)
    real(dp) :: level_variance(size(standard_error))
    integer :: order(size(standard_error))
    order = ranks_by_size(standard_error)
    level_variance = max(standard_error, standard_error_floor * standard_error(order((size(order) + 1) / 2)), &
                         1.0e-9_dp * abs(mean), sqrt(tiny(1.0_dp)))**2
  end function floored_variance

  !> The random-effects excess tau^2 >= 0 of the levels' variances s_k^2 (`level_variance`): the
  !> tau^2 at which the quadratic's chi^2 with weights 1 / (s_k^2 + tau^2) equals its degrees of
  !> freedom n - 3 (R. C. Paule and J. Mandel, J. Res. Natl. Bur. Stand. 87 (1982) 377-385, for a
  !> constant; the same condition for a regression), 0 when chi^2 is already at most n - 3.
  !> Bisection: chi^2 falls with tau^2, and at tau^2 = RSS / (n - 3), RSS the unweighted fit's
  !> residual sum, it is at most n - 3.
  pure function excess_variance(h, mean, level_variance) result(excess)
    real(dp), intent(in) :: h(:), mean(:), level_variance(:)
    real(dp) :: excess, coefficients(3), variance, chi2, lower, upper, middle
    integer :: n, step
    n = size(h)
    excess = 0.0_dp
    if (n <= 3) return
    call weighted_polynomial(h, mean, 1.0_dp / level_variance, 2, coefficients, variance, chi2)
    if (chi2 <= n - 3) return
    call weighted_polynomial(h, mean, [(1.0_dp, step = 1, n)], 2, coefficients, variance, chi2)
    lower = 0.0_dp
    upper = chi2 / (n - 3)
    do step = 1, 200
      if (upper - lower <= 1.0e-13_dp * upper) exit
      middle = 0.5_dp * (lower + upper)
      call weighted_polynomial(h, mean, 1.0_dp / (level_variance + middle), 2, coefficients, variance, chi2)
      if (chi2 > n - 3) then
        lower = middle
      else
        upper = middle
      end if
    end do
    excess = upper
  end function excess_variance

  !> Least squares of y ~ sum_j c_j x^(j-1), j = 1..degree+1, with weights w (1 / variance);
  !> variance: of c_1; chi2: the weighted residual sum. Columns scaled by max |x| and weights by
  !> their largest for conditioning (the fit does not change; huge weights do not overflow).
  pure subroutine weighted_polynomial(x, y, w, degree, coefficients, variance, chi2)
    real(dp), intent(in) :: x(:), y(:), w(:)
    integer, intent(in) :: degree
    real(dp), intent(out) :: coefficients(3), variance, chi2
    real(dp) :: basis(size(x), degree + 1), normal(degree + 1, degree + 1), inverse(degree + 1, degree + 1)
    real(dp) :: scale, largest
    integer :: j
    scale = maxval(abs(x))
    largest = maxval(w)
    do j = 1, degree + 1
      basis(:, j) = (x / scale)**(j - 1)
    end do
    normal = matmul(transpose(basis), spread(w / largest, 2, degree + 1) * basis)
    inverse = inverted(normal)
    coefficients = 0.0_dp
    coefficients(1:degree + 1) = matmul(inverse, matmul(transpose(basis), (w / largest) * y))
    chi2 = sum(w * (y - matmul(basis, coefficients(1:degree + 1)))**2)
    variance = inverse(1, 1) / largest
    do j = 2, degree + 1
      coefficients(j) = coefficients(j) / scale**(j - 1)
    end do
  end subroutine weighted_polynomial

  !> Inverse of a small symmetric positive definite matrix by Gauss-Jordan elimination.
  pure function inverted(matrix) result(inverse)
    real(dp), intent(in) :: matrix(:, :)
    real(dp) :: inverse(size(matrix, 1), size(matrix, 1)), work(size(matrix, 1), 2 * size(matrix, 1)), pivot
    integer :: n, i, k
    n = size(matrix, 1)
    work = 0.0_dp
    work(:, 1:n) = matrix
    do i = 1, n
      work(i, n + i) = 1.0_dp
    end do
    do i = 1, n
      pivot = work(i, i)
      work(i, :) = work(i, :) / pivot
      do k = 1, n
        if (k /= i) work(k, :) = work(k, :) - work(k, i) * work(i, :)
      end do
    end do
    inverse = work(:, n + 1:)
  end function inverted

  !> Indices of `values` from the smallest to the largest (insertion sort: a handful of levels).
  pure function ranks_by_size(values) result(order)
    real(dp), intent(in) :: values(:)
    integer :: order(size(values)), i, j, held
    order = [(i, i = 1, size(values))]
    do i = 2, size(values)
      held = order(i)
      j = i - 1
      do while (j >= 1)
        if (values(order(j)) <= values(held)) exit
        order(j + 1) = order(j)
        j = j - 1
      end do
      order(j + 1) = held
    end do
  end function ranks_by_size
end module beadmob_continuum_fit
