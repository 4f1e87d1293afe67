"""The analysis subcommands of ``beadmob-post`` (coefficients, classify, dynamics, fit,
table, compare, plot-coefficients, plot-bench, report, diffusion, orbit).

Each handler takes the parsed arguments and the output stream and returns the exit status;
failures raise :class:`CommandError` (or ResultFileError / ValueError subclasses), which
``cli.main`` prints as one ``beadmob-post: error: ...`` line. scipy and matplotlib are imported
inside the handlers that need them, so ``info`` stays quick.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from beadmob_post.classify import (
    DEFAULT_ZERO_TOLERANCE,
    STANDARD_GRAVITY,
    bead_model_volume_m3,
    classify,
    physical_scales,
    physical_times,
)
from beadmob_post.mobility import FRICTION_CHOICES, Coefficients, compute_coefficients
from beadmob_post.paper import COEFFICIENT_NAMES, TAB_MOB_NUM, PaperBeadModel, paper_counterpart, paper_row
from beadmob_post.results import load_result


class CommandError(Exception):
    """A failure to report as ``beadmob-post: error: <message>``."""


# ----------------------------------------------------------------------------- parser
def add_analysis_commands(commands) -> None:
    """Add the analysis subcommands to the ``add_subparsers`` object ``commands``."""
    p = commands.add_parser(
        "coefficients", help="the paper's mu11 mu22 mu33 mu42 mu51 and the off-pattern entries",
        description="Compute the dimensionless coefficients of eq. (matrices) of the settlers "
        "paper from the 6x6 mobility of a result file: body frame of the paper (mirror-plane "
        "normals, x along the larger in-plane size, z so that theta = 0 is stable), centre of "
        "mass as reference point, L from the file or --reference-length. Lists the entries the "
        "paper's form assumes to be zero.")
    _file_argument(p)
    _hydro_options(p)
    p.add_argument("--all", action="store_true", help="list every off-pattern entry, not the largest 5")
    p.add_argument("--json", action="store_true", help="print as JSON")
    p.set_defaults(handler=run_coefficients)

    p = commands.add_parser(
        "classify", help="settler / drifter / flutterer, reorientation times, terminal velocity",
        description="Classify the body from the signs of mu42 and mu51 (settler when "
        "mu42 mu51 < 0), give the time coefficients tau51 = 1/mu51 and tau42 = 1/mu42 in the "
        "dimensionless time of eq. (eq:time) and U_f = mu33 (unit F/(pi eta L)); with the "
        "physical options, the same in seconds and m/s (eq. eq:mobility, eq:mju33).")
    _file_argument(p, optional=True)
    _hydro_options(p)
    _paper_option(p)
    p.add_argument("--zero-tolerance", type=float, default=DEFAULT_ZERO_TOLERANCE,
                   help="mu42, mu51 count as zero below this times max(mu11, mu22, mu33) "
                   f"(default {DEFAULT_ZERO_TOLERANCE:g})")
    _physical_options(p)
    p.add_argument("--json", action="store_true", help="print as JSON")
    p.set_defaults(handler=run_classify)

    p = commands.add_parser(
        "dynamics", help="integrate the 3-D orientation under gravity; plot theta(t), phi(t)",
        description="Integrate the rigid-body orientation (quaternion, scipy solve_ivp) and the "
        "centre-of-mass path of the settling body with its computed mobility, from any initial "
        "orientation R = Rz(phi) Ry(theta) Rz(psi). With --plane the start is a tilt about body "
        "y = lab Y or x = X and the paper's closed form tan(theta/2) = A exp(mu t) is drawn and "
        "checked.")
    _file_argument(p, optional=True)
    _hydro_options(p)
    _paper_option(p)
    p.add_argument("--theta", type=float, default=170.0, help="initial theta (deg; default 170)")
    p.add_argument("--phi", type=float, default=None, help="initial phi (deg; default 0)")
    p.add_argument("--psi", type=float, default=None, help="initial psi (deg; default 0)")
    p.add_argument("--plane", choices=("x", "y"),
                   help="planar start: rotation about y = Y (mu51) or x = X (mu42)")
    p.add_argument("--t-end", type=float, help="end of the dimensionless time (default: 12 "
                   "e-folds of the slower planar rotation)")
    p.add_argument("--samples", type=int, default=400, help="output samples (default 400)")
    p.add_argument("--pattern-only", action="store_true",
                   help="use only the five coefficients (paper's form), not the full mobility")
    p.add_argument("-o", "--output", type=Path, help="figure (.png/.pdf; default <FILE stem>_dynamics.png)")
    p.add_argument("--csv", type=Path, help="also write the samples as CSV")
    _physical_options(p)
    p.set_defaults(handler=run_dynamics)

    p = commands.add_parser(
        "fit", help="weighted fit of tan(theta/2) = A exp(-t/tau) to measured theta(t) (App. D)",
        description="Fit eq. (eq:exp_exp) to theta(t) series (CSV: columns t, theta_deg or "
        "theta_rad, optional sigma_tan / sigma_theta_deg / sigma_theta_rad / n_pixels,a,b) with "
        "weights 1/sigma^2 and the weighted R^2 of Appendix D; prints the table in the form of "
        "Table tab:fitting_param.")
    p.add_argument("files", type=Path, nargs="+", metavar="CSV", help="theta(t) series")
    _table_options(p)
    p.add_argument("--confidence", type=float, default=0.95,
                   help="level of the confidence half-widths in --json/CSV (default 0.95)")
    p.add_argument("--plot-dir", type=Path, help="write <series>_fit.png there")
    p.add_argument("--json", action="store_true", help="print the fits as JSON")
    p.add_argument("--axis", choices=("x", "y"),
                   help="rotation axis of the trials: y gives mu51 = -pi eta L^2/(F tau), x gives "
                   "mu42 = pi eta L^2/(F tau) (needs the physical options)")
    _physical_options(p, with_volume=False)
    p.set_defaults(handler=run_fit)

    for name, helptext, handler in (
        ("table", "one table of many result files (CSV, Markdown, LaTeX)", run_table),
        ("compare", "result files beside the paper's Table tab_mob_num, relative differences", run_compare),
    ):
        p = commands.add_parser(name, help=helptext, description=helptext + ". Files without "
                                "/hydrodynamics contribute their geometry (N, L/d) only.")
        p.add_argument("files", type=Path, nargs="+", metavar="FILE", help="beadmob result files")
        _table_options(p)
        p.add_argument("--allow-unconverged", action="store_true",
                       help="accept files whose solves beadmob flagged as not converged")
        _friction_option(p)
        if name == "compare":
            p.add_argument("--plot", type=Path, help="also draw the coefficient bars (.png/.pdf)")
        p.set_defaults(handler=handler)

    p = commands.add_parser("plot-coefficients", help="bars of the coefficients beside the paper's",
                            description="Bars of mu11 ... mu51 of each file beside Table tab_mob_num.")
    p.add_argument("files", type=Path, nargs="+", metavar="FILE", help="beadmob result files")
    p.add_argument("-o", "--output", type=Path, required=True, help="figure (.png or .pdf)")
    p.add_argument("--allow-unconverged", action="store_true", help=argparse.SUPPRESS)
    _friction_option(p)
    p.set_defaults(handler=run_plot_coefficients)

    p = commands.add_parser(
        "plot-bench", help="benchmark/convergence plots from a bench/ CSV",
        description="Plots from a benchmark CSV (format 'beadmob-bench 1', see "
        "docs/postprocessing.md): time-vs-n (log-log, fitted exponent), time-vs-error, "
        "convergence (coefficients against --x).")
    p.add_argument("file", type=Path, metavar="CSV", help="benchmark table")
    p.add_argument("--kind", choices=("time-vs-n", "time-vs-error", "convergence"), default="time-vs-n")
    p.add_argument("--x", default="n_beads", choices=("n_beads", "multipole_order"),
                   help="abscissa of the convergence plot")
    p.add_argument("-o", "--output", type=Path, help="figure (.png/.pdf; default <CSV stem>_<kind>.png)")
    p.set_defaults(handler=run_plot_bench)

    p = commands.add_parser(
        "continuum", help="a continuum job's values and its convergence plot",
        description="Print the continuum coefficients of a continuum job's result file "
        "(&continuum, /continuum) with their error bars and the level means they come from, "
        "and draw each coefficient against the bead diameter with the quadratic to zero bead "
        "size (-o).")
    _file_argument(p)
    p.add_argument("-o", "--output", type=Path, help="convergence figure (.png/.pdf)")
    p.add_argument("--json", action="store_true", help="print as JSON")
    p.set_defaults(handler=run_continuum)

    p = commands.add_parser(
        "report", help="all tables and figures of a set of result files in one directory",
        description="Write into DIR: coefficients.{csv,md,tex} (table), comparison.{csv,md,tex} "
        "(beside the paper's Table tab_mob_num), coefficients_vs_paper.{png,pdf} (when any file "
        "has /hydrodynamics) and <stem>_beads.png for every file.")
    p.add_argument("files", type=Path, nargs="+", metavar="FILE", help="beadmob result files")
    p.add_argument("-o", "--output-dir", type=Path, required=True, metavar="DIR")
    p.add_argument("--no-beads", action="store_true", help="skip the bead pictures")
    p.add_argument("--allow-unconverged", action="store_true", help=argparse.SUPPRESS)
    _friction_option(p)
    p.set_defaults(handler=run_report)

    p = commands.add_parser(
        "diffusion", help="diffusion tensor, Stokes radius, relaxation times; [eta] and B with /flow",
        description="From the mobility: the centre of diffusion (Harvey & Garcia de la Torre 1980; the "
        "same point as beadmob's centre of mobility), the diffusion tensor D = kT M there, D_t = tr(D_tt)/3, "
        "the Stokes radius kT/(6 pi eta D_t), the rotational diffusion constants (eigenvalues of D_rr), the "
        "five l = 2 relaxation times (Favro 1960) and their harmonic mean. With /flow: the intrinsic "
        "viscosity [eta] (eta_eff = eta (1 + [eta] phi)) without and with rotary Brownian motion (zero "
        "shear), and Bretherton's constant B. Dimensionless (kT = eta = 1, lengths in the file's unit) "
        "unless --temperature, --viscosity and --length-unit are given.")
    _file_argument(p)
    p.add_argument("--temperature", type=float, metavar="K", help="temperature T (K)")
    p.add_argument("--viscosity", type=float, metavar="PA_S", help="solvent viscosity eta (Pa s)")
    p.add_argument("--length-unit", type=float, metavar="M",
                   help="metres per length unit of the file (the bead diameter d)")
    p.add_argument("--volume", type=float, metavar="V",
                   help="the body's volume in the file's length unit cubed (default: /continuum volume, "
                   "else N d^3, a lattice cell per bead)")
    p.add_argument("--allow-unconverged", action="store_true",
                   help="use a file whose solves beadmob flagged as not converged")
    _friction_option(p)
    p.add_argument("--json", action="store_true", help="print as JSON")
    p.set_defaults(handler=run_diffusion)

    p = commands.add_parser(
        "orbit", help="orientation of the body in simple shear (Jeffery orbits for any shape)",
        description="Integrate the orientation of the force- and torque-free body in the shear flow "
        "u = gamma y e_x from /flow/velocity_per_strain (any shape; vorticity along -z), and the drift of "
        "its centre relative to the flow, to the strain gamma t = --strain. Prints each body axis's "
        "period (its return to its start) and, for a body of revolution, Bretherton's constant, "
        "Jeffery's period and orbit constant.")
    _file_argument(p)
    p.add_argument("--strain", type=float, default=100.0, help="final strain gamma t (default 100)")
    p.add_argument("--initial-axis", metavar="X,Y,Z",
                   help="initial lab direction of the body axis --axis (default: the body as in the input)")
    p.add_argument("--axis", choices=("x", "y", "z", "symmetry"),
                   help="the body axis set by --initial-axis: x, y, z of /geometry/body_axes or the "
                   "symmetry axis (default: symmetry for a body of revolution, else z)")
    p.add_argument("--samples", type=int, default=2001, help="output samples (default 2001)")
    p.add_argument("--method", choices=("quaternion", "rkmk"), default="quaternion",
                   help="integrator: scipy DOP853 on the quaternion (default) or Munthe-Kaas RK4 on SO(3)")
    p.add_argument("--tolerance", type=float, default=1e-5,
                   help="largest distance of a return to the start (default 1e-5)")
    p.add_argument("--allow-unconverged", action="store_true",
                   help="use a /flow whose strain solves beadmob flagged as not converged")
    p.add_argument("--plot", type=Path, metavar="OUT", help="angles of the body axes against the strain (.png/.pdf)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(handler=run_orbit)


def _file_argument(parser, optional: bool = False) -> None:
    parser.add_argument("file", type=Path, metavar="FILE", nargs="?" if optional else None,
                        help="beadmob result file with /hydrodynamics"
                        + (" (or --paper SHAPE)" if optional else ""))


def _paper_option(parser) -> None:
    parser.add_argument("--paper", choices=[row.shape for row in TAB_MOB_NUM], metavar="SHAPE",
                        help="instead of FILE: the coefficients of Table tab_mob_num for SHAPE "
                        "(paper's form only)")


def _hydro_options(parser) -> None:
    parser.add_argument("--reference-length", type=float, metavar="L",
                        help="reference length L in bead diameters (default: the file's)")
    parser.add_argument("--allow-unconverged", action="store_true",
                        help="use a file whose solves beadmob flagged as not converged")
    _friction_option(parser)


def _friction_option(parser) -> None:
    parser.add_argument(
        "--friction", choices=FRICTION_CHOICES, default="default",
        help="which friction of /hydrodynamics: 'default' = friction (with the lubrication "
        "correction when the run had it on), 'multipole' = multipole_friction (the order-L "
        "friction alone, without the lubrication correction)")


def _table_options(parser) -> None:
    parser.add_argument("-o", "--output", type=Path, help="write the table here (format from .csv/.md/.tex)")
    parser.add_argument("--format", choices=("csv", "md", "tex"),
                        help="table format on stdout (default md; with -o: from its suffix)")


def _physical_options(parser, with_volume: bool = True) -> None:
    group = parser.add_argument_group(
        "physical units (SI)",
        "give --length-m, a viscosity and one of force / buoyant mass / density difference "
        "to get seconds and m/s")
    group.add_argument("--length-m", type=float, help="the reference length L in metres")
    group.add_argument("--viscosity", type=float, help="dynamic viscosity eta (Pa s)")
    group.add_argument("--kinematic-viscosity", type=float, help="nu (m^2/s), with --fluid-density")
    group.add_argument("--fluid-density", type=float, help="fluid density (kg/m^3); also gives Re")
    group.add_argument("--force", type=float, help="F = gravity minus buoyancy (N)")
    group.add_argument("--buoyant-mass", type=float, help="buoyant mass (kg): F = m_b g")
    group.add_argument("--density-difference", type=float,
                       help="particle minus fluid density (kg/m^3): F = |delta rho| V g")
    if with_volume:
        group.add_argument("--volume", type=float,
                           help="particle volume (m^3; default: N spheres of d = L/(L/d))")
    group.add_argument("--gravity", type=float, default=STANDARD_GRAVITY, help="g (m/s^2)")


def _scales(arguments, coefficients: Coefficients | None):
    """PhysicalScales from the options, or None when no physical option was given."""
    names = ("length_m", "viscosity", "kinematic_viscosity", "fluid_density", "force",
             "buoyant_mass", "density_difference", "volume")
    if all(getattr(arguments, name, None) is None for name in names):
        return None
    if arguments.length_m is None:
        raise CommandError("physical units need --length-m (the reference length L in metres)")
    volume = getattr(arguments, "volume", None)
    if arguments.density_difference is not None and volume is None:
        if coefficients is None:
            raise CommandError("--density-difference needs the particle volume")
        volume = bead_model_volume_m3(coefficients.n_beads, coefficients.reference_length,
                                      arguments.length_m)
    try:
        return physical_scales(
            arguments.length_m, viscosity_Pa_s=arguments.viscosity,
            kinematic_viscosity_m2_s=arguments.kinematic_viscosity,
            fluid_density_kg_m3=arguments.fluid_density, force_N=arguments.force,
            buoyant_mass_kg=arguments.buoyant_mass,
            density_difference_kg_m3=arguments.density_difference, volume_m3=volume,
            gravity_m_s2=arguments.gravity)
    except ValueError as exc:
        raise CommandError(f"physical units: {exc}") from exc


def _coefficients(arguments) -> Coefficients:
    paper = getattr(arguments, "paper", None)
    if paper is not None or arguments.file is None:
        if paper is None:
            raise CommandError("give a result FILE or --paper SHAPE")
        if arguments.file is not None:
            raise CommandError("give either a result FILE or --paper SHAPE, not both")
        return paper_coefficients(paper_row(paper))
    if arguments.reference_length is not None and not arguments.reference_length > 0:
        raise CommandError(f"--reference-length must be positive, got {arguments.reference_length}")
    return compute_coefficients(load_result(arguments.file), arguments.reference_length,
                                allow_unconverged=arguments.allow_unconverged,
                                friction=arguments.friction)


def paper_coefficients(row: PaperBeadModel) -> Coefficients:
    """Table `tab_mob_num` values as Coefficients in the paper's form (no off-pattern part)."""
    from beadmob_post.mobility import pattern_mobility

    return Coefficients(
        path=f"paper:{row.shape}", shape=row.shape, n_beads=row.n_beads,
        reference_length=float(row.length_over_d),
        mu11=row.mu11, mu22=row.mu22, mu33=row.mu33, mu42=row.mu42, mu51=row.mu51,
        body_axes=np.eye(3), dimensionless_body_mobility=pattern_mobility(*row.coefficients()),
        z_reversed=False, xy_swapped=False, off_pattern=0.0, off_pattern_entries=(),
        mirror_planes=(1.0, 1.0, 0.0), paper_class=True, multipole_order=2, lubrication=True,
        all_converged=True,
    )


def _write_json(out: TextIO, data: Any) -> None:
    out.write(json.dumps(data, indent=2, default=_json_default) + "\n")


def _json_default(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(type(value).__name__)


def _g(value: float) -> str:
    return "inf" if math.isinf(value) else f"{value:.6g}"


# ----------------------------------------------------------------------------- coefficients
def coefficients_summary(c: Coefficients) -> dict[str, Any]:
    return {
        "file": c.path, "shape": c.shape, "n_beads": c.n_beads,
        "reference_length": c.reference_length,
        "coefficients": c.as_dict(),
        "ratio_51_42": c.ratio_51_42, "sum_over_51": c.sum_over_51,
        "body_axes": c.body_axes, "z_reversed": c.z_reversed, "xy_swapped": c.xy_swapped,
        "off_pattern": c.off_pattern,
        "off_pattern_entries": [
            {"block": e.block, "row": e.row, "column": e.column, "value": e.value,
             "relative": e.relative} for e in c.off_pattern_entries],
        "mirror_planes": c.mirror_planes, "paper_class": c.paper_class,
        "multipole_order": c.multipole_order, "lubrication": c.lubrication,
        "friction": c.friction, "run_lubrication": c.run_lubrication,
        "all_converged": c.all_converged,
        "dimensionless_body_mobility": c.dimensionless_body_mobility,
        "error_bar": None if c.error_bar is None else {
            "companion_order": c.error_bar.companion_order,
            "errors": dict(zip(COEFFICIENT_NAMES, c.error_bar.errors)),
            "scaled_errors": dict(zip(COEFFICIENT_NAMES, c.error_bar.scaled_errors)),
            "extrapolated": dict(zip(COEFFICIENT_NAMES, c.error_bar.extrapolated)),
            "extrapolated_errors": dict(zip(COEFFICIENT_NAMES, c.error_bar.extrapolated_errors)),
            "largest": c.error_bar.largest, "largest_extrapolated": c.error_bar.largest_extrapolated},
    }


def run_coefficients(arguments, out: TextIO) -> int:
    c = _coefficients(arguments)
    if arguments.json:
        _write_json(out, coefficients_summary(c))
        return 0
    lines = [f"file:             {c.path}",
             f"shape:            {c.shape}, N = {c.n_beads}, L = {c.reference_length:g} d",
             "method:           multipole order "
             f"{c.multipole_order if c.multipole_order is not None else '?'}, lubrication "
             f"{'?' if c.lubrication is None else ('yes' if c.lubrication else 'no')}"
             + (" (/hydrodynamics/multipole_friction: order-L friction"
                + ("; the run's lubrication correction left out)" if c.run_lubrication else ")")
                if c.friction == "multipole" else "")]
    if c.all_converged is False:
        lines.append("WARNING:          beadmob flagged the solves as not converged")
    bar = c.error_bar
    for k, (name, value) in enumerate(c.as_dict().items()):
        paper = paper_counterpart(c.shape, c.reference_length)
        ref = f"   (paper: {getattr(paper, name):.3f})" if paper is not None else ""
        error = f" +- {bar.errors[k]:.6f}   extrapolated {bar.extrapolated[k]: .6f} +- " \
                f"{bar.extrapolated_errors[k]:.6f}" if bar is not None else ""
        lines.append(f"{name}:             {value: .6f}{error}{ref}")
    if bar is not None:
        lines.append(f"error bar:        estimated truncation error (companion of order {bar.companion_order}); "
                     f"largest over the mobility {bar.largest:.2g} on the scale sqrt(M_ii M_jj), "
                     f"extrapolated {bar.largest_extrapolated:.2g}")
    else:
        lines.append("error bar:        none in the file (L = 1, error_estimate off, or an older beadmob)")
    lines.append(f"|mu51/mu42|:      {_g(c.ratio_51_42)}")
    lines.append(f"(mu51+mu42)/|mu51|: {_g(c.sum_over_51)}")
    for name, axis in zip("xyz", c.body_axes):
        lines.append(f"body axis {name}:      ({', '.join(f'{v:.6g}' for v in axis)})")
    notes = []
    if c.xy_swapped:
        notes.append("x and y of /geometry/body_axes exchanged (x along the larger size)")
    if c.z_reversed:
        notes.append("z turned by pi about x (theta = 0 stable)")
    if notes:
        lines.append("frame:            " + "; ".join(notes))
    if c.paper_class is False:
        lines.append(f"WARNING:          mirror planes {c.mirror_planes} are not the paper's "
                     "(x and y only): the paper's form does not apply exactly")
    lines.append(f"off-pattern:      {c.off_pattern:.3g} (largest tt/rt entry outside eq. "
                 "matrices, relative to the largest coefficient)")
    entries = sorted(c.off_pattern_entries, key=lambda e: -abs(e.value))
    shown = entries if arguments.all else entries[:5]
    for e in shown:
        lines.append(f"  {e.block}[{e.row},{e.column}] = {e.value: .3e}  (relative {e.relative:.2e})")
    out.write("\n".join(lines) + "\n")
    return 0


# ----------------------------------------------------------------------------- classify
def run_classify(arguments, out: TextIO) -> int:
    c = _coefficients(arguments)
    result = classify(c, zero_tolerance=arguments.zero_tolerance)
    scales = _scales(arguments, c)
    times = physical_times(c, scales) if scales is not None else None
    data = {
        "file": c.path, "shape": c.shape, "family": result.family, "reason": result.reason,
        "coefficients": c.as_dict(),
        "theta0_stable_rotation_about_y": result.stable_about_y,
        "theta0_stable_rotation_about_x": result.stable_about_x,
        "tau51": result.tau51, "tau42": result.tau42, "terminal_velocity": c.mu33,
        "sum_over_51": result.sum_over_51, "remarks": list(result.remarks),
    }
    if scales is not None:
        data.update({
            "length_m": scales.length_m, "force_N": scales.force_N,
            "viscosity_Pa_s": scales.viscosity_Pa_s, "time_unit_s": scales.time_unit_s,
            "tau51_s": times.tau51_s, "tau42_s": times.tau42_s,
            "terminal_velocity_m_s": times.terminal_velocity_m_s, "reynolds": times.reynolds,
        })
    if arguments.json:
        _write_json(out, data)
        return 0
    lines = [f"file:        {c.path} ({c.shape}, N = {c.n_beads}, L = {c.reference_length:g} d)",
             f"family:      {result.family}",
             f"why:         {result.reason}",
             f"mu42, mu51:  {c.mu42:.6g}, {c.mu51:.6g}",
             f"theta = 0:   {'stable' if result.stable_about_y else 'not stable'} for rotation "
             f"about y (d theta/dt = mu51 sin theta), "
             f"{'stable' if result.stable_about_x else 'not stable'} about x "
             "(d theta/dt = -mu42 sin theta)"]
    lines += [f"note:        {remark}" for remark in result.remarks]
    lines += ["times in the dimensionless time t = F t~/(pi eta L^2) (eq. eq:time):",
              f"  tau51 = 1/mu51 = {_g(result.tau51)}",
              f"  tau42 = 1/mu42 = {_g(result.tau42)}",
              f"  U_f = mu33 = {c.mu33:.6g} (unit F/(pi eta L), eq. eq:mju33)"]
    if scales is not None:
        lines += [f"physical: L = {scales.length_m:g} m, F = {scales.force_N:.6g} N, "
                  f"eta = {scales.viscosity_Pa_s:g} Pa s (time unit pi eta L^2/F = "
                  f"{scales.time_unit_s:.6g} s)",
                  f"  tau~51 = {_g(times.tau51_s)} s   (-1/tau~51 = {_g(-1 / times.tau51_s)} 1/s)",
                  f"  tau~42 = {_g(times.tau42_s)} s   (1/tau~42 = {_g(1 / times.tau42_s)} 1/s)",
                  f"  U_f = {times.terminal_velocity_m_s * 1e3:.6g} mm/s"]
        if times.reynolds is not None:
            lines.append(f"  Re = rho U_f L / eta = {times.reynolds:.3g}")
    out.write("\n".join(lines) + "\n")
    return 0


# ----------------------------------------------------------------------------- dynamics
def run_dynamics(arguments, out: TextIO) -> int:
    from beadmob_post import dynamics
    from beadmob_post.mobility import pattern_mobility
    from beadmob_post.plots import dynamics_figure, save

    c = _coefficients(arguments)
    if arguments.samples < 2:
        raise CommandError(f"--samples must be at least 2, got {arguments.samples}")
    mobility = pattern_mobility(*c.values()) if arguments.pattern_only else c.dimensionless_body_mobility
    if arguments.plane is not None:
        if arguments.phi is not None or arguments.psi is not None:
            raise CommandError("--plane fixes phi and psi; give only --theta with it")
        start = dynamics.planar_orientation(arguments.theta, arguments.plane)
    else:
        start = dynamics.orientation(arguments.theta, arguments.phi or 0.0, arguments.psi or 0.0)
    t_end = arguments.t_end or dynamics.default_end_time(c.mu42, c.mu51, max(c.mu11, c.mu22, c.mu33))
    trajectory = dynamics.integrate(mobility, start, t_end, n_samples=arguments.samples)
    closed = None
    lines = [f"integrated {c.shape} (N = {c.n_beads}) to t = {t_end:.6g} "
             f"({_mobility_source(c, arguments.pattern_only)})",
             f"theta: {np.degrees(trajectory.theta[0]):.3f} -> {np.degrees(trajectory.theta[-1]):.6g} deg; "
             f"phi: {np.degrees(trajectory.phi[0]):.3f} -> {np.degrees(trajectory.phi[-1]):.6g} deg; "
             f"psi: {np.degrees(trajectory.psi[0]):.3f} -> {np.degrees(trajectory.psi[-1]):.6g} deg"]
    if arguments.plane is not None:
        rate = c.mu51 if arguments.plane == "y" else -c.mu42
        closed = dynamics.planar_closed_form(np.radians(arguments.theta), rate, trajectory.t)
        deviation = float(np.abs(trajectory.theta - closed).max())
        lines.append(f"closed form tan(theta/2) = A exp({'mu51' if arguments.plane == 'y' else '-mu42'} t): "
                     f"largest difference {np.degrees(deviation):.2e} deg")
    scales = _scales(arguments, c)
    unit = scales.time_unit_s if scales is not None else None
    if arguments.output is not None:
        output = arguments.output
    elif arguments.file is not None:
        output = arguments.file.with_name(f"{arguments.file.stem}_dynamics.png")
    else:
        output = Path(f"{c.shape}_paper_dynamics.png")
    title = (f"{c.shape}: start theta = {arguments.theta:g} deg"
             + (f", rotation about {arguments.plane}" if arguments.plane else ""))
    save(dynamics_figure(trajectory, title, closed, unit), output)
    lines.append(f"wrote {output}")
    if arguments.csv is not None:
        dynamics.write_csv(trajectory, arguments.csv, unit)
        lines.append(f"wrote {arguments.csv}")
    out.write("\n".join(lines) + "\n")
    return 0


def _mobility_source(c: Coefficients, pattern_only: bool) -> str:
    if c.path.startswith("paper:"):
        return "coefficients of Table tab_mob_num"
    return "five coefficients only" if pattern_only else "full body mobility"


# ----------------------------------------------------------------------------- fit
def run_fit(arguments, out: TextIO) -> int:
    from beadmob_post import fitting
    from beadmob_post.tables import format_fit_table

    if not 0 < arguments.confidence < 1:
        raise CommandError(f"--confidence must lie in (0, 1), got {arguments.confidence}")
    fits, series_list = [], []
    for path in arguments.files:
        series = fitting.read_series(path)
        series_list.append(series)
        fits.append(fitting.fit_series(series, confidence=arguments.confidence))
    scales = _scales(arguments, None)
    if arguments.json:
        data = [vars(f) | {"tau": f.tau} for f in fits]
        if scales is not None:
            for item, f in zip(data, fits):
                item["mu"] = _mu_from_rate(f.rate, scales, arguments.axis)
        _write_json(out, data)
    else:
        text = _emit_table(arguments, lambda fmt: format_fit_table(fits, fmt))
        out.write(text)
        if scales is not None:
            name = {"y": "mu51", "x": "mu42"}.get(arguments.axis, "|mu|")
            for f in fits:
                out.write(f"{Path(f.path).stem}: {name} = {_mu_from_rate(f.rate, scales, arguments.axis):.4g}"
                          f" (1/tau = {f.rate:.4g} 1/s, pi eta L^2/F = {scales.time_unit_s:.4g} s)\n")
    if arguments.plot_dir is not None:
        from beadmob_post.plots import fit_figure, save
        for series, f in zip(series_list, fits):
            written = save(fit_figure(series, f), arguments.plot_dir / f"{Path(series.path).stem}_fit.png")
            out.write(f"wrote {written}\n")
    return 0


def _mu_from_rate(rate: float, scales, axis: str | None) -> float:
    """eq. eq:mobility: mu = (pi eta L^2/F)/tau~; mu51 < 0 for a settler (rate = -mu51 ...)."""
    magnitude = rate * scales.time_unit_s
    return -magnitude if axis == "y" else magnitude


# ----------------------------------------------------------------------------- tables
def _emit_table(arguments, render) -> str:
    """Render with the chosen format; write to -o (returning a 'wrote' line) or return text."""
    from beadmob_post.tables import format_for_path

    if arguments.output is not None:
        fmt = arguments.format or format_for_path(arguments.output)
        arguments.output.write_text(render(fmt), encoding="utf-8")
        return f"wrote {arguments.output}\n"
    return render(arguments.format or "md")


def run_table(arguments, out: TextIO) -> int:
    from beadmob_post.tables import collect, format_table

    rows = collect(arguments.files, allow_unconverged=arguments.allow_unconverged,
                   friction=arguments.friction)
    out.write(_emit_table(arguments, lambda fmt: format_table(rows, fmt)))
    return 0


def run_compare(arguments, out: TextIO) -> int:
    from beadmob_post.tables import collect, comparison, format_comparison

    rows = collect(arguments.files, allow_unconverged=arguments.allow_unconverged,
                   friction=arguments.friction)
    if not comparison(rows):
        raise CommandError("none of the files is one of the paper's seven bead models (cone, "
                           "crescent_moon, arrowhead, ring_1mm ... ring_4mm with the paper's "
                           "L/d): nothing to compare")
    out.write(_emit_table(arguments, lambda fmt: format_comparison(rows, fmt)))
    if arguments.plot is not None:
        from beadmob_post.plots import coefficient_bars, save
        out.write(f"wrote {save(coefficient_bars(rows), arguments.plot)}\n")
    return 0


def run_plot_coefficients(arguments, out: TextIO) -> int:
    from beadmob_post.plots import coefficient_bars, save
    from beadmob_post.tables import collect

    rows = collect(arguments.files, allow_unconverged=arguments.allow_unconverged,
                   friction=arguments.friction)
    out.write(f"wrote {save(coefficient_bars(rows), arguments.output)}\n")
    return 0


def run_plot_bench(arguments, out: TextIO) -> int:
    from beadmob_post.bench import read_bench
    from beadmob_post.plots import bench_figure, save

    runs = read_bench(arguments.file)
    output = arguments.output or arguments.file.with_name(f"{arguments.file.stem}_{arguments.kind}.png")
    out.write(f"wrote {save(bench_figure(runs, arguments.kind, arguments.x), output)}\n")
    return 0


def run_continuum(arguments, out: TextIO) -> int:
    from beadmob_post.continuum import convergence_figure, load_continuum

    result = load_continuum(arguments.file)
    if arguments.json:
        _write_json(out, {"bead_diameters": result.bead_diameters, "level_coefficients": result.level_coefficients,
                          "level_coefficient_error": result.level_coefficient_error,
                          "coefficients": result.coefficients, "coefficient_error": result.coefficient_error,
                          "reference_length": result.reference_length,
                          "reference_length_from": result.reference_length_from, "volume": result.volume})
    else:
        out.write(f"coefficients with L = {result.reference_length:.6g} ({result.reference_length_from})\n")
        out.write("level  bead diameter   " + "  ".join(f"{name:>9}" for name in COEFFICIENT_NAMES) + "\n")
        for k, d in enumerate(result.bead_diameters):
            out.write(f"{k + 1:5d}  {d:13.5g}   " + "  ".join(f"{v:9.5f}" for v in result.level_coefficients[k]) + "\n")
        out.write("continuum            " + "  ".join(f"{v:9.5f}" for v in result.coefficients) + "\n")
        out.write("error bar (+-)       " + "  ".join(f"{v:9.5f}" for v in result.coefficient_error) + "\n")
    if arguments.output is not None:
        from beadmob_post.plots import save
        out.write(f"wrote {save(convergence_figure(result, arguments.file.name), arguments.output)}\n")
    return 0


def run_report(arguments, out: TextIO) -> int:
    from beadmob_post.beadplot import plot_beads
    from beadmob_post.plots import coefficient_bars, write_both
    from beadmob_post.tables import collect, comparison, format_comparison, format_table

    rows = collect(arguments.files, allow_unconverged=arguments.allow_unconverged,
                   friction=arguments.friction)
    directory = arguments.output_dir
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for fmt in ("csv", "md", "tex"):
        path = directory / f"coefficients.{fmt}"
        path.write_text(format_table(rows, fmt), encoding="utf-8")
        written.append(path)
    if comparison(rows):
        for fmt in ("csv", "md", "tex"):
            path = directory / f"comparison.{fmt}"
            path.write_text(format_comparison(rows, fmt), encoding="utf-8")
            written.append(path)
    if any(row.coefficients is not None for row in rows):
        written += write_both(coefficient_bars(rows), directory / "coefficients_vs_paper")
    else:
        out.write("note: no file has /hydrodynamics; no coefficient figure\n")
    if not arguments.no_beads:
        for path in arguments.files:
            written.append(plot_beads(load_result(path), directory / f"{path.stem}_beads.png"))
    for path in written:
        out.write(f"wrote {path}\n")
    return 0


# ----------------------------------------------------------------------------- diffusion
def _diffusion(arguments):
    from beadmob_post.brownian import diffusion_analysis, physical_scales

    try:
        scales = physical_scales(arguments.temperature, arguments.viscosity, arguments.length_unit)
    except ValueError as exc:
        raise CommandError(str(exc)) from exc
    if arguments.volume is not None and not arguments.volume > 0:
        raise CommandError(f"--volume must be positive, got {arguments.volume}")
    return diffusion_analysis(load_result(arguments.file), volume=arguments.volume,
                              allow_unconverged=arguments.allow_unconverged, friction=arguments.friction,
                              scales=scales)


def _pm(errors, name, index=None, fmt=".3g") -> str:
    """' +- bar' when the error bar is known."""
    if not errors or errors.get(name) is None:
        return ""
    value = errors[name] if index is None else errors[name][index]
    return f" +- {value:{fmt}}"


def run_diffusion(arguments, out: TextIO) -> int:
    from beadmob_post.brownian import BEAD_VOLUME_SOURCE

    d = _diffusion(arguments)
    if arguments.json:
        _write_json(out, d.as_dict())
        return 0
    unit, e = d.length_unit, d.errors

    def vector(values) -> str:
        return "(" + ", ".join(f"{v:.6g}" for v in values) + ")"

    distance = float(np.linalg.norm(d.centre_of_diffusion - d.reference_point))
    lines = [f"file:             {d.path} (mobility from /{d.source})",
             f"units:            kT = eta = 1, lengths in {unit}"
             + ("" if d.physical else " (--temperature, --viscosity, --length-unit for SI)"),
             f"reference point:  {vector(d.reference_point)} {unit} "
             f"({'centre of mass' if d.source == 'hydrodynamics' else '/continuum centroid'})",
             f"centre of diffusion: {vector(d.centre_of_diffusion)} {unit}, {distance:.4g} {unit} from it"]
    if d.file_centre_of_mobility is not None:
        gap = float(np.linalg.norm(d.file_centre_of_mobility - d.centre_of_diffusion))
        lines.append(f"  = beadmob's centre of mobility {vector(d.file_centre_of_mobility)} (difference {gap:.2g})")
    lines += [f"D_t:              {d.translational:.6g}{_pm(e, 'translational_diffusion')} "
              f"(tr D_tt / 3 at the centre of diffusion; principal {vector(d.translational_principal)})",
              f"Stokes radius:    {d.stokes_radius:.6g}{_pm(e, 'stokes_radius')} {unit} (kT / (6 pi eta D_t))",
              "D_r:              " + ", ".join(f"{v:.6g}{_pm(e, 'rotational_diffusion', k)}"
                                               for k, v in enumerate(d.rotational))
              + " (eigenvalues of D_rr)"]
    for k, axis in enumerate(d.rotational_axes):
        lines.append(f"  axis {k + 1}:         {vector(axis)}")
    lines += ["tau_1..tau_5:     " + ", ".join(f"{v:.6g}" for v in d.relaxation_times)
              + " (l = 2 relaxation times, Favro 1960)",
              f"tau_h:            {d.harmonic_mean_time:.6g}{_pm(e, 'harmonic_mean_relaxation_time')} "
              "(harmonic mean = 1/(6 mean D_r))",
              f"volume:           {d.volume:.6g} {unit}^3 ({d.volume_source}"
              + (")" if d.volume_source != BEAD_VOLUME_SOURCE or d.flow is None else
                 "; [eta] scales as 1/volume: --volume gives the body's own, e.g. the shape's)")]
    if d.flow is None:
        lines.append("flow:             no /flow in the file ([eta] and B need &hydrodynamics flow = .true.)")
    else:
        f, b = d.flow, d.flow.bretherton
        fe = f.errors
        lines += [f"[eta] zero shear: {f.intrinsic_viscosity.zero_shear:.6g}{_pm(fe, 'zero_shear')} "
                  "(rotary Brownian, eta_eff = eta (1 + [eta] phi))",
                  f"[eta] no Brownian: {f.intrinsic_viscosity.high_frequency:.6g}{_pm(fe, 'high_frequency')} "
                  "(isotropic average of the stresslet; high-frequency limit)",
                  f"  Brownian part:  {f.intrinsic_viscosity.brownian:.6g}{_pm(fe, 'brownian')}",
                  f"Bretherton B:     {b.constant:.6g}{_pm(fe, 'bretherton')} about {vector(b.axis)} "
                  f"(relative residual {b.residual:.2g}: "
                  + ("a body of revolution)" if b.axisymmetric else "NOT of the form B p x (E.p))")]
        if b.axisymmetric and b.aspect_ratio is not None:
            lines.append(f"  r_e, period:    equivalent aspect ratio {b.aspect_ratio:.6g}, Jeffery period "
                         f"{b.jeffery_period:.6g} / shear rate")
        lines.append("Jeffery lambda:   " + ", ".join(f"{v:.6g}" for v in f.jeffery_constants)
                     + f" (D_r axes 1, 2, 3; outside the triaxial form {f.jeffery_off_pattern:.2g})")
    if d.physical is not None:
        p = d.as_dict()["physical"]
        lines += [f"physical:         T = {d.physical.temperature_K:g} K, eta = {d.physical.viscosity_Pa_s:g} Pa s, "
                  f"1 {unit} = {d.physical.length_m:g} m",
                  f"  D_t = {p['translational_diffusion_m2_s']:.6g} m^2/s, R_s = {p['stokes_radius_m']:.6g} m",
                  "  D_r = " + ", ".join(f"{v:.6g}" for v in p["rotational_diffusion_1_s"]) + " 1/s",
                  "  tau = " + ", ".join(f"{v:.6g}" for v in p["relaxation_times_s"])
                  + f" s, tau_h = {p['harmonic_mean_relaxation_time_s']:.6g} s"]
    if e is not None:
        lines.append("error bars:       first order from /hydrodynamics/body_mobility_error"
                     + (" and /flow/*_error" if d.flow is not None and d.flow.errors else "") + " (worst case)")
    out.write("\n".join(lines) + "\n")
    return 0


# ----------------------------------------------------------------------------- orbit
def _parse_direction(text: str) -> np.ndarray:
    try:
        values = np.array([float(v) for v in text.split(",")])
    except ValueError:
        values = np.array([])
    if values.shape != (3,) or not np.all(np.isfinite(values)) or np.linalg.norm(values) == 0:
        raise CommandError(f"--initial-axis needs three numbers X,Y,Z (not all zero), got {text!r}")
    return values / np.linalg.norm(values)


def run_orbit(arguments, out: TextIO) -> int:
    from beadmob_post import orbit
    from beadmob_post.brownian import bretherton_fit, canonical_flow, require_flow
    from beadmob_post.mobility import MobilityError, checked_mobility

    if not (arguments.strain > 0 and np.isfinite(arguments.strain)):
        raise CommandError(f"--strain must be positive, got {arguments.strain}")
    if arguments.samples < 2:
        raise CommandError(f"--samples must be at least 2, got {arguments.samples}")
    result = load_result(arguments.file)
    velocity = canonical_flow(require_flow(result, arguments.allow_unconverged))[0]
    candidates = [result.body_axes]
    try:
        mobility = checked_mobility(result, allow_unconverged=True)
        candidates.insert(0, np.linalg.eigh(mobility[3:6, 3:6])[1].T)
    except MobilityError:
        pass
    fit = bretherton_fit(velocity[3:6], np.vstack(candidates))
    axes = {f"body {name}": result.body_axes[k] for k, name in enumerate("xyz")}
    if fit.axisymmetric and np.linalg.norm(velocity[3:6]) > 0:
        # the symmetry axis is followed too; named with the body axis it coincides with, if any
        same = [name for name, a in axes.items() if abs(abs(a @ fit.axis) - 1) < 1e-9]
        if same:
            axes = {(f"{name} (symmetry)" if name == same[0] else name): a for name, a in axes.items()}
        else:
            axes["symmetry axis"] = fit.axis
    chosen = arguments.axis or ("symmetry" if fit.axisymmetric else "z")
    if chosen == "symmetry":
        if not fit.axisymmetric:
            raise CommandError(f"{arguments.file}: the body is not a body of revolution for its rotation in "
                               f"flow (residual {fit.residual:.2g} of Bretherton's form); use --axis x, y or z")
        followed = fit.axis
    else:
        followed = result.body_axes["xyz".index(chosen)]
    start = np.eye(3)
    if arguments.initial_axis is not None:
        start = orbit.minimal_rotation(followed, _parse_direction(arguments.initial_axis))
    trajectory = orbit.integrate(velocity, start, arguments.strain, samples=arguments.samples,
                                 method=arguments.method)
    data = orbit.summary(trajectory, axes, fit, tolerance=arguments.tolerance)
    data.update({"file": str(arguments.file), "initial_axis": chosen,
                 "initial_direction": (start @ followed).tolist()})
    if arguments.plot is not None:
        from beadmob_post.plots import save
        save(orbit.orbit_figure(trajectory, axes, f"{result.shape_name}: orientation in shear u = gamma y e_x"),
             arguments.plot)
        data["plot"] = str(arguments.plot)
    if arguments.json:
        _write_json(out, data)
        return 0

    def vector(values) -> str:
        return "(" + ", ".join(f"{v:.4g}" for v in values) + ")"

    lines = [f"file:             {arguments.file} in u = gamma y e_x (vorticity -z) to strain {arguments.strain:g} "
             f"({arguments.method})",
             f"start:            {chosen} axis along {vector(start @ followed)}"]
    width = max(18, max(len(name) for name in data["axes"]) + 2)
    for name, item in data["axes"].items():
        if item["fixed"]:
            text = "does not move"
        elif item["period"] is None:
            text = "no return within the strain"
        else:
            text = (f"period {item['period']:.8g} (closure {item['closure']:.1g}, {item['returns']} returns, "
                    f"mean {item['mean_period']:.8g})")
        lines.append(f"{name + ':':<{width}}{vector(item['initial_lab'])} -> {vector(item['final_lab'])}; {text}")
    whole = data["orientation"]
    lines.append("orientation:      " + ("no return within the strain" if whole["period"] is None else
                                         f"period {whole['period']:.8g} (closure {whole['closure']:.1g})"))
    b = data["bretherton"]
    if fit.axisymmetric:
        text = f"Bretherton B = {b['constant']:.6g} about {vector(b['axis'])}"
        if b["jeffery_period"] is not None:
            text += f"; Jeffery period {b['jeffery_period']:.8g}"
        if b.get("orbit_constant") is not None:
            if b.get("orbit_constant_relative_change") is not None:
                change = f" (relative change {b['orbit_constant_relative_change']:.1g})"
            elif b.get("orbit_constant_change") is not None:
                change = f" (change {b['orbit_constant_change']:.1g}: the axis on the vorticity)"
            else:
                change = " (not finite along the orbit)"
            text += f"; orbit constant C = {b['orbit_constant']:.6g}{change}"
        lines.append("revolution:       " + text)
    else:
        lines.append(f"revolution:       no (residual {b['residual']:.2g} of Bretherton's form)")
    drift = data["drift"]
    lines.append(f"drift:            mean {vector(drift['mean'])}, largest {drift['largest']:.3g} "
                 f"(velocity / (shear rate x length unit)); centre at {vector(drift['final_position'])}")
    lines.append(f"orthogonality:    max |Q^T Q - I| = {data['orthogonality_error']:.1g}")
    if arguments.plot is not None:
        lines.append(f"wrote {arguments.plot}")
    out.write("\n".join(lines) + "\n")
    return 0


__all__ = ["CommandError", "add_analysis_commands"]
