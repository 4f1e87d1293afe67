"""Tests of the beadmob-post command, run as a subprocess through scripts/beadmob-post."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import h5py
import numpy as np

from beadmob_post.beadplot import DEFAULT_DPI, FIGURE_SIZE_INCHES
from conftest import SCRIPTS_DIR, png_size


def assert_one_line_error(completed: subprocess.CompletedProcess, *fragments: str) -> None:
    """Exit status 2, nothing on stdout, and a single 'beadmob-post: error:' line on stderr."""
    assert completed.returncode == 2, completed.stderr
    assert completed.stdout == ""
    lines = completed.stderr.splitlines()
    assert len(lines) == 1, completed.stderr
    assert lines[0].startswith("beadmob-post: error: ")
    assert "Traceback" not in completed.stderr
    for fragment in fragments:
        assert fragment in lines[0]


def test_help_lists_the_commands(run_command):
    completed = run_command("--help")
    assert completed.returncode == 0
    assert "info" in completed.stdout and "plot-beads" in completed.stdout
    plot_help = run_command("plot-beads", "--help")
    assert plot_help.returncode == 0 and "--output" in plot_help.stdout


def test_no_command_is_a_usage_error(run_command):
    completed = run_command()
    assert completed.returncode == 2
    assert "beadmob-post: error:" in completed.stderr
    assert "Traceback" not in completed.stderr


def test_info_prints_beads_shape_and_metadata(run_command, result_path):
    completed = run_command("info", result_path)
    assert completed.returncode == 0, completed.stderr
    lines = completed.stdout.splitlines()
    assert "beads:            N = 4" in lines
    assert "shape:            l_shape (built-in shape)" in lines
    assert "parameters:       arm_length = 3, height = 2" in lines
    assert "extent:           (3, 1, 2) d along body x, y, z" in lines
    assert "centre of mass:   (2.75, 3, 4.25) d" in lines
    assert any(line.startswith("mpi_ranks:") and line.endswith("2") for line in lines)
    assert any("abc1234" in line for line in lines)


def test_info_json(run_command, result_path):
    completed = run_command("info", "--json", result_path)
    assert completed.returncode == 0, completed.stderr
    summary = json.loads(completed.stdout)
    assert summary["n_beads"] == 4
    assert summary["shape"] == "l_shape"
    assert summary["shape_parameters"] == {"arm_length": 3.0, "height": 2.0}
    assert summary["metadata"]["format_version"] == 1
    np.testing.assert_allclose(summary["body_axes"], np.eye(3))


def test_plot_beads_default_output_next_to_the_file(run_command, result_path, tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    completed = run_command("plot-beads", result_path, cwd=elsewhere)
    expected = result_path.with_name("result_beads.png")
    assert completed.returncode == 0, completed.stderr
    assert completed.stdout.strip() == f"wrote {expected}"
    assert expected.stat().st_size > 10_000
    assert png_size(expected) == tuple(round(s * DEFAULT_DPI) for s in FIGURE_SIZE_INCHES)
    assert list(elsewhere.iterdir()) == []


def test_plot_beads_output_option_and_dpi(run_command, result_path, tmp_path):
    output = tmp_path / "pictures" / "model.png"
    output.parent.mkdir()
    completed = run_command("plot-beads", result_path, "-o", output, "--dpi", "60")
    assert completed.returncode == 0, completed.stderr
    assert png_size(output) == tuple(round(s * 60) for s in FIGURE_SIZE_INCHES)


def test_plot_beads_pdf(run_command, result_path, tmp_path):
    output = tmp_path / "model.pdf"
    completed = run_command("plot-beads", result_path, "--output", output, "--title", "L")
    assert completed.returncode == 0, completed.stderr
    assert output.read_bytes()[:5] == b"%PDF-"


def test_missing_file(run_command, tmp_path):
    missing = tmp_path / "missing.h5"
    for command in ("info", "plot-beads"):
        assert_one_line_error(run_command(command, missing), str(missing), "no such file")


def test_not_an_hdf5_file(run_command, tmp_path):
    path = tmp_path / "input.nml"
    path.write_text("&shape\n  name = 'cone'\n/\n")
    assert_one_line_error(run_command("info", path), str(path), "is not an HDF5 file")
    assert_one_line_error(run_command("plot-beads", path), "is not an HDF5 file")
    assert not path.with_name("input_beads.png").exists()


def test_hdf5_file_of_another_program(run_command, tmp_path):
    path = tmp_path / "other.h5"
    with h5py.File(path, "w") as handle:
        handle["data"] = np.arange(3)
    assert_one_line_error(
        run_command("info", path),
        f"{path} is not a beadmob result file (no /format attribute)",
    )


def test_hdf5_file_of_another_format(run_command, make_result_file):
    path = make_result_file(file_format="something-else")
    assert_one_line_error(
        run_command("plot-beads", path), "is not a beadmob result file", "something-else"
    )


def test_missing_dataset(run_command, make_result_file):
    path = make_result_file(omit=("geometry/positions",))
    assert_one_line_error(run_command("info", path), "missing dataset /geometry/positions")


def test_unwritable_output(run_command, result_path, tmp_path):
    output = tmp_path / "no_such_dir" / "beads.png"
    assert_one_line_error(run_command("plot-beads", result_path, "-o", output), "no_such_dir")


def test_unsupported_output_format(run_command, result_path, tmp_path):
    completed = run_command("plot-beads", result_path, "-o", tmp_path / "beads.gif")
    assert_one_line_error(completed, "unsupported picture format '.gif'")


def test_module_entry_point(result_path):
    environment = dict(os.environ, PYTHONPATH=str(SCRIPTS_DIR), MPLBACKEND="Agg")
    completed = subprocess.run(
        [sys.executable, "-m", "beadmob_post", "info", str(result_path)],
        capture_output=True, text=True, env=environment, timeout=120,
    )
    assert completed.returncode == 0, completed.stderr
    assert "N = 4" in completed.stdout


def test_truncated_hdf5_file(run_command, result_path, tmp_path):
    truncated = tmp_path / "truncated.h5"
    truncated.write_bytes(result_path.read_bytes()[:2000])
    assert_one_line_error(run_command("info", truncated), str(truncated), "cannot read the file")


def test_unexpected_errors_are_one_line(monkeypatch, capsys, result_path):
    from beadmob_post import cli

    def broken_loader(path):
        raise RuntimeError("boom\nsecond line")

    monkeypatch.setattr(cli, "load_result", broken_loader)
    monkeypatch.delenv(cli.DEBUG_VARIABLE, raising=False)
    assert cli.main(["info", str(result_path)]) == 2
    captured = capsys.readouterr()
    assert captured.err.splitlines() == [
        "beadmob-post: error: unexpected RuntimeError: boom second line "
        f"(set {cli.DEBUG_VARIABLE}=1 to see the traceback)"
    ]
