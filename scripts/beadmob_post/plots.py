"""Figures: coefficients beside the paper, orientation dynamics, fits, benchmarks (PNG or PDF).

Object-oriented matplotlib only (``Figure``, no pyplot), as in :mod:`beadmob_post.beadplot`.
"""

from __future__ import annotations

from pathlib import Path
import numpy as np
from matplotlib.figure import Figure

from beadmob_post import bench as bench_module
from beadmob_post.beadplot import SUPPORTED_SUFFIXES
from beadmob_post.paper import COEFFICIENT_NAMES

DEFAULT_DPI = 120
_GREEK = {"mu11": r"$\mu_{11}$", "mu22": r"$\mu_{22}$", "mu33": r"$\mu_{33}$",
          "mu42": r"$\mu_{42}$", "mu51": r"$\mu_{51}$"}


def save(figure: Figure, path: str | Path, dpi: int = DEFAULT_DPI) -> Path:
    """Write ``figure`` as .png or .pdf (by suffix); returns the path."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUPPORTED_SUFFIXES:
        raise ValueError(f"{path}: unsupported picture format {suffix or '(no suffix)'!r}; "
                         f"use one of {', '.join(SUPPORTED_SUFFIXES)}")
    figure.savefig(path, format=suffix.lstrip("."), dpi=dpi)
    return path


def coefficient_bars(rows) -> Figure:
    """One panel per coefficient: beadmob bars beside the paper's (Table `tab_mob_num`)."""
    rows = [row for row in rows if row.coefficients is not None]
    if not rows:
        raise ValueError("no result file with /hydrodynamics: no coefficients to draw")
    figure = Figure(figsize=(3.2 * len(COEFFICIENT_NAMES), 4.2), layout="constrained")
    axes_row = figure.subplots(1, len(COEFFICIENT_NAMES))
    positions = np.arange(len(rows))
    width = 0.38
    for axes, name in zip(axes_row, COEFFICIENT_NAMES):
        ours = [row.values[name] for row in rows]
        paper = [getattr(row.paper, name) if row.paper is not None else np.nan for row in rows]
        axes.bar(positions - width / 2, ours, width, label="beadmob", color="tab:blue")
        axes.bar(positions + width / 2, paper, width, label="paper (tab_mob_num)", color="tab:orange")
        axes.axhline(0.0, color="black", linewidth=0.6)
        axes.set_xticks(positions, [row.label for row in rows], rotation=45, ha="right")
        axes.set_title(_GREEK[name])
    handles, names = axes_row[0].get_legend_handles_labels()
    figure.legend(handles, names, loc="outside lower center", ncols=2)
    orders = sorted({row.coefficients.multipole_order for row in rows} - {None})
    lubrication = {row.coefficients.lubrication for row in rows}
    method = {frozenset({True}): " + lubrication",
              frozenset({False}): ", no lubrication correction"}.get(frozenset(lubrication), "")
    figure.suptitle("Mobility coefficients, beadmob (multipole order "
                    f"{', '.join(map(str, orders)) or '?'}{method}) vs paper (order 2 + lubrication)")
    return figure


def dynamics_figure(trajectory, title: str, closed_form: np.ndarray | None = None,
                    time_unit_s: float | None = None) -> Figure:
    """theta(t), phi(t) and psi(t); path of body z on the sphere; centre-of-mass path."""
    t = trajectory.t * (time_unit_s or 1.0)
    t_label = "time $\\tilde t$ (s)" if time_unit_s else "time $t$ (eq. time)"
    figure = Figure(figsize=(14, 8), layout="constrained")
    grid = figure.subplots(2, 2)
    ax = grid[0, 0]
    ax.plot(t, np.degrees(trajectory.theta), label=r"$\theta$ (solve_ivp)")
    if closed_form is not None:
        ax.plot(t, np.degrees(closed_form), "k--", linewidth=1,
                label=r"$\tan(\theta/2) = A e^{\mu t}$ (paper)")
    ax.set_xlabel(t_label)
    ax.set_ylabel(r"$\theta$ (deg)")
    ax.legend()
    ax = grid[0, 1]
    ax.plot(t, np.degrees(trajectory.phi), label=r"$\phi$ (azimuth of $z$)")
    ax.plot(t, np.degrees(trajectory.psi), label=r"$\psi$ (spin about $z$)")
    ax.set_xlabel(t_label)
    ax.set_ylabel("angle (deg)")
    ax.legend()
    ax = grid[1, 0]
    # Azimuthal equidistant view of the body z axis: radius theta, angle phi.
    theta_deg = np.degrees(trajectory.theta)
    ax.plot(theta_deg * np.cos(trajectory.phi), theta_deg * np.sin(trajectory.phi))
    ax.plot(theta_deg[0] * np.cos(trajectory.phi[0]), theta_deg[0] * np.sin(trajectory.phi[0]),
            "o", label="start")
    ax.plot(0, 0, "k+", markersize=10, label=r"$\theta = 0$")
    circle = np.linspace(0, 2 * np.pi, 200)
    for radius in (90, 180):
        ax.plot(radius * np.cos(circle), radius * np.sin(circle), color="grey", linewidth=0.5)
    ax.set_aspect("equal")
    ax.set_xlabel(r"$\theta\cos\phi$ (deg)")
    ax.set_ylabel(r"$\theta\sin\phi$ (deg)")
    ax.set_title("body $z$ axis seen from above")
    ax.legend(fontsize="small")
    ax = grid[1, 1]
    position = trajectory.position
    ax.plot(position[:, 0], position[:, 2], label="X-Z")
    ax.plot(position[:, 1], position[:, 2], label="Y-Z")
    ax.set_xlabel("horizontal position / L")
    ax.set_ylabel("Z / L")
    ax.set_title("centre of mass")
    ax.legend()
    figure.suptitle(title)
    return figure


def fit_figure(series, fit) -> Figure:
    """tan(theta/2) with error bars and the fitted eq. `eq:exp_exp` (log scale)."""
    from beadmob_post.fitting import model

    figure = Figure(figsize=(7, 4.5), layout="constrained")
    ax = figure.subplots()
    y = series.tan_half_theta
    ax.errorbar(series.t, y, yerr=series.sigma_tan, fmt="o", markersize=3, label="data")
    fine = np.linspace(series.t.min(), series.t.max(), 300)
    ax.plot(fine, model(fine, fit.amplitude, fit.rate), "k-",
            label=f"A = {fit.amplitude:.3f}, 1/τ = {fit.rate:.4g}, R² = {fit.r_squared:.3f}")
    ax.set_yscale("log")
    ax.set_xlabel("time")
    ax.set_ylabel(r"$\tan(\theta/2)$")
    ax.legend()
    ax.set_title(Path(series.path).name)
    return figure


def bench_figure(runs, kind: str, x: str = "n_beads") -> Figure:
    """``time-vs-n``, ``time-vs-error`` or ``convergence`` (coefficients against ``x``)."""
    groups = bench_module.by_series(runs)
    if kind == "convergence":
        figure = Figure(figsize=(3.2 * len(COEFFICIENT_NAMES), 4.0), layout="constrained")
        axes_row = figure.subplots(1, len(COEFFICIENT_NAMES))
        drawn = False
        for axes, name in zip(axes_row, COEFFICIENT_NAMES):
            for series, members in groups.items():
                points = sorted((r.get(x), r.get(name)) for r in members
                                if r.get(x) is not None and r.get(name) is not None)
                if points:
                    drawn = True
                    axes.plot(*zip(*points), "o-", label=series)
            axes.set_xlabel(x)
            axes.set_title(_GREEK[name])
        if not drawn:
            raise ValueError(f"no lines with both {x} and a coefficient column: nothing to draw")
        axes_row[0].legend(fontsize="small")
        figure.suptitle("Convergence of the mobility coefficients")
        return figure
    figure = Figure(figsize=(7, 5), layout="constrained")
    ax = figure.subplots()
    if kind == "time-vs-n":
        for series, members in groups.items():
            n = np.array([r.values["n_beads"] for r in members])
            time = np.array([r.values["wall_time_s"] for r in members])
            order = np.argsort(n)
            slope = bench_module.power_law_exponent(n, time)
            label = series if slope is None else f"{series} (time ~ N^{slope:.2f})"
            ax.plot(n[order], time[order], "o-", label=label)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("number of beads N")
        ax.set_ylabel("wall time (s)")
        ax.set_title("Wall time against N")
    elif kind == "time-vs-error":
        drawn = False
        for series, members in groups.items():
            points = sorted((r.values["wall_time_s"], e) for r, e in bench_module.errors(members) if e > 0)
            if points:
                drawn = True
                ax.plot(*zip(*points), "o-", label=series)
        if not drawn:
            raise ValueError("no line has an error (an 'error' column or coefficients and a "
                             "reference line): nothing to draw")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("relative error of the coefficients")
        ax.set_title("Error against wall time")
    else:
        raise ValueError(f"unknown benchmark plot {kind!r}")
    ax.legend()
    return figure


def default_output(path: Path, suffix: str) -> Path:
    return path.with_name(f"{path.stem}_{suffix}.png")


def write_both(figure: Figure, stem: Path, dpi: int = DEFAULT_DPI) -> list[Path]:
    """Save ``figure`` as ``stem``.png and ``stem``.pdf."""
    return [save(figure, stem.with_suffix(".png"), dpi), save(figure, stem.with_suffix(".pdf"), dpi)]


