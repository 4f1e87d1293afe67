"""Tests of beadmob_post.fitting: the weighted fit of Appendix D."""

from __future__ import annotations

import numpy as np
import pytest

from beadmob_post import dynamics
from beadmob_post.fitting import (
    SeriesError,
    fit_series,
    read_series,
    sigma_tan_from_ellipse,
    synthetic_series,
    weighted_r_squared,
)
from beadmob_post.mobility import pattern_mobility
from beadmob_post.paper import TAB_FITTING_PARAM

#: An equivalent ellipse of a few thousand pixels (Appendix C): sigma_theta ~ 0.6 degree.
PIXELS, MAJOR, MINOR = 2000.0, 40.0, 15.0


def write_series(path, t, theta, extra: dict | None = None, theta_column="theta_rad"):
    columns = {"t": t, theta_column: theta, **(extra or {})}
    header = ",".join(columns)
    data = np.column_stack(list(columns.values()))
    np.savetxt(path, data, delimiter=",", header=header, comments="", fmt="%.12g")
    return path


def test_weighted_r_squared_by_hand():
    # y_w = (1 + 2 + 2*3)/4 = 2.25; sum w (y - y^)^2 = 2; sum w (y - y_w)^2 = 2.75.
    value = weighted_r_squared(np.array([1.0, 2.0, 3.0]), np.array([1.0, 2.0, 2.0]),
                               np.array([1.0, 1.0, 2.0]))
    assert value == pytest.approx(1 - 2 / 2.75)


def test_sigma_from_the_ellipse_is_eq_ang_err():
    theta = np.radians(90.0)  # tan(theta/2) = 1, so the factor 1 + tan^2 = 2
    expected = 2 * MAJOR * MINOR / (2 * np.sqrt(PIXELS) * (MAJOR**2 - MINOR**2))
    assert sigma_tan_from_ellipse(theta, PIXELS, MAJOR, MINOR) == pytest.approx(expected)


def test_noise_free_series_is_fitted_exactly(tmp_path):
    t = np.arange(0.0, 40.0, 1.0)
    theta = 2 * np.arctan(5.776 * np.exp(-0.2136 * t))  # arrowhead trial, tab:fitting_param
    fit = fit_series(read_series(write_series(tmp_path / "a.csv", t, theta)))
    assert fit.amplitude == pytest.approx(5.776, rel=1e-9)
    assert fit.rate == pytest.approx(0.2136, rel=1e-9)
    assert fit.r_squared == pytest.approx(1.0, abs=1e-12)
    assert fit.weighting.startswith("unweighted")


@pytest.mark.parametrize("label, amplitude, _da, rate, _dr, _r2", TAB_FITTING_PARAM[:2])
def test_noisy_series_recovers_known_parameters(tmp_path, label, amplitude, _da, rate, _dr, _r2):
    # A synthetic trial with the parameters of Table tab:fitting_param (cone, crescent moon),
    # sampled at 1 frame per second over 68 s (section "Results ... inverted orientations"),
    # with noise of the size of eq. eq:ang_err.
    rng = np.random.default_rng(2024)
    t = np.arange(0.0, 69.0, 1.0)
    theta, _ = synthetic_series(amplitude, rate, t, PIXELS, MAJOR, MINOR, rng)
    extra = {"n_pixels": np.full_like(t, PIXELS), "a": np.full_like(t, MAJOR),
             "b": np.full_like(t, MINOR)}
    series = read_series(write_series(tmp_path / f"{label}.csv", t, np.degrees(theta), extra,
                                      theta_column="theta_deg"))
    fit = fit_series(series)
    assert series.weighting.startswith("equivalent ellipse")
    assert abs(fit.amplitude - amplitude) < 4 * fit.amplitude_error
    assert abs(fit.rate - rate) < 4 * fit.rate_error
    assert fit.rate == pytest.approx(rate, rel=0.02)
    assert fit.r_squared > 0.99
    assert fit.rate_halfwidth > fit.rate_error  # 95 % Student-t bound wider than one sigma


def test_standard_errors_cover_the_truth_about_68_percent_of_the_time():
    from beadmob_post.fitting import Series

    rng = np.random.default_rng(7)
    t = np.arange(0.0, 40.0, 1.0)
    hits = 0
    trials = 200
    for _ in range(trials):
        theta, sigma = synthetic_series(2.0, 0.1, t, PIXELS, MAJOR, MINOR, rng)
        fit = fit_series(Series("mc", t, theta, sigma, "test"))
        hits += abs(fit.rate - 0.1) < fit.rate_error
    assert 0.55 < hits / trials < 0.80


def test_sigma_theta_column_is_propagated(tmp_path):
    t = np.arange(0.0, 10.0)
    theta = 2 * np.arctan(2.0 * np.exp(-0.3 * t))
    series = read_series(write_series(tmp_path / "s.csv", t, theta,
                                      {"sigma_theta_rad": np.full_like(t, 0.01)}))
    np.testing.assert_allclose(series.sigma_tan, 0.5 * (1 + np.tan(theta / 2) ** 2) * 0.01)


def test_dynamics_output_fits_back_to_mu51(tmp_path):
    # The CSV of the orientation integration is a valid fit input; in dimensionless time the
    # fitted 1/tau is -mu51 (eq. so51 with eq. eq:exp_exp), and R^2 = 1.
    mobility = pattern_mobility(0.42, 0.37, 0.40, 0.050, -0.067)
    trajectory = dynamics.integrate(mobility, dynamics.planar_orientation(170.0, "y"), 60.0,
                                    n_samples=100)
    path = tmp_path / "dynamics.csv"
    dynamics.write_csv(trajectory, path)
    fit = fit_series(read_series(path))
    assert fit.rate == pytest.approx(0.067, rel=1e-7)
    assert fit.amplitude == pytest.approx(np.tan(np.radians(85.0)), rel=1e-7)
    assert fit.r_squared == pytest.approx(1.0, abs=1e-10)


@pytest.mark.parametrize(
    "content, message",
    [
        ("", "empty file"),
        ("time,angle\n0,1\n1,2\n2,3\n", "must name columns 't' and 'theta_deg' or 'theta_rad'"),
        ("t,theta_deg\n0,100\n1,abc\n2,80\n", "data line 2, column 'theta_deg': 'abc' is not a number"),
        ("t,theta_deg\n0,100\n1,90\n", "2 data lines; the fit of A and tau needs at least 3"),
        ("t,theta_deg,sigma_tan\n0,100,0.1\n1,90,0\n2,80,0.1\n", "every uncertainty must be positive"),
        ("t,theta_deg\n0,nan\n1,90\n2,80\n", "is not finite"),
    ],
)
def test_bad_series_files(tmp_path, content, message):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    with pytest.raises(SeriesError, match=message):
        read_series(path)


def test_theta_outside_the_range_is_reported(tmp_path):
    path = write_series(tmp_path / "big.csv", np.arange(3.0), np.array([0.5, 3.2, 0.2]))
    with pytest.raises(SeriesError, match=r"theta must lie in \(-pi, pi\)"):
        fit_series(read_series(path))
    path = write_series(tmp_path / "neg.csv", np.arange(3.0), np.array([0.5, -0.1, -0.2]))
    with pytest.raises(SeriesError, match="fewer than two samples with theta > 0"):
        fit_series(read_series(path))


def test_missing_series_file(tmp_path):
    with pytest.raises(SeriesError, match="no such file"):
        read_series(tmp_path / "none.csv")
