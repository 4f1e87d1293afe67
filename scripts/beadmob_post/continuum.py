"""The continuum job's results (&continuum; the /continuum group, docs/output.md): reading, the
extrapolation redone here from the level means (an independent check of beadmob's), and the
convergence figure (each coefficient's level means against the bead diameter, the quadratic to
zero bead size and the continuum value with its error bar)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
from matplotlib.figure import Figure
from scipy.optimize import brentq

from beadmob_post.paper import COEFFICIENT_NAMES


@dataclass(frozen=True)
class ContinuumResult:
    bead_diameters: np.ndarray          # (K,) coarsest first, the shape's length unit
    level_coefficients: np.ndarray      # (K, 5) mean over each level's offsets
    level_coefficient_error: np.ndarray  # (K, 5) standard error of that mean
    sample_level: np.ndarray            # (S,) 1-based level of each sample
    sample_coefficients: np.ndarray     # (S, 5)
    coefficients: np.ndarray            # (5,) continuum values
    coefficient_error: np.ndarray       # (5,) their error bars
    mobility: np.ndarray                # (6, 6)
    mobility_error: np.ndarray          # (6, 6)
    reference_length: float
    volume: float
    #: Where reference_length came from: "input", "body" (the body's own extent along body x) or
    #: "finest level" (the finest bead model's outer size: every file written before 2026-11-29).
    reference_length_from: str = "finest level"


def load_continuum(path: str | Path) -> ContinuumResult:
    """The /continuum group of a result file (ValueError when the file has none)."""
    with h5py.File(path, "r") as f:
        if "continuum" not in f:
            raise ValueError(f"{path}: no /continuum group (not a continuum job's result)")
        c = f["continuum"]
        levels = len(c["bead_diameters"])

        def per_level(name, width):
            values = np.asarray(c[name][()])
            return values if values.shape == (levels, width) else values.T

        samples = np.asarray(c.attrs["sample_level"]).reshape(-1)
        sample_coefficients = np.asarray(c["sample_coefficients"][()])
        if sample_coefficients.shape != (len(samples), 5):
            sample_coefficients = sample_coefficients.T
        return ContinuumResult(
            bead_diameters=np.asarray(c["bead_diameters"][()]),
            level_coefficients=per_level("level_coefficients", 5),
            level_coefficient_error=per_level("level_coefficient_error", 5),
            sample_level=samples, sample_coefficients=sample_coefficients,
            coefficients=np.asarray(c["coefficients"][()]),
            coefficient_error=np.asarray(c["coefficient_error"][()]),
            mobility=np.asarray(c["mobility"][()]), mobility_error=np.asarray(c["mobility_error"][()]),
            reference_length=float(c.attrs["reference_length"]), volume=float(c.attrs["volume"]),
            reference_length_from=_text(c.attrs.get("reference_length_from", b"finest level")))


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _floored_errors(mean: np.ndarray, standard_error: np.ndarray) -> np.ndarray:
    median = np.sort(standard_error)[(len(standard_error) - 1) // 2]
    return np.maximum.reduce([standard_error, np.full_like(standard_error, 0.2 * median), 1e-9 * np.abs(mean),
                              np.full_like(standard_error, np.sqrt(np.finfo(float).tiny))])


def _weighted_quadratic(h, mean, sigma, excess):
    """numpy's least squares of mean ~ c0 + c1 h + c2 h^2 with weights 1 / (sigma^2 + excess): (c, chi^2)."""
    scale = np.sqrt(sigma**2 + excess)
    basis = np.vander(h, 3, increasing=True)
    c = np.linalg.lstsq(basis / scale[:, None], mean / scale, rcond=None)[0]
    return c, float(np.sum(((mean - basis @ c) / scale) ** 2))


def level_excess(h: np.ndarray, mean: np.ndarray, standard_error: np.ndarray) -> float:
    """tau of beadmob's fit (continuum_fit.f90): 0, or the excess standard deviation tau at which the
    quadratic's chi^2 with weights 1 / (s_k^2 + tau^2) is K - 3 (Paule & Mandel 1982); s_k the
    standard error floored at a fifth of the median level's and 1e-9 |mean|. scipy's root finder on
    numpy's least squares, not beadmob's bisection of its normal equations."""
    h, mean = np.asarray(h, dtype=float), np.asarray(mean, dtype=float)
    sigma = _floored_errors(mean, np.asarray(standard_error, dtype=float))
    dof = len(h) - 3
    if dof <= 0 or _weighted_quadratic(h, mean, sigma, 0.0)[1] <= dof:
        return 0.0
    basis = np.vander(h, 3, increasing=True)
    upper = float(np.sum((mean - basis @ np.linalg.lstsq(basis, mean, rcond=None)[0]) ** 2)) / dof
    return float(np.sqrt(brentq(lambda t: _weighted_quadratic(h, mean, sigma, t)[1] - dof, 0.0, upper,
                                xtol=1e-15 * upper, rtol=1e-14)))


def quadratic_fit(h: np.ndarray, mean: np.ndarray, standard_error: np.ndarray) -> np.ndarray:
    """Coefficients (c0, c1, c2) of mean ~ c0 + c1 h + c2 h^2 by beadmob's weights (continuum_fit.f90):
    1 / (s_k^2 + tau^2), s_k the floored standard error and tau the levels' excess (level_excess)."""
    h, mean = np.asarray(h, dtype=float), np.asarray(mean, dtype=float)
    sigma = _floored_errors(mean, np.asarray(standard_error, dtype=float))
    return _weighted_quadratic(h, mean, sigma, level_excess(h, mean, standard_error) ** 2)[0]


def convergence_figure(result: ContinuumResult, title: str = "") -> Figure:
    """One panel per coefficient: the samples, the level means +- standard error against the
    bead diameter, the quadratic fit and the continuum value with its error bar at d = 0."""
    figure = Figure(figsize=(13, 3.4), layout="constrained")
    axes = figure.subplots(1, 5)
    h = result.bead_diameters
    curve = np.linspace(0.0, h.max() * 1.05, 100)
    for k, (ax, name) in enumerate(zip(axes, COEFFICIENT_NAMES)):
        ax.plot(h[result.sample_level - 1], result.sample_coefficients[:, k], ".", color="0.6", label="offsets")
        ax.errorbar(h, result.level_coefficients[:, k], yerr=result.level_coefficient_error[:, k], fmt="o",
                    color="C0", label="level mean")
        c = quadratic_fit(h, result.level_coefficients[:, k], result.level_coefficient_error[:, k])
        ax.plot(curve, c[0] + c[1] * curve + c[2] * curve**2, "-", color="C0", lw=1)
        ax.errorbar([0.0], [result.coefficients[k]], yerr=[result.coefficient_error[k]], fmt="s", color="C3",
                    capsize=4, label="continuum")
        ax.set_title(name)
        ax.set_xlabel("bead diameter")
    axes[0].legend(fontsize="small")
    if title:
        figure.suptitle(title)
    return figure


__all__ = ["ContinuumResult", "load_continuum", "level_excess", "quadratic_fit", "convergence_figure"]
