"""Pictures of a bead model: three orthogonal views in the body frame.

Each bead is a filled circle of diameter 1 d in data units (equal aspect), so the picture shows
the true bead size. In each view the beads are drawn from the back to the front, so nearer beads
cover farther ones, and are coloured by their coordinate along the viewing direction.

Only the object-oriented matplotlib API is used (``matplotlib.figure.Figure``, no pyplot), so
nothing depends on an interactive backend or on global figure state.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.collections import EllipseCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from beadmob_post.results import BeadResult

#: Size of the whole figure in inches (width, height); with ``DEFAULT_DPI`` this fixes the
#: pixel size of the PNG.
FIGURE_SIZE_INCHES = (15.0, 6.0)
DEFAULT_DPI = 120
#: Colormap of the depth colouring.
DEPTH_COLORMAP = "viridis"
#: Output formats chosen by the suffix of the output path.
SUPPORTED_SUFFIXES = (".png", ".pdf")
#: Above this many beads the circles are rasterised inside vector (PDF) output.
RASTERISE_ABOVE_N_BEADS = 20_000

_AXIS_NAMES = ("x", "y", "z")
#: Space between the outermost bead centres and the panel border: bead radius + half a bead.
_PANEL_MARGIN = 1.0


@dataclass(frozen=True)
class View:
    """An orthographic view: body axis ``horizontal`` to the right, ``vertical`` up.

    The viewer looks along the remaining axis ``depth``; ``viewer_sign`` is +1 when the viewer
    sits on the positive side of that axis (so larger depth values are nearer), -1 otherwise.
    With the screen plane spanned by (horizontal, vertical), the direction towards the viewer
    is their cross product, which fixes the sign for a right-handed body frame.
    """

    name: str
    horizontal: int
    vertical: int
    depth: int
    viewer_sign: int

    @property
    def label(self) -> str:
        """Short description such as ``"front (x-z)"``."""
        return f"{self.name} ({_AXIS_NAMES[self.horizontal]}-{_AXIS_NAMES[self.vertical]})"


#: The three views drawn by :func:`plot_beads`. Front: x right, z up, viewer on the -y side.
#: Side: y right, z up, viewer on the +x side. Top: x right, y up, viewer on the +z side.
STANDARD_VIEWS = (
    View("front", horizontal=0, vertical=2, depth=1, viewer_sign=-1),
    View("side", horizontal=1, vertical=2, depth=0, viewer_sign=+1),
    View("top", horizontal=0, vertical=1, depth=2, viewer_sign=+1),
)


def back_to_front_order(body_coordinates: np.ndarray, view: View) -> np.ndarray:
    """Indices that sort the beads from the farthest to the nearest bead for ``view``.

    ``body_coordinates`` is an (N, 3) array. Beads at equal depth keep their file order
    (stable sort), so the picture is reproducible.
    """
    nearness = view.viewer_sign * np.asarray(body_coordinates)[:, view.depth]
    return np.argsort(nearness, kind="stable")


def build_figure(result: BeadResult, title: str | None = None) -> Figure:
    """The three-view figure of ``result`` (not saved; see :func:`plot_beads`)."""
    if result.n_beads == 0:
        raise ValueError(f"{result.path}: the bead model has no beads to draw")
    coordinates = result.body_coordinates()
    figure = Figure(figsize=FIGURE_SIZE_INCHES, layout="constrained")
    # Panel widths proportional to the horizontal spans give all views one common scale.
    spans = np.ptp(coordinates, axis=0) + 2.0 * _PANEL_MARGIN
    axes_row = figure.subplots(
        1, len(STANDARD_VIEWS),
        gridspec_kw={"width_ratios": [spans[view.horizontal] for view in STANDARD_VIEWS]},
    )
    for axes, view in zip(axes_row, STANDARD_VIEWS):
        _draw_view(figure, axes, coordinates, view, n_beads=result.n_beads)
    figure.suptitle(title if title is not None else default_title(result))
    return figure


def plot_beads(
    result: BeadResult, path: str | Path, title: str | None = None, dpi: int = DEFAULT_DPI
) -> Path:
    """Draw ``result``'s bead model in three views and write it to ``path``.

    The format follows the suffix of ``path``: ``.png`` (raster, ``dpi`` dots per inch, size
    ``FIGURE_SIZE_INCHES`` times ``dpi`` pixels) or ``.pdf`` (vector). Returns the path written.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUPPORTED_SUFFIXES:
        raise ValueError(
            f"{path}: unsupported picture format {suffix or '(no suffix)'!r}; "
            f"use one of {', '.join(SUPPORTED_SUFFIXES)}"
        )
    figure = build_figure(result, title=title)
    figure.savefig(path, format=suffix.lstrip("."), dpi=dpi)
    return path


def default_title(result: BeadResult) -> str:
    """Title naming the shape, its parameters and the number of beads."""
    parameters = ", ".join(
        f"{name} = {value:g}" for name, value in sorted(result.shape_parameters.items())
    )
    details = f" ({parameters})" if parameters else ""
    return f"{result.shape_name}{details}: N = {result.n_beads} beads"


def _draw_view(figure: Figure, axes, coordinates: np.ndarray, view: View, n_beads: int) -> None:
    """Draw one view of the beads into ``axes`` with a depth colorbar below it."""
    order = back_to_front_order(coordinates, view)
    ordered = coordinates[order]
    centres = ordered[:, [view.horizontal, view.vertical]]
    depth = ordered[:, view.depth]

    low, high = float(depth.min()), float(depth.max())
    if high - low < 1e-12:  # flat along the viewing direction: any non-empty colour range
        low, high = low - 0.5, high + 0.5
    beads = EllipseCollection(
        widths=np.ones(len(centres)),
        heights=np.ones(len(centres)),
        angles=np.zeros(len(centres)),
        units="xy",
        offsets=centres,
        offset_transform=axes.transData,
        cmap=DEPTH_COLORMAP,
        norm=Normalize(vmin=low, vmax=high),
    )
    beads.set_array(depth)
    beads.set_edgecolor((0.0, 0.0, 0.0, 0.6))
    beads.set_linewidth(_edge_width(centres, n_beads))
    beads.set_rasterized(n_beads > RASTERISE_ABOVE_N_BEADS)
    axes.add_collection(beads, autolim=False)

    axes.set_xlim(centres[:, 0].min() - _PANEL_MARGIN, centres[:, 0].max() + _PANEL_MARGIN)
    axes.set_ylim(centres[:, 1].min() - _PANEL_MARGIN, centres[:, 1].max() + _PANEL_MARGIN)
    axes.set_aspect("equal", adjustable="box")
    horizontal, vertical, depth_name = (
        _AXIS_NAMES[view.horizontal], _AXIS_NAMES[view.vertical], _AXIS_NAMES[view.depth]
    )
    axes.set_xlabel(f"{horizontal} / d")
    axes.set_ylabel(f"{vertical} / d")
    axes.set_title(view.label)

    side = "+" if view.viewer_sign > 0 else "\u2212"
    colorbar = figure.colorbar(beads, ax=axes, orientation="horizontal", shrink=0.8, aspect=30)
    colorbar.set_label(f"depth {depth_name} / d (viewer on the {side}{depth_name} side)")


def _edge_width(centres: np.ndarray, n_beads: int) -> float:
    """Outline width in points: thin outlines that vanish when beads are too small to show them.

    A rough estimate of the drawn bead size is the panel width (about a third of the figure)
    divided by the span of the picture in bead diameters.
    """
    span = float(np.ptp(centres, axis=0).max()) + 2.0
    bead_size_points = FIGURE_SIZE_INCHES[0] * 72.0 / len(STANDARD_VIEWS) / span
    if bead_size_points < 4.0 or n_beads > RASTERISE_ABOVE_N_BEADS:
        return 0.0
    return min(0.5, 0.05 * bead_size_points)
