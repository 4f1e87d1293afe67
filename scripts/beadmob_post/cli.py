"""The ``beadmob-post`` command: inspect, analyse and picture beadmob result files.

Every failure (unreadable file, wrong format, unwritable output) ends with one line
``beadmob-post: error: ...`` on stderr and exit status 2, like argparse usage errors.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any, Sequence, TextIO

import numpy as np

from beadmob_post import __version__
from beadmob_post.results import BeadResult, ResultFileError, load_result
from beadmob_post.commands import CommandError, add_analysis_commands

PROGRAM_NAME = "beadmob-post"
#: Exit status of every error, as for argparse usage errors.
ERROR_EXIT_STATUS = 2
#: Set this environment variable to get Python tracebacks of unexpected errors.
DEBUG_VARIABLE = "BEADMOB_POST_DEBUG"


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with the subcommands ``info`` and ``plot-beads``."""
    parser = argparse.ArgumentParser(
        prog=PROGRAM_NAME,
        description="Postprocess beadmob result files (HDF5).",
        epilog=f"Run '{PROGRAM_NAME} COMMAND --help' for the options of one command.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    info = commands.add_parser(
        "info",
        help="print the bead model, shape and run metadata of a result file",
        description="Print the number of beads, shape, shape parameters, extents, centre of "
        "mass, body axes and run metadata of a beadmob result file.",
    )
    info.add_argument("file", type=Path, metavar="FILE", help="beadmob result file (.h5)")
    info.add_argument("--json", action="store_true", help="print the summary as JSON")
    info.set_defaults(handler=run_info)

    plot = commands.add_parser(
        "plot-beads",
        help="draw the bead model in three views (front, side, top)",
        description="Draw the bead model in the body frame in three orthogonal views, beads "
        "as circles of diameter d coloured by depth. The format follows the output suffix "
        "(.png or .pdf).",
    )
    plot.add_argument("file", type=Path, metavar="FILE", help="beadmob result file (.h5)")
    plot.add_argument(
        "-o", "--output", type=Path, metavar="OUT",
        help="output picture (.png or .pdf; default: <FILE stem>_beads.png next to FILE)",
    )
    plot.add_argument("--title", help="figure title (default: shape, parameters and N)")
    plot.add_argument("--dpi", type=int, default=None, help="resolution of PNG output")
    plot.set_defaults(handler=run_plot_beads)
    add_analysis_commands(commands)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command with ``argv`` (default: ``sys.argv[1:]``); returns the exit status."""
    parser = build_parser()
    arguments = parser.parse_args(argv)
    try:
        return arguments.handler(arguments, sys.stdout)
    except (CommandError, ResultFileError) as exc:
        return _report_error(str(exc))
    except (OSError, ValueError) as exc:
        return _report_error(_describe(exc))
    except Exception as exc:  # noqa: BLE001 - last resort: one line instead of a traceback
        if os.environ.get(DEBUG_VARIABLE):
            raise
        return _report_error(
            f"unexpected {type(exc).__name__}: {exc} (set {DEBUG_VARIABLE}=1 to see the traceback)"
        )


def run_info(arguments: argparse.Namespace, out: TextIO) -> int:
    """``info FILE``: print a summary of the result file."""
    result = load_result(arguments.file)
    summary = summarise(result)
    if arguments.json:
        out.write(json.dumps(summary, indent=2) + "\n")
    else:
        out.write(format_summary(summary))
    return 0


def run_plot_beads(arguments: argparse.Namespace, out: TextIO) -> int:
    """``plot-beads FILE [-o OUT]``: write the three-view bead picture."""
    from beadmob_post.beadplot import DEFAULT_DPI, plot_beads  # matplotlib only when needed

    if arguments.dpi is not None and arguments.dpi <= 0:
        raise CommandError(f"--dpi must be positive, got {arguments.dpi}")
    result = load_result(arguments.file)
    output = arguments.output or default_bead_picture_path(arguments.file)
    written = plot_beads(
        result, output, title=arguments.title, dpi=arguments.dpi or DEFAULT_DPI
    )
    out.write(f"wrote {written}\n")
    return 0


def default_bead_picture_path(result_path: Path) -> Path:
    """``<dir>/<stem>_beads.png`` for the result file ``<dir>/<stem>.h5``."""
    return result_path.with_name(f"{result_path.stem}_beads.png")


def summarise(result: BeadResult) -> dict[str, Any]:
    """The facts printed by ``info``, as JSON-compatible values."""
    return {
        "file": str(result.path),
        "n_beads": result.n_beads,
        "shape": result.shape_name,
        "shape_source": result.shape_source,
        "shape_parameters": dict(result.shape_parameters),
        "reference_length": result.reference_length,
        "extent": result.extent.tolist(),
        "centre_of_mass": result.centre_of_mass.tolist(),
        "body_axes": result.body_axes.tolist(),
        "input_source": result.input_source,
        "metadata": {name: _jsonable(value) for name, value in result.metadata.items()},
        "hydrodynamics": _hydro_summary(result),
    }


def _hydro_summary(result: BeadResult) -> dict[str, Any] | None:
    """What /hydrodynamics holds (None without it); coefficients as beadmob wrote them."""
    hydro = result.hydrodynamics
    if hydro is None:
        return None
    attributes = hydro.attributes
    names = attributes.get("phase_names")
    seconds = attributes.get("phase_seconds")
    phases = None
    if isinstance(names, str) and seconds is not None and len(names.split()) == np.size(seconds):
        phases = dict(zip(names.split(), np.ravel(seconds).astype(float).tolist()))
    cutoff = attributes.get("lubrication_cutoff")

    def listed(array):
        return None if array is None else array.tolist()

    return {
        "multipole_order": hydro.multipole_order,
        "lubrication": hydro.lubrication,
        "lubrication_cutoff": float(cutoff) if hydro.lubrication and cutoff is not None else None,
        "all_converged": hydro.all_converged,
        "operator": attributes.get("operator"),
        "coefficients": listed(hydro.coefficients),
        "multipole_coefficients": listed(hydro.multipole_coefficients),
        "centre_of_mobility": listed(hydro.centre_of_mobility),
        "phase_seconds": phases,
        "diffusion": _diffusion_summary(result),
    }


def _diffusion_summary(result: BeadResult) -> dict[str, Any] | None:
    """The main numbers of ``diffusion`` (kT = eta = 1), None when the mobility is not usable."""
    from beadmob_post.brownian import diffusion_analysis

    try:
        d = diffusion_analysis(result)
    except (ResultFileError, ValueError, np.linalg.LinAlgError):
        return None
    summary = {
        "translational_diffusion": d.translational, "stokes_radius": d.stokes_radius,
        "rotational_diffusion": d.rotational.tolist(), "harmonic_mean_relaxation_time": d.harmonic_mean_time,
        "centre_of_diffusion": d.centre_of_diffusion.tolist(),
    }
    if d.flow is not None:
        summary.update({
            "intrinsic_viscosity_zero_shear": d.flow.intrinsic_viscosity.zero_shear,
            "intrinsic_viscosity_high_frequency": d.flow.intrinsic_viscosity.high_frequency,
            "bretherton_constant": d.flow.bretherton.constant, "axisymmetric": d.flow.bretherton.axisymmetric,
        })
    return summary


def format_summary(summary: dict[str, Any]) -> str:
    """Human-readable text of :func:`summarise`'s dictionary, one fact per line."""
    def vector(values: Sequence[float]) -> str:
        return "(" + ", ".join(f"{value:.6g}" for value in values) + ")"

    parameters = summary["shape_parameters"]
    parameter_text = (
        ", ".join(f"{name} = {value:g}" for name, value in sorted(parameters.items()))
        if parameters else "(none)"
    )
    reference = summary["reference_length"]
    lines = [
        f"file:             {summary['file']}",
        f"beads:            N = {summary['n_beads']}",
        f"shape:            {summary['shape']}"
        + (f" ({summary['shape_source']})" if summary["shape_source"] else ""),
        f"parameters:       {parameter_text}",
        "reference length: " + (f"L = {reference:g} d" if reference is not None else "(none)"),
        f"extent:           {vector(summary['extent'])} d along body x, y, z",
        f"centre of mass:   {vector(summary['centre_of_mass'])} d",
    ]
    for name, axis in zip(("x", "y", "z"), summary["body_axes"]):
        lines.append(f"body axis {name}:      {vector(axis)}")
    if summary["input_source"] is not None:
        lines.append(f"input:            {summary['input_source']}")
    hydro = summary.get("hydrodynamics")
    if hydro is not None:
        converged = {True: "all solves converged", False: "NOT CONVERGED",
                     None: "convergence not recorded"}[hydro["all_converged"]]
        cutoff = hydro.get("lubrication_cutoff")
        operator = hydro.get("operator")
        lines.append(f"hydrodynamics:    multipole order {hydro['multipole_order']}, lubrication "
                     f"{'yes' if hydro['lubrication'] else 'no'}"
                     + (f" (cutoff {cutoff:g} d)" if cutoff is not None else "")
                     + f", {converged}" + (f", operator {operator}" if operator else ""))
        if hydro["coefficients"] is not None:
            lines.append("mu11..mu51:       " + ", ".join(f"{v:.4g}" for v in hydro["coefficients"])
                         + " (as written by beadmob; see 'coefficients')")
        if hydro.get("multipole_coefficients") is not None:
            lines.append("  order L alone:  "
                         + ", ".join(f"{v:.4g}" for v in hydro["multipole_coefficients"])
                         + " (without the lubrication correction; 'coefficients --friction "
                         "multipole')")
        if hydro.get("centre_of_mobility") is not None:
            lines.append(f"centre of mobility: {vector(hydro['centre_of_mobility'])} d")
        diffusion = hydro.get("diffusion")
        if diffusion is not None:
            lines.append(f"diffusion:        D_t = {diffusion['translational_diffusion']:.4g}, R_s = "
                         f"{diffusion['stokes_radius']:.4g} d, D_r = "
                         + ", ".join(f"{v:.4g}" for v in diffusion["rotational_diffusion"])
                         + f", tau_h = {diffusion['harmonic_mean_relaxation_time']:.4g} (kT = eta = 1; see "
                         "'diffusion')")
            if "intrinsic_viscosity_zero_shear" in diffusion:
                lines.append(f"flow:             [eta] = {diffusion['intrinsic_viscosity_zero_shear']:.4g} "
                             f"(zero shear; {diffusion['intrinsic_viscosity_high_frequency']:.4g} without "
                             f"Brownian motion), Bretherton B = {diffusion['bretherton_constant']:.4g}"
                             + ("" if diffusion["axisymmetric"] else " (not a body of revolution)")
                             + " (see 'diffusion', 'orbit')")
        if hydro.get("phase_seconds"):
            lines.append("wall time:        " + ", ".join(
                f"{name} {value:.3g} s" for name, value in hydro["phase_seconds"].items()))
    for name, value in summary["metadata"].items():
        lines.append(f"{name + ':':<18}{value}")
    return "\n".join(lines) + "\n"


def _jsonable(value: Any) -> Any:
    """Arrays to lists so that metadata can be printed as JSON."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


def _describe(exc: OSError | ValueError) -> str:
    """One-line text of an OS or value error, naming the file when known."""
    if isinstance(exc, OSError) and exc.filename is not None:
        return f"{exc.filename}: {exc.strerror or exc}"
    return str(exc)


def _report_error(message: str) -> int:
    """Print ``beadmob-post: error: message`` (one line) on stderr; return the exit status."""
    one_line = " ".join(message.split())
    print(f"{PROGRAM_NAME}: error: {one_line}", file=sys.stderr)
    return ERROR_EXIT_STATUS
