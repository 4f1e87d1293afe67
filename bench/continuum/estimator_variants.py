#!/usr/bin/env python3
"""estimator_variants.py [--coverage DIR] [--nonconvex DIR] [--spheres FILE ...] [--variants A,B]
[--out FILE]: would another error-bar estimator make a real particle's continuum bar as small as an ellipsoid's and still hold?

Issue 44 item 4 asks for bars of 0.1 % (translation) and 0.3 % (rotation) on non-ellipsoidal bodies
at the default budget. The continuum job's estimator (docs/theory.md T18) is replayed here, without
a solve, on the samples of jobs already run and kept:

* the coverage jobs (bench/continuum/coverage.py --keep DIR; 21 jobs of 12 bodies with exact
  mobilities, 114 principal diagonal entries): how many exact values each variant's bar holds and
  the median bar / true error (target <= 4);
* the non-convex jobs (bench/continuum/nonconvex.py --keep DIR: dumbbell, bent rod, 3-D cross, rough
  sphere, and the 1.6:1:0.7 ellipsoid beside them): the largest translation and rotation bar of each,
  relative to the value, in the body's principal frame.

Variants (each changes one thing of beadmob's estimator, scripts/beadmob_post/continuum_bar.py):
* beadmob before moment control: as the job did it until 12f2eb4 (the levels' random-effects excess
  variance since be29465; the coverage replay reproduces the bars of files written from then until
  12f2eb4); every variant below but the next is a change of this one;
* moment control: beadmob from 12f2eb4 until the next term (docs/theory.md T18, "Moment control"):
  each level's mean with the samples' bead moments (volume, first and second, which average to the
  body's over random offsets) as control variates, a ridge regression pooled over the levels, its
  ridge chosen by leave-one-out; replayed on files written before it from the sample moments they
  hold; its model spread (as every variant's above and below that does not say otherwise) the
  larger distance of the line through the three finest levels and of the quadratic without the
  coarsest from the quadratic;
* next term: beadmob since 2026-11-29 (T18, "The error bar"): the moment control with the line's
  distance capped, on ladders of five or more levels, by the h^3 term the quadratic's own b h and
  c h^2 foresee (c^2 / b times the quadratic's intercept of h^3);
* volume variance covariate (an experiment of 2026-11-29, not built): the next term's estimator with
  one more term in the level means' law, g v_k, v_k the variance of level k's samples' bead volume
  over their offsets relative to the body's volume squared, kept for an entry when |g| is at least
  twice its standard error (random-effects weights of the four-term law), its spread the reduced
  four-term law's distance or the next term. On a lattice aligned with flat faces a level's mean
  sits between the friction of n and n + 1 rows across a bar, about f(n + frac) + f'' frac (1 -
  frac) / 2: its offset average carries the curvature of the friction in the rows times their
  variance, which v_k follows (0 on levels where the bars are whole rows at every offset);
* cubic beyond noise (built in 51273d1 and 7b47e0c, reverted): the model spread as how far the cubic's
  and the reduced quadratic's intercepts lie from the quadratic's beyond the levels' sampling noise
  of each difference, sum_k (r_k - r_quadratic,k)^2 s_k^2 (r: an intercept's weights on the level
  means; tau not subtracted); the line only on three-level ladders, where nothing else is possible;
* chi^2 inflation: the estimator before be29465, weights 1 / s_k^2 and the intercept's variance
  times max(1, chi^2 / (K - 3)) (a level whose offsets agree keeps its full weight), with the line
  spread of its time;
* floor 0.5, floor 1: a level's standard error floored at half / all of the median level's
  (beadmob: a fifth), i.e. levels whose offsets happen to agree weigh less;
* half-range spread: the model spread as half the range of the three models' intercepts (the
  quadratic, the line through the three finest levels, the quadratic without the coarsest) instead
  of the largest distance from the quadratic's;
* no line: the model spread as the quadratic without the coarsest level's distance alone, noise and all
  (the line through the three finest levels left out: on ellipsoids its own intercept errs about
  five times as far as the quadratic's, so its distance from the quadratic measures the line more
  than the quadratic);
* 2 sigma alone: no model spread;
* model average (AIC): the moment control's level means, and instead of the quadratic with its
  model spread, Bayesian model averaging over the fits a lattice-QCD continuum limit would try
  (W. I. Jay and E. T. Neil, Phys. Rev. D 103, 114502 (2021), arXiv:2008.01069): the line and the
  quadratic in h through the finest n levels, every n that leaves no negative degrees of freedom,
  weighed by exp(-(chi^2 + 2 k + 2 N_cut) / 2) (k parameters, N_cut levels left out; chi^2 with
  beadmob's weights 1 / (s_k^2 + tau^2)); the value their weighted mean, the bar 2 sqrt(the
  weighted mean of their variances + the weighted variance of their values). It asks the data
  alone which model holds, as the line in beadmob's spread does;
* volume regression, moment regression: the first try of the moment control (plain least squares of
  each sample's order-L value, so not on jobs with control samples): before the level means, each
  corrected sample's relative deviation from its level's mean is regressed, pooled over all levels,
  on its relative volume deviation (or on the volume and the six central second moments) and the
  fitted part removed.

Kept jobs are not in the repository (the benches' run folders are ignored by git): run coverage.py
and nonconvex.py with --keep first, or point --coverage / --nonconvex at their folders."""
import argparse
import dataclasses
import json
from dataclasses import dataclass
import sys
import time
from pathlib import Path

import h5py
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from continuum_jobs import ROOT  # noqa: E402
import coverage  # noqa: E402

sys.path.insert(0, str(ROOT / "scripts"))
from beadmob_post import continuum_bar as bar_module  # noqa: E402

NONCONVEX = ("dumbbell", "bent_rod", "cross", "rough_sphere", "ellipsoid")
VARIANTS = ("beadmob before moment control", "moment control", "next term", "volume variance covariate",
            "model average (AIC)", "cubic beyond noise",
            "chi^2 inflation", "floor 0.5", "floor 1", "half-range spread", "no line", "2 sigma alone",
            "volume regression", "moment regression")
#: the variants built on the moment control (the rest change the estimator before it)
MOMENT_VARIANTS = ("moment control", "next term", "volume variance covariate", "model average (AIC)")


class HalfRangeSpread(bar_module.Extrapolation):
    @property
    def model_spread(self) -> float:
        intercepts = (self.value, self.linear_value, self.reduced_value)
        return (max(intercepts) - min(intercepts)) / 2


class LineSpread(bar_module.Extrapolation):
    """The model spread until the next term: the line's and the reduced quadratic's larger distance."""
    @property
    def model_spread(self) -> float:
        return max(abs(self.linear_value - self.value), abs(self.reduced_value - self.value))


class ReducedSpread(bar_module.Extrapolation):
    @property
    def model_spread(self) -> float:
        return abs(self.reduced_value - self.value)


class NoSpread(bar_module.Extrapolation):
    @property
    def model_spread(self) -> float:
        return 0.0


def spread_variant(kind):
    """beadmob's fit with the model spread of `kind` (an Extrapolation subclass)."""
    def extrapolate(h, mean, standard_error):
        fit = beadmob_extrapolate(h, mean, standard_error)
        return kind(**fit.__dict__)
    return extrapolate


def floored_extrapolation(floor):
    """beadmob's extrapolate with the standard-error floor at `floor` times the median level's."""
    def extrapolate(h, mean, standard_error):
        saved = bar_module.STANDARD_ERROR_FLOOR
        bar_module.STANDARD_ERROR_FLOOR = floor
        try:
            return line_extrapolate(h, mean, standard_error)
        finally:
            bar_module.STANDARD_ERROR_FLOOR = saved
    return extrapolate


def inflated_extrapolation(h, mean, standard_error):
    """The estimator before be29465: plain inverse-variance weights, the intercept's variance scaled
    by the reduced chi^2 when above 1."""
    h, mean, standard_error = (np.asarray(v, dtype=float) for v in (h, mean, standard_error))
    n = len(h)
    sigma = bar_module.floored_standard_error(standard_error, mean)
    weights = 1.0 / sigma**2
    polynomial = bar_module._weighted_polynomial
    coefficients, variance, chi2 = polynomial(h, mean, weights, 2)
    reduced_chi2 = chi2 / (n - 3) if n > 3 else float("nan")
    if n > 3:
        variance *= max(1.0, reduced_chi2)
    order = np.argsort(h, kind="stable")
    linear = polynomial(h[order[:3]], mean[order[:3]], weights[order[:3]], 1)[0][0]
    reduced = polynomial(h[order[:-1]], mean[order[:-1]], weights[order[:-1]], 2)[0][0] if n > 3 else coefficients[0]
    return bar_module.Extrapolation(float(coefficients[0]), float(np.sqrt(variance)), float(linear), float(reduced),
                                    float(reduced_chi2))


@dataclass(frozen=True)
class FixedSpread(bar_module.Extrapolation):
    spread: float = 0.0

    @property
    def model_spread(self) -> float:
        return self.spread


def intercept_row(h, weights, degree):
    """The weighted polynomial fit's intercept as weights on the level means (least squares of the unit vectors)."""
    basis = np.vander(h / np.max(np.abs(h)), degree + 1, increasing=True)
    scaled = weights / np.max(weights)
    return np.linalg.solve(basis.T @ (scaled[:, None] * basis), basis.T * scaled)[0]


def cubic_beyond_noise(h, mean, standard_error):
    """beadmob's fit with the model spread of 51273d1 (reverted): the cubic's and the reduced quadratic's
    moves beyond the levels' sampling noise (s_k: beadmob's floored standard errors, tau not subtracted)."""
    fit = beadmob_extrapolate(h, mean, standard_error)
    h, mean, standard_error = (np.asarray(v, dtype=float) for v in (h, mean, standard_error))
    n = len(h)
    sigma = bar_module.floored_standard_error(standard_error, mean)
    weights = 1.0 / (sigma**2 + fit.excess_deviation**2)
    full_row = intercept_row(h, weights, 2)
    order = np.argsort(h, kind="stable")
    if n > 3:
        reduced = np.zeros(n)
        reduced[order[:-1]] = intercept_row(h[order[:-1]], weights[order[:-1]], 2)
        others = [reduced, intercept_row(h, weights, 3)]
    else:
        line = np.zeros(n)
        line[order[:3]] = intercept_row(h[order[:3]], weights[order[:3]], 1)
        others = [line]
    spread = max(np.sqrt(max(((row - full_row) @ mean) ** 2 - np.sum((row - full_row) ** 2 * sigma**2), 0.0))
                 for row in others)
    return FixedSpread(**fit.__dict__, spread=float(spread))


def model_average(h, mean, standard_error):
    """Jay and Neil's model average over the line and the quadratic through the finest n levels
    (every n with at least as many levels as parameters), with beadmob's level weights (its floor
    and excess tau^2 of the full quadratic); the bar is 2 sigma of the average, its spread 0."""
    fit = beadmob_extrapolate(h, mean, standard_error)
    h, mean, standard_error = (np.asarray(v, dtype=float) for v in (h, mean, standard_error))
    n = len(h)
    weights = 1.0 / (bar_module.floored_standard_error(standard_error, mean) ** 2 + fit.excess_deviation**2)
    order = np.argsort(h, kind="stable")
    criteria, values, variances = [], [], []
    for degree in (1, 2):
        for kept in range(degree + 1, n + 1):
            chosen = order[:kept]
            coefficients, variance, chi2 = bar_module._weighted_polynomial(h[chosen], mean[chosen], weights[chosen],
                                                                          degree)
            criteria.append(chi2 + 2 * (degree + 1) + 2 * (n - kept))
            values.append(coefficients[0])
            variances.append(variance)
    criteria, values, variances = np.array(criteria), np.array(values), np.array(variances)
    probability = np.exp(-(criteria - criteria.min()) / 2)
    probability /= probability.sum()
    value = float(probability @ values)
    total = float(probability @ variances + probability @ (values - value) ** 2)
    return FixedSpread(value, np.sqrt(total), fit.linear_value, fit.reduced_value, fit.reduced_chi2,
                       fit.excess_deviation, fit.plain_reduced_chi2, spread=0.0)


def _law_fit(design, y, w):
    normal = design.T @ (w[:, None] * design)
    covariance = np.linalg.inv(normal)
    coefficients = covariance @ (design.T @ (w * y))
    return coefficients, covariance, float(np.sum(w * (y - design @ coefficients) ** 2))


def level_volume_variance(job):
    """v_k: each level's variance of its samples' bead volume over the offsets / the body's volume^2."""
    with h5py.File(job) as f:
        c = f["continuum"]
        volume = np.asarray(c["sample_moments"][()], dtype=float).reshape(-1, 13)[:, 0]
        level = np.asarray(c.attrs["sample_level"]).reshape(-1)
        body = float(np.asarray(c["body_moments"][()]).reshape(13)[0])
    return np.array([np.var(volume[level == k], ddof=1) / body**2 if np.sum(level == k) > 1 else 0.0
                     for k in range(1, level.max() + 1)])


def covariate_extrapolation(v):
    """beadmob's extrapolation with g v_k added to the law where |g| >= 2 sd (the variant's docstring)."""
    def extrapolate(h, mean, standard_error):
        fit = beadmob_extrapolate(h, mean, standard_error)
        h, mean, standard_error = (np.asarray(x, dtype=float) for x in (h, mean, standard_error))
        n = len(h)
        if n < 6 or np.ptp(v) == 0:
            return fit
        s2 = bar_module.floored_standard_error(standard_error, mean) ** 2
        design = np.column_stack([np.ones(n), h, h**2, v])
        excess = 0.0
        if _law_fit(design, mean, 1 / s2)[2] > n - 4:   # random effects, as excess_variance for 4 terms
            lower, upper = 0.0, _law_fit(design, mean, np.ones(n))[2] / (n - 4)
            for _ in range(200):
                middle = (lower + upper) / 2
                lower, upper = (middle, upper) if _law_fit(design, mean, 1 / (s2 + middle))[2] > n - 4 else (lower, middle)
            excess = upper
        weights = 1 / (s2 + excess)
        coefficients, covariance, _ = _law_fit(design, mean, weights)
        if abs(coefficients[3]) < 2 * np.sqrt(covariance[3, 3]):
            return fit
        kept = np.argsort(h, kind="stable")[: n - 1]
        reduced = _law_fit(design[kept], mean[kept], weights[kept])[0][0]
        kappa3 = _law_fit(design, h**3, weights)[0][0]
        next_term = abs(coefficients[2] ** 2 / coefficients[1] * kappa3) if coefficients[1] != 0 else np.inf
        spread = max(abs(reduced - coefficients[0]), min(abs(fit.linear_value - coefficients[0]), next_term))
        return FixedSpread(float(coefficients[0]), float(np.sqrt(covariance[0, 0])), fit.linear_value, float(reduced),
                           fit.reduced_chi2, float(np.sqrt(excess)), fit.plain_reduced_chi2, spread=float(spread))
    return extrapolate


def half_range_extrapolation(h, mean, standard_error):
    fit = beadmob_extrapolate(h, mean, standard_error)
    return HalfRangeSpread(fit.value, fit.standard_error, fit.linear_value, fit.reduced_value, fit.reduced_chi2)


def sample_features(path, with_moments):
    """Per sample: log volume and (with_moments) the six central second moments over their mean trace."""
    with h5py.File(path) as f:
        moments = np.asarray(f["continuum/sample_moments"][()], dtype=float)
    volume = moments[:, 0]
    centre = moments[:, 1:4] / volume[:, None]
    second = moments[:, 4:13].reshape(-1, 3, 3) / volume[:, None, None] - np.einsum("si,sj->sij", centre, centre)
    columns = [np.log(volume)]
    if with_moments:
        scale = np.trace(second.mean(axis=0)) / 3
        columns += [second[:, i, j] / scale for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))]
    return np.column_stack(columns)


def regressed_bar(features):
    """combination_bar with the pooled regression of the samples on `features` done first."""
    def combination_bar(samples, weights, power):
        values = np.einsum("sjk,jk->s", samples.sample_mobility, np.asarray(weights, dtype=float))
        level = samples.sample_level
        centred_x, centred_y, scale = features.copy(), values.copy(), np.empty_like(values)
        for k in np.unique(level):
            chosen = level == k
            centred_x[chosen] -= features[chosen].mean(axis=0)
            centred_y[chosen] -= values[chosen].mean()
            scale[chosen] = values[chosen].mean()
        beta = np.linalg.lstsq(centred_x, centred_y / scale, rcond=None)[0]
        values = values - scale * (centred_x @ beta)
        mean, error = bar_module.level_means(values, level, len(samples.bead_diameters))
        fit = bar_module.extrapolate(samples.bead_diameters, mean, error)
        return fit.value, fit.fit_error + abs(fit.value) * power / 3.0 * samples.volume_error / samples.volume, fit
    return combination_bar


beadmob_extrapolate = bar_module.extrapolate
line_extrapolate = spread_variant(LineSpread)
beadmob_combination_bar = bar_module.combination_bar
beadmob_read_samples = bar_module.read_samples


def samples_reader(with_moments):
    """read_samples with the sample and body moments the moment control uses (from any file since
    the moments were written) or without them (the estimator before the moment control)."""
    def read_samples(path):
        samples = beadmob_read_samples(path)
        if not with_moments:
            return dataclasses.replace(samples, sample_moments=None, body_moments=None)
        with h5py.File(path, "r") as f:
            c = f["continuum"]
            return dataclasses.replace(samples, sample_moments=np.asarray(c["sample_moments"][()], dtype=float).reshape(
                len(samples.sample_level), 13), body_moments=np.asarray(c["body_moments"][()], dtype=float).reshape(13))
    return read_samples


def use_variant(variant, job):
    """Set continuum_bar's functions for `variant` on the kept job result `job` (h5 path)."""
    bar_module.extrapolate = {"chi^2 inflation": inflated_extrapolation,
                              "floor 0.5": floored_extrapolation(0.5), "floor 1": floored_extrapolation(1.0),
                              "half-range spread": half_range_extrapolation,
                              "cubic beyond noise": cubic_beyond_noise,
                              "model average (AIC)": model_average,
                              "no line": spread_variant(ReducedSpread),
                              "2 sigma alone": spread_variant(NoSpread),
                              "next term": beadmob_extrapolate}.get(variant, line_extrapolate)
    bar_module.combination_bar = beadmob_combination_bar
    bar_module.read_samples = samples_reader(variant in MOMENT_VARIANTS)
    if variant.endswith("regression"):
        bar_module.combination_bar = regressed_bar(sample_features(job, variant == "moment regression"))
    if variant == "volume variance covariate":
        bar_module.extrapolate = covariate_extrapolation(level_volume_variance(job))


def coverage_row(variant, folder):
    """Held / entries, median and smallest bar / error of the variant's replayed values and bars (the value
    too is the variant's: its weights move the intercept)."""
    held, total, ratios = 0, 0, []
    for body in coverage.BODIES:
        for form in body.forms:
            job = folder / f"{body.key}-{form}"
            if not (job / "job.h5").exists() or "failed" in json.loads((job / "meta.json").read_text()):
                continue
            use_variant(variant, job / "job.h5")
            rotation = np.array(json.loads((job / "meta.json").read_text())["rotation"])
            replayed = bar_module.principal_diagonal(bar_module.read_samples(job / "job.h5"), rotation)
            for (value, bar, _), exact in zip(replayed, body.exact()):
                if np.isnan(exact):
                    continue
                total += 1
                held += abs(value - exact) <= bar
                ratios.append(bar / abs(value - exact))
    return held, total, float(np.median(ratios)), float(np.min(ratios))


def nonconvex_bars(variant, folder):
    """{body: (largest translation bar %, largest rotation bar %)} in the principal frame."""
    bars = {}
    for key in NONCONVEX:
        job = folder / key / "job.h5"
        if not job.exists():
            continue
        use_variant(variant, job)
        with h5py.File(job) as f:
            axes = np.asarray(f["continuum/equivalent_axes"][()]).T   # h5py rows are the Fortran columns
        relative = [100 * b / abs(v) for v, b, _ in bar_module.principal_diagonal(bar_module.read_samples(job), axes)]
        bars[key] = (max(relative[:3]), max(relative[3:]))
    return bars


def sphere_row(variant, files):
    """Held / entries and the largest error / bar of the six diagonal entries of each sphere job
    (radius 1, viscosity 1) against Stokes: 1 / (6 pi), 1 / (8 pi)."""
    exact = np.array([1 / (6 * np.pi)] * 3 + [1 / (8 * np.pi)] * 3)
    ratios = []
    for path in files:
        use_variant(variant, path)
        replayed = bar_module.principal_diagonal(bar_module.read_samples(path), np.eye(3))
        ratios += [abs(value - e) / bar for (value, bar, _), e in zip(replayed, exact)]
    return int(np.sum(np.array(ratios) <= 1)), len(ratios), float(np.max(ratios))


def job_sizes(folder):
    sizes = {}
    for key in NONCONVEX:
        job = folder / key / "job.h5"
        if job.exists():
            with h5py.File(job) as f:
                c = f["continuum"]
                sizes[key] = (float(c.attrs["time_budget"]), int(np.max(c.attrs["sample_beads"])))
    return sizes


def has_control_samples(job):
    with h5py.File(job, "r") as f:
        return f["continuum"].attrs.get("control_offsets", 0) > 0


def shown(folder):
    """A kept-jobs folder as written in the table: relative to the repository when inside it."""
    folder = folder.resolve()
    return folder.relative_to(ROOT) if folder.is_relative_to(ROOT) else folder


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--coverage", default=str(HERE / "coverage_final_runs"))
    parser.add_argument("--nonconvex", default=str(HERE / "nonconvex_runs"))
    parser.add_argument("--spheres", nargs="*", default=[],
                        help="result files of continuum jobs of a sphere of radius 1 (e.g. CTest continuum_np2's) "
                             "to replay against Stokes")
    parser.add_argument("--variants", default=None,
                        help="comma-separated names of the variants to replay (default: all, in the order above)")
    parser.add_argument("--out", default=str(HERE / "estimator_variants.md"))
    args = parser.parse_args()
    chosen = VARIANTS if args.variants is None else tuple(v.strip() for v in args.variants.split(","))
    unknown = [v for v in chosen if v not in VARIANTS]
    if unknown:
        parser.error(f"unknown variant(s) {unknown}; known: {', '.join(VARIANTS)}")
    coverage_folder, nonconvex_folder = Path(args.coverage), Path(args.nonconvex)
    sizes = job_sizes(nonconvex_folder)
    lines = ["# Error-bar estimators replayed on kept continuum jobs", "",
             f"Written by `bench/continuum/estimator_variants.py` on {time.strftime('%Y-%m-%d')} from the jobs kept in "
             f"`{shown(coverage_folder)}` (coverage.py) and `{shown(nonconvex_folder)}` "
             "(nonconvex.py); nothing solved. The non-convex jobs replayed here: "
             + ", ".join(f"{k} ({b:.0f} s budget, finest level {n} beads)" for k, (b, n) in sizes.items())
             + ". Variants: see the script's docstring.", "",
             "| variant | coverage (held / entries) | median bar / error | smallest bar / error | "
             + " | ".join(f"{k} t / r %" for k in sizes) + " |" + (" spheres (held / entries, largest error / bar) |"
                                                                  if args.spheres else ""),
             "|---|---|---|---|" + "---|" * (len(sizes) + bool(args.spheres))]
    controlled = any(has_control_samples(job) for job in coverage_folder.glob("*/job.h5"))
    for variant in chosen:
        if controlled and variant.endswith("regression"):
            # Their regression is of each sample's order-L value, which a control sample lacks.
            lines.append(f"| {variant} | not replayed: jobs with control samples (a control sample has no order-L value "
                         "to regress) |" + " |" * (len(sizes) + 2))
            continue
        held, total, median, smallest = coverage_row(variant, coverage_folder)
        bars = nonconvex_bars(variant, nonconvex_folder)
        lines.append(f"| {variant} | {held} / {total} | {median:.2f} | {smallest:.2f} | "
                     + " | ".join(f"{bars[k][0]:.3f} / {bars[k][1]:.3f}" for k in sizes) + " |")
        if args.spheres:
            held, total, worst = sphere_row(variant, args.spheres)
            lines[-1] += f" {held} / {total}, {worst:.2f} |"
        print(lines[-1], flush=True)
    Path(args.out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
