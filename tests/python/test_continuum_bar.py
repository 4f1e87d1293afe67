"""beadmob_post.continuum_bar: the continuum job's estimator (docs/theory.md T18) replayed for a
linear combination of mobility entries.

- Level means on an exact straight line in h: the intercept is its constant, no spread, the bar
  only the volume term p / 3 * (relative volume error) * |value|; on an exact quadratic the
  intercept and the reduced fit are its constant and the spread is the line's miss.
- Noisy levels: the intercept is numpy's least squares of beadmob_post.continuum.quadratic_fit
  (an independent implementation of the same weights, its random-effects excess found by scipy's
  root finder), the bar hypot(2 sigma, spread) + volume term.
- A body seen turned: samples M_s = Q D_s Q^T; the principal diagonal replayed with Q equals the
  replay of the unturned samples D_s entry by entry.
- Moment control (docs/theory.md T18): on samples exactly linear in their moment features the
  shift is numpy's least squares of the deviations from the level means (the ridge's leave-one-out
  choice falls on no ridge) and leaves each level's value; too few samples get none.
- Real result files of the test suite (continuum_np2's spheres, when BEADMOB_TEST_OUTPUT_DIR
  holds them; filled.h5 has samples enough for the moment control): the replay reproduces each
  file's 36 error bars and its diagonal.
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from beadmob_post.continuum import quadratic_fit
from beadmob_post.continuum_bar import (combination_bar, controlled_level_means, entry_power, extrapolate, level_means,
                                        moment_control_shift, principal_diagonal,
                                        read_samples, replay_discrepancy)

H = 0.3 * 2.0 ** (-np.arange(7) / 3)


def write_file(path, samples, levels, volume=4.0, volume_error=0.004):
    """A /continuum group as beadmob writes it (Fortran (36, S) arrays read by h5py as (S, 36))."""
    with h5py.File(path, "w") as f:
        c = f.create_group("continuum")
        c["bead_diameters"] = H
        c.attrs["sample_level"] = np.asarray(levels, dtype=np.int32)
        c["sample_mobility"] = np.stack([m.reshape(36, order="F") for m in samples])
        c.attrs["volume"] = volume
        c.attrs["volume_standard_error"] = volume_error
        c["mobility"] = np.eye(6)
        c["mobility_error"] = np.ones((6, 6))
    return path


def noisy_samples(rng, base, offsets=4):
    samples, levels = [], []
    for k, h in enumerate(H):
        for _ in range(offsets):
            noise = rng.normal(scale=2e-4, size=(6, 6))
            samples.append(base * (1 + 0.3 * h - 0.5 * h**2) + noise + noise.T)
            levels.append(k + 1)
    return samples, np.array(levels)


def test_exact_line_has_only_the_volume_term(tmp_path):
    base = np.diag([0.05, 0.04, 0.03, 0.02, 0.015, 0.01])
    samples = [base * (1 + 0.3 * h) for h in H for _ in range(3)]
    levels = np.repeat(np.arange(1, 8), 3)
    data = read_samples(write_file(tmp_path / "c.h5", samples, levels))
    for i in range(6):
        weights = np.zeros((6, 6))
        weights[i, i] = 1
        value, bar, fit = combination_bar(data, weights, entry_power(i, i))
        assert value == pytest.approx(base[i, i], rel=1e-10)
        assert fit.model_spread == pytest.approx(0, abs=1e-12 * base[i, i])
        # (2 sigma: of the 1e-9 floor on the standard errors, ~1e-8 of the value)
        assert bar == pytest.approx(entry_power(i, i) / 3 * 0.001 * base[i, i], abs=1e-8 * base[i, i])


def test_exact_quadratic_spread_is_the_next_term(tmp_path):
    # Seven levels: the spread is the h^3 term foreseen from the quadratic's b = 0.015 and c = -0.025,
    # c^2 / b times the intercept numpy's least squares of h^3 on [1, h, h^2] gives (equal weights),
    # where that is below the line's distance (numpy.polyfit of the three finest levels).
    mean = 0.05 * (1 + 0.3 * H - 0.5 * H**2)
    fit = extrapolate(H, mean, np.full(7, 1e-5))
    line = np.polyfit(H[-3:], mean[-3:], 1)[1]
    kappa3 = np.linalg.lstsq(np.vander(H, 3, increasing=True), H**3, rcond=None)[0][0]
    next_term = 0.025**2 / 0.015 * abs(kappa3)
    assert fit.value == pytest.approx(0.05, rel=1e-10)
    assert fit.reduced_value == pytest.approx(0.05, rel=1e-10)
    assert next_term < abs(line - 0.05)
    assert fit.next_term == pytest.approx(next_term, rel=1e-8)
    assert fit.model_spread == pytest.approx(next_term, rel=1e-8)
    # Four levels foresee nothing: the spread is the line's distance.
    fit = extrapolate(H[-4:], mean[-4:], np.full(4, 1e-5))
    assert fit.next_term == np.inf
    assert fit.model_spread == pytest.approx(abs(line - 0.05), rel=1e-8)


def test_noisy_levels_match_numpy_refit():
    rng = np.random.default_rng(1)
    mean = 0.05 * (1 + 0.3 * H - 0.5 * H**2) + rng.normal(scale=1e-4, size=7)
    error = rng.uniform(2e-5, 1e-4, size=7)
    error[3] = 1e-7                          # below the floor: counts as a fifth of the median
    fit = extrapolate(H, mean, error)
    # the levels scatter more than their standard errors say: the random-effects excess is engaged
    assert fit.reduced_chi2 == pytest.approx(1.0, rel=1e-9)
    assert fit.value == pytest.approx(quadratic_fit(H, mean, error)[0], rel=1e-10)
    assert fit.fit_error == pytest.approx(np.hypot(2 * fit.standard_error, fit.model_spread))
    assert fit.standard_error > 0 and fit.model_spread > 0


def test_vanishing_entry_replays_as_zero(tmp_path):
    """An entry that symmetry makes exactly zero in every sample (a coupling of a body with mirror
    planes): value 0 and a bar of the floor (1e-154), not a singular fit of infinite weights."""
    base = np.diag([0.05, 0.04, 0.03, 0.02, 0.015, 0.01])
    samples = [base * (1 + 0.3 * h) for h in H for _ in range(4)]
    data = read_samples(write_file(tmp_path / "z.h5", samples, np.repeat(np.arange(1, 8), 4)))
    weights = np.zeros((6, 6))
    weights[0, 4] = 1
    value, bar, fit = combination_bar(data, weights, entry_power(0, 4))
    assert value == 0 and bar < 1e-100 and np.isfinite(fit.standard_error)


def test_level_means():
    mean, error = level_means(np.array([1.0, 3.0, 5.0, 2.0]), np.array([1, 1, 2, 2]), 2)
    assert mean == pytest.approx([2.0, 3.5])
    assert error == pytest.approx([1.0, 1.5])


def test_controlled_level_mean_is_unbiased_and_its_error_is_its_scatter():
    """The control-variate level mean (docs/theory.md T18, "Control samples"), 2 paired samples
    and 8 in all, y = 5 + 1.003 x + noise of 0.1 sd(x): over 20000 draws its mean is the true 5 and
    its scatter what its standard error says (Monte Carlo against the formula, 3 % on the variance:
    the draws' own sampling error is 1 %), about half the scatter of the plain mean of the 2 paired
    samples, sqrt((1.003^2 + 0.01) / 2) = 0.71 times the controls' sd."""
    rng = np.random.default_rng(20261128)
    draws, pairs, total = 20000, 2, 8
    x = rng.normal(size=(draws, total))
    y = 5.0 + 1.003 * x[:, :pairs] + 0.1 * rng.normal(size=(draws, pairs))
    level = np.ones(total, dtype=int)
    full = np.array([1] * pairs + [0] * (total - pairs))
    estimates, variances = np.zeros(draws), np.zeros(draws)
    for i in range(draws):
        values = np.concatenate([y[i], np.zeros(total - pairs)])
        mean, error = controlled_level_means(values, x[i], full, level, 1)
        estimates[i], variances[i] = mean[0], error[0] ** 2
    assert abs(estimates.mean() - 5.0) < 4 * estimates.std() / np.sqrt(draws)
    assert estimates.var() == pytest.approx(variances.mean(), rel=0.03)
    assert estimates.std() < 0.6 * np.sqrt((1.003**2 + 0.01) / pairs)


def test_turned_body_replays_its_principal_entries(tmp_path):
    rng = np.random.default_rng(7)
    base = np.diag([0.05, 0.04, 0.03, 0.02, 0.015, 0.01])
    principal, levels = noisy_samples(rng, base)
    turn, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q = np.zeros((6, 6))
    q[:3, :3] = q[3:, 3:] = turn
    plain = read_samples(write_file(tmp_path / "plain.h5", principal, levels))
    turned = read_samples(write_file(tmp_path / "turned.h5", [q @ m @ q.T for m in principal], levels))
    for i, (value, bar, _) in enumerate(principal_diagonal(turned, turn)):
        weights = np.zeros((6, 6))
        weights[i, i] = 1
        expected_value, expected_bar, _ = combination_bar(plain, weights, entry_power(i, i))
        assert value == pytest.approx(expected_value, rel=1e-12)
        assert bar == pytest.approx(expected_bar, rel=1e-8)


def test_moment_control_on_linear_samples():
    rng = np.random.default_rng(11)
    levels = np.repeat([1, 2, 3], 20)
    features = rng.normal(size=(60, 10))
    body = rng.normal(size=10)
    sensitivity = rng.normal(size=10)
    level_value = np.array([2.0, 1.5, 1.2])[levels - 1]
    target = level_value + 0.01 * (features - body) @ sensitivity
    shift, factor = moment_control_shift(target, levels, features, body)
    centred, deviation = features.copy(), target.copy()
    for k in (1, 2, 3):
        chosen = levels == k
        centred[chosen] -= features[chosen].mean(axis=0)
        deviation[chosen] -= target[chosen].mean()
    beta = np.linalg.lstsq(centred, deviation, rcond=None)[0]
    assert beta == pytest.approx(0.01 * sensitivity, rel=1e-9)
    assert shift == pytest.approx((features - body) @ beta, rel=1e-9, abs=1e-12)
    assert factor == pytest.approx(57 / 47, rel=1e-9)
    # the shifted values are the level values exactly: the linear part removed at the body's moments
    assert target - shift == pytest.approx(level_value, rel=1e-12)
    few, factor = moment_control_shift(target[:20], levels[:20], features[:20], body)
    assert np.all(few == 0.0) and factor == 1.0


@pytest.mark.parametrize("name", ["sphere.h5", "controlled.h5", "filled.h5"])
def test_real_continuum_file(beadmob_output_dir, name):
    path = beadmob_output_dir / "continuum" / name
    if not path.exists():
        pytest.skip(f"{path} not written (CTest continuum_np2 runs before pytest)")
    assert replay_discrepancy(read_samples(path)) < 1e-8
