"""Weighted fit of tan(theta/2) = A exp(-t/tau) to a measured theta(t) series (paper, App. D).

The model is eq. `eq:exp_exp`, the solution of eqs. `so51`/`so42` in dimensional time; the
weights are w_i = 1/sigma_i^2 with sigma_i the uncertainty of tan(theta_i/2), eq. `eq:ang_err`;
the goodness of fit is the weighted R^2 of Appendix "Parameters of the fit" (Table
`tab:fitting_param`). scipy's ``curve_fit`` does the weighted nonlinear least squares (as
MATLAB's fit in the paper).

Input CSV (header line required, ``#`` comment lines allowed, comma separated):

* ``t`` -- time in seconds (or any unit: 1/tau comes out in its inverse);
* ``theta_deg`` or ``theta_rad`` -- the inclination angle theta;
* optional uncertainty, first found wins: ``sigma_tan`` (of tan(theta/2)); ``sigma_theta_deg``
  or ``sigma_theta_rad`` (of theta; sigma_tan = (1 + tan^2(theta/2)) sigma_theta / 2); or the
  equivalent ellipse of Appendix C, ``n_pixels``, ``a``, ``b`` (eq. `eq:ang_err`). Without any,
  all weights are 1.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import curve_fit
from scipy.stats import t as student_t


class SeriesError(ValueError):
    """A theta(t) file cannot be used; the message names the file and the problem."""


@dataclass(frozen=True)
class Series:
    path: str
    t: np.ndarray
    theta: np.ndarray          # radians
    sigma_tan: np.ndarray | None
    weighting: str             # how sigma was obtained

    @property
    def tan_half_theta(self) -> np.ndarray:
        return np.tan(self.theta / 2.0)


def sigma_tan_from_ellipse(theta: np.ndarray, n_pixels, a, b) -> np.ndarray:
    """Eq. `eq:ang_err`: (1 + tan^2(theta/2)) a b / (2 sqrt(N_B) |a^2 - b^2|)."""
    n_pixels, a, b = (np.asarray(v, dtype=float) for v in (n_pixels, a, b))
    return (1.0 + np.tan(theta / 2.0) ** 2) * a * b / (2.0 * np.sqrt(n_pixels) * np.abs(a**2 - b**2))


def read_series(path: str | Path) -> Series:
    """Read a theta(t) CSV (format in the module docstring)."""
    path = Path(path)
    if not path.exists():
        raise SeriesError(f"{path}: no such file")
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            lines = [line for line in handle if line.strip() and not line.lstrip().startswith("#")]
    except (OSError, UnicodeDecodeError) as exc:
        raise SeriesError(f"{path}: cannot read the file: {exc}") from exc
    if not lines:
        raise SeriesError(f"{path}: empty file (expected a header line and data)")
    reader = csv.DictReader(lines, skipinitialspace=True)
    header = [name.strip() for name in (reader.fieldnames or [])]
    reader.fieldnames = header
    if "t" not in header or not ({"theta_deg", "theta_rad"} & set(header)):
        raise SeriesError(
            f"{path}: the header must name columns 't' and 'theta_deg' or 'theta_rad' "
            f"(found: {', '.join(header) or 'nothing'})"
        )
    rows = list(reader)
    columns: dict[str, np.ndarray] = {}
    for name in header:
        values = []
        for line_number, row in enumerate(rows, start=2):
            text = (row.get(name) or "").strip()
            try:
                value = float(text)
            except ValueError:
                raise SeriesError(
                    f"{path}: data line {line_number - 1}, column {name!r}: {text!r} is not a number"
                ) from None
            if not math.isfinite(value):
                raise SeriesError(f"{path}: data line {line_number - 1}, column {name!r} is not finite")
            values.append(value)
        columns[name] = np.array(values)
    if len(rows) < 3:
        raise SeriesError(f"{path}: {len(rows)} data lines; the fit of A and tau needs at least 3")
    theta = columns["theta_rad"] if "theta_rad" in columns else np.radians(columns["theta_deg"])
    sigma, weighting = None, "unweighted (no uncertainty column)"
    if "sigma_tan" in columns:
        sigma, weighting = columns["sigma_tan"], "sigma_tan column"
    elif "sigma_theta_rad" in columns or "sigma_theta_deg" in columns:
        sigma_theta = (columns["sigma_theta_rad"] if "sigma_theta_rad" in columns
                       else np.radians(columns["sigma_theta_deg"]))
        sigma = 0.5 * (1.0 + np.tan(theta / 2.0) ** 2) * sigma_theta
        weighting = "sigma_theta column, propagated as in eq:ang_err"
    elif {"n_pixels", "a", "b"} <= set(columns):
        sigma = sigma_tan_from_ellipse(theta, columns["n_pixels"], columns["a"], columns["b"])
        weighting = "equivalent ellipse (n_pixels, a, b), eq:ang_err"
    if sigma is not None and not np.all(sigma > 0):
        raise SeriesError(f"{path}: every uncertainty must be positive (weights 1/sigma^2)")
    return Series(str(path), columns["t"], theta, sigma, weighting)


@dataclass(frozen=True)
class FitResult:
    path: str
    n: int
    amplitude: float           # A
    amplitude_error: float     # standard error
    rate: float                # 1/tau (per unit of t)
    rate_error: float
    r_squared: float           # weighted R^2 of Appendix D
    weighting: str
    confidence: float          # level of the *_halfwidth values
    amplitude_halfwidth: float
    rate_halfwidth: float

    @property
    def tau(self) -> float:
        return 1.0 / self.rate


def model(t: np.ndarray, amplitude: float, rate: float) -> np.ndarray:
    """Eq. `eq:exp_exp` with rate = 1/tau."""
    return amplitude * np.exp(-rate * t)


def weighted_r_squared(y: np.ndarray, y_model: np.ndarray, weights: np.ndarray) -> float:
    """R^2 = 1 - sum w (y - y^)^2 / sum w (y - y_w)^2, y_w the weighted mean (Appendix D)."""
    mean = np.sum(weights * y) / np.sum(weights)
    return 1.0 - np.sum(weights * (y - y_model) ** 2) / np.sum(weights * (y - mean) ** 2)


def fit_series(series: Series, confidence: float = 0.95) -> FitResult:
    """Weighted fit of eq. `eq:exp_exp`; errors are curve_fit's standard errors.

    With weights from measured uncertainties the covariance is scaled by the reduced chi^2
    (``absolute_sigma=False``), as MATLAB's fit does; ``*_halfwidth`` are the Student-t
    confidence half-widths at ``confidence`` (MATLAB reports 95 % bounds).
    """
    y = series.tan_half_theta
    t = series.t
    if np.any(np.abs(series.theta) >= np.pi):
        raise SeriesError(f"{series.path}: theta must lie in (-pi, pi) (tan(theta/2) finite)")
    # Start from the straight line through log y (log y = log A - t/tau); noise may push the
    # last, small values below zero, which the fit itself accepts.
    positive = y > 0
    if positive.sum() < 2:
        raise SeriesError(f"{series.path}: fewer than two samples with theta > 0")
    slope, intercept = np.polyfit(t[positive], np.log(y[positive]), 1)
    try:
        parameters, covariance = curve_fit(
            model, t, y, p0=(math.exp(intercept), -slope), sigma=series.sigma_tan,
            absolute_sigma=False, maxfev=10_000,
        )
    except (RuntimeError, ValueError) as exc:
        raise SeriesError(f"{series.path}: the fit did not converge: {exc}") from exc
    errors = np.sqrt(np.diag(covariance))
    weights = np.ones_like(y) if series.sigma_tan is None else series.sigma_tan ** -2.0
    r_squared = weighted_r_squared(y, model(t, *parameters), weights)
    dof = max(len(t) - 2, 1)
    factor = float(student_t.ppf(0.5 + confidence / 2.0, dof))
    return FitResult(
        path=series.path, n=len(t),
        amplitude=float(parameters[0]), amplitude_error=float(errors[0]),
        rate=float(parameters[1]), rate_error=float(errors[1]),
        r_squared=float(r_squared), weighting=series.weighting, confidence=confidence,
        amplitude_halfwidth=factor * float(errors[0]), rate_halfwidth=factor * float(errors[1]),
    )


def synthetic_series(
    amplitude: float, rate: float, t: np.ndarray, n_pixels: float, a: float, b: float,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """A noisy theta(t) (radians) and sigma of tan(theta/2) for tests and demonstrations.

    tan(theta/2) = A exp(-rate t) plus Gaussian noise of the eq. `eq:ang_err` size.
    """
    clean = amplitude * np.exp(-rate * np.asarray(t))
    theta_clean = 2.0 * np.arctan(clean)
    sigma = sigma_tan_from_ellipse(theta_clean, n_pixels, a, b)
    noisy = clean + rng.normal(0.0, sigma)
    return 2.0 * np.arctan(noisy), sigma
