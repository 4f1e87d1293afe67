"""The continuum job's value and error bar (docs/theory.md T18; src/hydro/continuum_fit.f90 and
continuum_values in src/driver/continuum_job.f90) recomputed from its samples for any linear
combination of the mobility entries, e.g. a diagonal entry in the principal frame of a body the
job saw turned: e^T Q^T M Q e is linear in M, so each sample gives one number, and the level
means, their standard errors, the weighted quadratic in h, the model spread and the volume term
follow exactly as beadmob does them for one entry. With Q = 1 it reproduces the file's own
mobility and mobility_error (bench/continuum/coverage.py checks this on every job it reads).

Only the analysis is redone here; the estimator is beadmob's (not changed, not tuned)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

#: beadmob's floor on a level's standard error, as a fraction of the median level's (continuum_fit.f90).
STANDARD_ERROR_FLOOR = 0.2
NEXT_TERM_LEVELS = 5      # continuum_fit.f90's next_term_levels


@dataclass(frozen=True)
class ContinuumSamples:
    bead_diameters: np.ndarray    # (K,) coarsest first
    sample_level: np.ndarray      # (S,) 1-based level of each sample
    sample_mobility: np.ndarray   # (S, 6, 6) corrected, shape units, about the centroid, input axes
    volume: float
    volume_error: float           # the volume's standard error (absolute, from the moment fills)
    mobility: np.ndarray          # (6, 6) the file's continuum mobility (symmetrised)
    mobility_error: np.ndarray    # (6, 6) its error bar, [row, column] of the mobility
    mobility_level_excess: np.ndarray | None = None   # (6, 6) tau of each entry's fit (files since be29465)
    #: with control samples (&continuum control_offsets > 0): 1 for a sample solved at order L, 0 for
    #: a control sample (its sample_mobility NaN), and every sample's order L - 1 corrected mobility
    sample_full: np.ndarray | None = None              # (S,)
    sample_control_mobility: np.ndarray | None = None  # (S, 6, 6)
    #: files since the moment control (/continuum moment_control = 1): every sample's bead moments
    #: (S, 13) and the body's (13), the control variates of each level's mean (moment_control_shift)
    sample_moments: np.ndarray | None = None
    body_moments: np.ndarray | None = None


@dataclass(frozen=True)
class Extrapolation:
    value: float            # intercept of the weighted quadratic over all levels
    standard_error: float   # of that intercept (with the levels' random-effects excess variance)
    linear_value: float     # the line through the three finest levels, at h = 0
    reduced_value: float    # the quadratic without the coarsest level, at h = 0
    reduced_chi2: float = float("nan")   # chi^2 / (K - 3) of the quadratic (nan for K = 3; 1 with an excess)
    excess_deviation: float = 0.0        # tau: the levels' scatter beyond their standard errors
    plain_reduced_chi2: float = float("nan")   # chi^2 / (K - 3) with weights 1 / s_k^2 alone (above 1: tau > 0)
    next_term: float = float("inf")      # the foreseen h^3 term's shift of the intercept (inf: K < 5)

    @property
    def model_spread(self) -> float:
        return max(abs(self.reduced_value - self.value), min(abs(self.linear_value - self.value), self.next_term))

    @property
    def fit_error(self) -> float:
        """The error bar without the volume term: the quadrature sum of 2 sigma and the model spread."""
        return float(np.hypot(2.0 * self.standard_error, self.model_spread))


def read_samples(path: str | Path) -> ContinuumSamples:
    """The samples and continuum values of a result file's /continuum group (docs/output.md)."""
    with h5py.File(path, "r") as f:
        c = f["continuum"]
        levels = np.asarray(c.attrs["sample_level"]).reshape(-1).astype(int)

        def per_sample(name):
            rows = np.asarray(c[name][()], dtype=float)
            if rows.shape != (len(levels), 36):
                rows = rows.T
            # Fortran writes a (6, 6) array per sample, columns first.
            return np.stack([row.reshape(6, 6, order="F") for row in rows])

        controlled = int(c.attrs.get("control_offsets", 0)) > 0
        # Fortran writes a (6, 6) array; h5py reads it transposed ([column, row]).
        return ContinuumSamples(
            bead_diameters=np.asarray(c["bead_diameters"][()], dtype=float), sample_level=levels,
            sample_mobility=per_sample("sample_mobility"),
            sample_full=np.asarray(c.attrs["sample_full"]).reshape(-1).astype(int) if controlled else None,
            sample_control_mobility=per_sample("sample_control_mobility") if controlled else None,
            volume=float(c.attrs["volume"]), volume_error=float(c.attrs["volume_standard_error"]),
            mobility=np.asarray(c["mobility"][()], dtype=float).T,
            mobility_error=np.asarray(c["mobility_error"][()], dtype=float).T,
            mobility_level_excess=np.asarray(c["mobility_level_excess"][()], dtype=float).T
            if "mobility_level_excess" in c else None,
            sample_moments=np.asarray(c["sample_moments"][()], dtype=float).reshape(len(levels), 13)
            if int(c.attrs.get("moment_control", 0)) else None,
            body_moments=np.asarray(c["body_moments"][()], dtype=float).reshape(13)
            if int(c.attrs.get("moment_control", 0)) else None)


def level_means(values: np.ndarray, sample_level: np.ndarray, levels: int) -> tuple[np.ndarray, np.ndarray]:
    """Each level's mean over its samples and that mean's standard error (sample standard deviation
    / sqrt(n); 0 for a single sample), as continuum_fit.f90's level_mean."""
    mean, error = np.zeros(levels), np.zeros(levels)
    for k in range(levels):
        x = values[sample_level == k + 1]
        mean[k] = x.mean()
        error[k] = np.sqrt(np.sum((x - mean[k]) ** 2) / (len(x) - 1) / len(x)) if len(x) > 1 else 0.0
    return mean, error


def controlled_level_means(values: np.ndarray, controls: np.ndarray, full: np.ndarray, sample_level: np.ndarray,
                           levels: int) -> tuple[np.ndarray, np.ndarray]:
    """continuum_fit.f90's controlled_level_mean per level: the mean of values - controls over the
    level's full samples plus the mean of controls over all its samples; variance var(y - x) / n +
    max(var(x) + 2 cov(y - x, x), 0) / m (the covariance from the n pairs, var(x) from the m)."""
    mean, error = np.zeros(levels), np.zeros(levels)
    for k in range(levels):
        level = sample_level == k + 1
        pair = level & (full == 1)
        y, x, x_all = values[pair], controls[pair], controls[level]
        n, m = len(y), len(x_all)
        difference = y - x
        mean[k] = difference.mean() + x_all.mean()
        if n < 2 or m < 2:
            continue
        covariance = np.sum((difference - difference.mean()) * (x - x.mean())) / (n - 1)
        variance = np.var(difference, ddof=1) / n + max(np.var(x_all, ddof=1) + 2 * covariance, 0.0) / m
        error[k] = np.sqrt(variance)
    return mean, error


#: moment_control.f90's constants: the ridge parameters tried (times the mean diagonal of the
#: standardised features' Gram matrix), and the samples needed beyond the levels per feature.
RIDGE_GRID = np.concatenate([[0.0], 10.0 ** (-6.0 + 0.25 * np.arange(33))])
SAMPLES_PER_FEATURE = 3


def moment_features(moments: np.ndarray, body: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """moment_control.f90's features: the volume, the first and the six distinct second moments about
    the body's centroid c of each sample's beads, relative to the body's volume V and its radius of
    gyration r (V, V r, V r^2), and the same of the body; (S, 10) and (10,)."""
    both = np.vstack([np.atleast_2d(moments), body])
    volume = body[0]
    centroid = body[1:4] / volume
    body_second = body[4:13].reshape(3, 3, order="F")
    gyration2 = (np.trace(body_second) - volume * centroid @ centroid) / volume / 3.0
    count, first = both[:, 0], both[:, 1:4]
    second = both[:, 4:13].reshape(-1, 3, 3, order="F")
    central = (second - np.einsum("si,j->sij", first, centroid) - np.einsum("i,sj->sij", centroid, first)
               + count[:, None, None] * np.outer(centroid, centroid))
    pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    columns = [count / volume] + [(first[:, i] - count * centroid[i]) / (volume * np.sqrt(gyration2)) for i in range(3)] \
        + [central[:, i, j] / (volume * gyration2) for i, j in pairs]
    table = np.column_stack(columns)
    return table[:-1], table[-1]


def moment_control_shift(target: np.ndarray, sample_level: np.ndarray, features: np.ndarray,
                         body_features: np.ndarray) -> tuple[np.ndarray, float]:
    """moment_control.f90's moment_control_shift: each sample's shift (to subtract from its value and
    control) and the factor on the level means' variances. The target's deviations from their level
    means are regressed (ridge, pooled over the levels) on the features' deviations from theirs;
    the ridge parameter, or none, by the smallest leave-one-out error."""
    target, features = np.asarray(target, dtype=float), np.asarray(features, dtype=float)
    s, p = features.shape
    levels = np.unique(sample_level)
    if s - len(levels) < SAMPLES_PER_FEATURE * p:
        return np.zeros(s), 1.0
    centred, deviation = features.copy(), target.copy()
    for k in levels:
        chosen = sample_level == k
        centred[chosen] -= features[chosen].mean(axis=0)
        deviation[chosen] -= target[chosen].mean()
    if not np.all(np.isfinite(deviation)):
        return np.zeros(s), 1.0
    spread = np.sqrt(np.sum(centred**2, axis=0) / s)
    used = spread > 1e-14 * np.maximum(np.abs(body_features), 1.0)
    if not np.any(used):
        return np.zeros(s), 1.0
    a = centred[:, used] / spread[used]
    gram = a.T @ a
    unit = np.trace(gram) / np.count_nonzero(used)
    best, best_error = None, float(np.sum(deviation**2))
    for ridge in RIDGE_GRID:
        matrix = gram + ridge * unit * np.eye(len(gram))
        try:   # beadmob inverts by Cholesky factors (dpotrf, dpotri) and skips what has none
            np.linalg.cholesky(matrix)
        except np.linalg.LinAlgError:
            continue
        inverse = np.linalg.inv(matrix)
        leverage = np.einsum("si,ij,sj->s", a, inverse, a)
        if np.any(1.0 - leverage < 1e-8):
            continue
        residual = deviation - a @ (inverse @ (a.T @ deviation))
        error = float(np.sum((residual / (1.0 - leverage)) ** 2))
        if error < best_error:
            best, best_error = (inverse, float(np.sum(leverage))), error
    if best is None:
        return np.zeros(s), 1.0
    inverse, parameters = best
    beta = (inverse @ (a.T @ deviation)) / spread[used]
    shift = (features[:, used] - body_features[used]) @ beta
    dof = s - len(levels)
    return shift, dof / max(dof - parameters, 1.0)


def _weighted_polynomial(x, y, w, degree):
    basis = np.vander(x, degree + 1, increasing=True)
    largest = np.max(w)
    normal = basis.T @ ((w / largest)[:, None] * basis)
    inverse = np.linalg.inv(normal)
    coefficients = inverse @ (basis.T @ ((w / largest) * y))
    chi2 = float(np.sum(w * (y - basis @ coefficients) ** 2))
    return coefficients, float(inverse[0, 0] / largest), chi2


def excess_variance(h: np.ndarray, mean: np.ndarray, level_variance: np.ndarray) -> float:
    """continuum_fit.f90's excess_variance: the tau^2 >= 0 at which the quadratic's chi^2 with
    weights 1 / (s_k^2 + tau^2) equals K - 3 (Paule & Mandel 1982), by the same bisection."""
    n = len(h)
    if n <= 3 or _weighted_polynomial(h, mean, 1.0 / level_variance, 2)[2] <= n - 3:
        return 0.0
    lower, upper = 0.0, _weighted_polynomial(h, mean, np.ones(n), 2)[2] / (n - 3)
    for _ in range(200):
        if upper - lower <= 1e-13 * upper:
            break
        middle = 0.5 * (lower + upper)
        if _weighted_polynomial(h, mean, 1.0 / (level_variance + middle), 2)[2] > n - 3:
            lower = middle
        else:
            upper = middle
    return upper


def floored_standard_error(standard_error: np.ndarray, mean: np.ndarray) -> np.ndarray:
    """continuum_fit.f90's floored_variance, as standard errors: max(se, STANDARD_ERROR_FLOOR times the
    median level's se, 1e-9 |mean|, sqrt(tiny))."""
    standard_error, mean = np.asarray(standard_error, dtype=float), np.asarray(mean, dtype=float)
    n = len(standard_error)
    median = np.sort(standard_error)[(n + 1) // 2 - 1]
    return np.maximum.reduce([standard_error, np.full(n, STANDARD_ERROR_FLOOR * median), 1e-9 * np.abs(mean),
                              np.full(n, np.sqrt(np.finfo(float).tiny))])


def extrapolate(h: np.ndarray, mean: np.ndarray, standard_error: np.ndarray) -> Extrapolation:
    """continuum_fit.f90's extrapolate_to_zero: level variances s_k^2 = max(se, a fifth of the median
    level's se, 1e-9 |mean|)^2, weights 1 / (s_k^2 + tau^2) with the random-effects excess tau^2
    (excess_variance); the quadratic over all levels, the line through the three finest levels, the
    quadratic without the coarsest and the foreseen h^3 term (next_term_shift)."""
    h, mean, standard_error = (np.asarray(v, dtype=float) for v in (h, mean, standard_error))
    n = len(h)
    sigma = floored_standard_error(standard_error, mean)
    excess = excess_variance(h, mean, sigma**2)
    plain_chi2 = _weighted_polynomial(h, mean, 1.0 / sigma**2, 2)[2] / (n - 3) if n > 3 else float("nan")
    weights = 1.0 / (sigma**2 + excess)
    coefficients, variance, chi2 = _weighted_polynomial(h, mean, weights, 2)
    reduced_chi2 = chi2 / (n - 3) if n > 3 else float("nan")
    order = np.argsort(h, kind="stable")
    finest = order[:3]
    linear = _weighted_polynomial(h[finest], mean[finest], weights[finest], 1)[0][0]
    reduced = coefficients[0]
    if n > 3:
        kept = order[: n - 1]
        reduced = _weighted_polynomial(h[kept], mean[kept], weights[kept], 2)[0][0]
    return Extrapolation(float(coefficients[0]), float(np.sqrt(variance)), float(linear), float(reduced),
                         float(reduced_chi2), float(np.sqrt(excess)), float(plain_chi2),
                         next_term_shift(h, weights, coefficients[1], coefficients[2]))


def next_term_shift(h: np.ndarray, weights: np.ndarray, b: float, c: float) -> float:
    """continuum_fit.f90's next_term_shift: |c^2 / b| times the weighted quadratic's intercept of h^3,
    the h^3 term foreseen as the series a + b h + c h^2 continues geometrically (inf on fewer than
    NEXT_TERM_LEVELS levels or b = 0)."""
    if len(h) < NEXT_TERM_LEVELS or abs(b) <= np.finfo(float).tiny:
        return float("inf")
    kappa3 = _weighted_polynomial(h, h**3, weights, 2)[0][0]
    if c == 0.0 or kappa3 == 0.0:
        return 0.0
    log_shift = 2.0 * np.log(abs(c)) - np.log(abs(b)) + np.log(abs(kappa3))
    return float(np.exp(log_shift)) if log_shift < np.log(np.finfo(float).max) else float("inf")


def combination_level_means(samples: ContinuumSamples, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each level's mean of sum_jk weights[j, k] M[j, k] and its standard error, as beadmob makes
    them: the plain mean over the level's samples, or with control samples the controlled mean."""
    weights = np.asarray(weights, dtype=float)
    levels = len(samples.bead_diameters)
    full = samples.sample_full
    if full is None:
        values = np.einsum("sjk,jk->s", samples.sample_mobility, weights)
        controls = values
    else:
        values = np.einsum("sjk,jk->s", np.where(full[:, None, None] == 1, samples.sample_mobility, 0.0), weights)
        controls = np.einsum("sjk,jk->s", samples.sample_control_mobility, weights)
    variance_factor = 1.0
    if samples.sample_moments is not None:
        shift, variance_factor = moment_control_shift(controls, samples.sample_level,
                                                      *moment_features(samples.sample_moments, samples.body_moments))
        values, controls = values - shift, controls - shift
    if full is None:
        mean, error = level_means(values, samples.sample_level, levels)
    else:
        mean, error = controlled_level_means(values, controls, full, samples.sample_level, levels)
    return mean, error * np.sqrt(variance_factor)


def combination_bar(samples: ContinuumSamples, weights: np.ndarray, power: int) -> tuple[float, float, Extrapolation]:
    """(value, error bar, the fit) of sum_jk weights[j, k] M[j, k] by beadmob's estimator; `power`:
    the combination scales as length^-power (1 translation, 2 coupling, 3 rotation), for the volume
    term p / 3 * (the volume's relative standard error) * |value|."""
    mean, error = combination_level_means(samples, weights)
    fit = extrapolate(samples.bead_diameters, mean, error)
    bar = fit.fit_error + abs(fit.value) * power / 3.0 * samples.volume_error / samples.volume
    return fit.value, bar, fit


def entry_power(row: int, column: int) -> int:
    """p of the mobility entry [row, column] (0-based): 1 + (row is a rotation) + (column is one)."""
    return 1 + int(row > 2) + int(column > 2)


def principal_diagonal(samples: ContinuumSamples, rotation: np.ndarray):
    """The six diagonal entries of Q^T M Q, Q = diag(R, R) (R: the body's principal axes as the
    columns, in the input frame), each as (value, error bar, fit)."""
    q = np.zeros((6, 6))
    q[:3, :3] = q[3:, 3:] = np.asarray(rotation, dtype=float)
    return [combination_bar(samples, np.outer(q[:, i], q[:, i]), entry_power(i, i)) for i in range(6)]


def replay_discrepancy(samples: ContinuumSamples) -> float:
    """Largest relative difference, over the 36 input-frame entries, between the error bar
    recomputed here and the file's (and over the diagonal values, and the levels' excess tau on the
    bar's scale where the file has it): ~1e-12 when this module still is beadmob's estimator."""
    worst = 0.0
    for row in range(6):
        for column in range(6):
            weights = np.zeros((6, 6))
            weights[row, column] = 1.0
            value, bar, fit = combination_bar(samples, weights, entry_power(row, column))
            scale = max(abs(samples.mobility_error[row, column]), 1e-300)
            worst = max(worst, abs(bar - samples.mobility_error[row, column]) / scale)
            if samples.mobility_level_excess is not None:
                worst = max(worst, abs(fit.excess_deviation - samples.mobility_level_excess[row, column]) / scale)
            if row == column:
                worst = max(worst, abs(value - samples.mobility[row, row]) / abs(samples.mobility[row, row]))
    return worst


__all__ = ["ContinuumSamples", "Extrapolation", "read_samples", "level_means", "controlled_level_means", "combination_level_means",
           "moment_features", "moment_control_shift", "excess_variance", "extrapolate",
           "combination_bar", "entry_power", "principal_diagonal", "replay_discrepancy"]
