"""Tests of beadmob_post.beadplot: draw order, true bead size, output files."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import EllipseCollection

from beadmob_post.beadplot import (
    DEFAULT_DPI,
    FIGURE_SIZE_INCHES,
    STANDARD_VIEWS,
    back_to_front_order,
    build_figure,
    plot_beads,
)
from beadmob_post.results import load_result
from conftest import png_size

VIEWS = {view.name: view for view in STANDARD_VIEWS}


def test_views_look_from_the_right_handed_side():
    # The direction towards the viewer is horizontal x vertical for every view.
    for view in STANDARD_VIEWS:
        towards_viewer = np.cross(np.eye(3)[view.horizontal], np.eye(3)[view.vertical])
        expected = np.zeros(3)
        expected[view.depth] = view.viewer_sign
        np.testing.assert_array_equal(towards_viewer, expected)
    assert [view.label for view in STANDARD_VIEWS] == ["front (x-z)", "side (y-z)", "top (x-y)"]


def test_front_view_draws_largest_y_first():
    # Front view: viewer on the -y side, so the bead with the largest y is farthest.
    coordinates = np.array([[0.0, -1.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.5, 0.0], [0.0, -3.0, 0.0]])
    order = back_to_front_order(coordinates, VIEWS["front"])
    np.testing.assert_array_equal(order, [1, 2, 0, 3])


def test_side_and_top_views_draw_smallest_coordinate_first():
    coordinates = np.array([[3.0, 0.0, -2.0], [-1.0, 0.0, 5.0], [1.0, 0.0, 0.0]])
    np.testing.assert_array_equal(back_to_front_order(coordinates, VIEWS["side"]), [1, 2, 0])
    np.testing.assert_array_equal(back_to_front_order(coordinates, VIEWS["top"]), [0, 2, 1])


def test_draw_order_is_stable_for_equal_depths():
    coordinates = np.zeros((5, 3))
    for view in STANDARD_VIEWS:
        np.testing.assert_array_equal(back_to_front_order(coordinates, view), np.arange(5))


def test_draw_order_is_back_to_front_for_random_beads():
    coordinates = np.random.default_rng(1).normal(size=(1000, 3))
    for view in STANDARD_VIEWS:
        order = back_to_front_order(coordinates, view)
        nearness = view.viewer_sign * coordinates[order, view.depth]
        assert np.all(np.diff(nearness) >= 0.0)
        assert sorted(order.tolist()) == list(range(1000))


def test_figure_draws_every_bead_with_unit_diameter_back_to_front(result_path):
    result = load_result(result_path)
    body = result.body_coordinates()
    figure = build_figure(result)
    panels = [axes for axes in figure.axes if axes.get_title()]
    assert [axes.get_title() for axes in panels] == [view.label for view in STANDARD_VIEWS]

    for axes, view in zip(panels, STANDARD_VIEWS):
        (beads,) = [c for c in axes.collections if isinstance(c, EllipseCollection)]
        order = back_to_front_order(body, view)
        # Circle centres are the body-frame coordinates, in drawing order.
        np.testing.assert_allclose(
            beads.get_offsets(), body[order][:, [view.horizontal, view.vertical]]
        )
        # Colours follow the depth coordinate, in the same order.
        np.testing.assert_allclose(beads.get_array(), body[order, view.depth])
        # Circles of one bead diameter in data units, equal aspect.
        np.testing.assert_array_equal(beads.get_widths(), np.ones(result.n_beads))
        np.testing.assert_array_equal(beads.get_heights(), np.ones(result.n_beads))
        assert axes.get_aspect() == 1.0
        # Every bead lies fully inside the panel.
        x_low, x_high = axes.get_xlim()
        y_low, y_high = axes.get_ylim()
        centres = beads.get_offsets()
        assert x_low <= centres[:, 0].min() - 0.5 and centres[:, 0].max() + 0.5 <= x_high
        assert y_low <= centres[:, 1].min() - 0.5 and centres[:, 1].max() + 0.5 <= y_high


def test_drawn_circles_have_the_bead_diameter_on_screen(result_path):
    figure = build_figure(load_result(result_path))
    FigureCanvasAgg(figure).draw()  # lays out the axes and sizes the circles in pixels
    for axes in [axes for axes in figure.axes if axes.get_title()]:
        (beads,) = [c for c in axes.collections if isinstance(c, EllipseCollection)]
        origin, unit_x, unit_y = axes.transData.transform([[0, 0], [1, 0], [0, 1]])
        pixels_per_d_x = unit_x[0] - origin[0]
        pixels_per_d_y = unit_y[1] - origin[1]
        assert pixels_per_d_x == pytest.approx(pixels_per_d_y, rel=1e-6)  # equal aspect
        # Each bead is the unit circle mapped by its own transform, then by the collection's
        # transform into pixels: its radius on screen must be half a diameter d.
        transforms = beads.get_transform().get_matrix() @ beads.get_transforms()
        np.testing.assert_allclose(transforms[:, 0, 0], 0.5 * pixels_per_d_x, rtol=1e-6)
        np.testing.assert_allclose(transforms[:, 1, 1], 0.5 * pixels_per_d_y, rtol=1e-6)
        np.testing.assert_allclose(transforms[:, 0, 1], 0.0, atol=1e-9)


def test_default_title_names_shape_and_bead_count(result_path):
    figure = build_figure(load_result(result_path))
    title = figure.get_suptitle()
    assert "l_shape" in title and "N = 4" in title
    custom = build_figure(load_result(result_path), title="my beads")
    assert custom.get_suptitle() == "my beads"


def test_png_has_the_expected_pixel_size(result_path, tmp_path):
    output = plot_beads(load_result(result_path), tmp_path / "beads.png")
    assert output == tmp_path / "beads.png"
    assert output.stat().st_size > 10_000
    expected = tuple(round(size * DEFAULT_DPI) for size in FIGURE_SIZE_INCHES)
    assert png_size(output) == expected


def test_png_dpi_scales_the_pixel_size(result_path, tmp_path):
    output = plot_beads(load_result(result_path), tmp_path / "beads.png", dpi=50)
    assert png_size(output) == tuple(round(size * 50) for size in FIGURE_SIZE_INCHES)


def test_pdf_output(result_path, tmp_path):
    output = plot_beads(load_result(result_path), tmp_path / "beads.pdf")
    assert output.read_bytes()[:5] == b"%PDF-"


def test_unsupported_suffix_is_rejected(result_path, tmp_path):
    with pytest.raises(ValueError, match="unsupported picture format '.jpg'"):
        plot_beads(load_result(result_path), tmp_path / "beads.jpg")
    assert not (tmp_path / "beads.jpg").exists()


def test_hundred_thousand_beads(make_result_file, tmp_path):
    # A 50 x 50 x 40 block: 100 000 beads must be drawn (vectorised, no per-bead artists).
    grid = np.stack(np.meshgrid(np.arange(50), np.arange(50), np.arange(40), indexing="ij"), -1)
    positions = grid.reshape(-1, 3).astype(float)
    result = load_result(make_result_file(positions=positions))
    output = plot_beads(result, tmp_path / "block.png", dpi=40)
    assert result.n_beads == 100_000
    assert png_size(output) == tuple(round(size * 40) for size in FIGURE_SIZE_INCHES)
