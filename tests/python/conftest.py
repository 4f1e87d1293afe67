"""Shared fixtures for the beadmob_post tests.

Synthetic result files are written with h5py following the schema of the Fortran program
(strings as fixed-length byte strings, as Fortran writes them). Real output of the Fortran
program is found through the environment variable BEADMOB_TEST_OUTPUT_DIR (set by CTest).
"""

from __future__ import annotations

import os
import struct
import subprocess
import sys
from pathlib import Path
from typing import Callable

import h5py
import numpy as np
import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]
SCRIPTS_DIR = REPO_ROOT / "scripts"
COMMAND = SCRIPTS_DIR / "beadmob-post"

# Make `import beadmob_post` work without installation, as the wrapper script does.
if str(SCRIPTS_DIR) not in sys.path:
    sys.path.insert(0, str(SCRIPTS_DIR))

#: An L-shaped model of 4 beads, deliberately off the origin.
L_SHAPE_POSITIONS = np.array(
    [[2.0, 3.0, 4.0], [3.0, 3.0, 4.0], [4.0, 3.0, 4.0], [2.0, 3.0, 5.0]]
)


def _text(value: str) -> np.bytes_:
    """A string attribute as the Fortran program stores it (fixed-length bytes)."""
    return np.bytes_(value.encode())


def write_result_file(
    path: Path,
    positions: np.ndarray = L_SHAPE_POSITIONS,
    shape_name: str = "l_shape",
    shape_parameters: dict[str, float] | None = None,
    body_axes: np.ndarray | None = None,
    file_format: str | None = "beadmob-result",
    format_version: int = 1,
    omit: tuple[str, ...] = (),
    hydrodynamics: dict | None = None,
    reference_length: float = 3.0,
    mirror_planes: tuple[float, float, float] | None = None,
) -> Path:
    """Write a synthetic beadmob result file at ``path`` and return ``path``.

    ``omit`` lists HDF5 paths (e.g. ``"geometry/positions"``) left out of the file, to test
    the reader's errors; ``file_format=None`` leaves out the root attribute ``format``.
    ``hydrodynamics`` writes a /hydrodynamics group: key ``friction`` (6x6, required),
    ``mobility`` (default: the inverse of the friction; None leaves it out), ``companion_friction``
    (a dataset), every other key becomes an attribute (e.g. ``all_converged=0``).
    """
    positions = np.asarray(positions, dtype=float)
    axes = np.eye(3) if body_axes is None else np.asarray(body_axes, dtype=float)
    parameters = {"arm_length": 3.0, "height": 2.0} if shape_parameters is None else shape_parameters
    centre = positions.mean(axis=0)
    body = (positions - centre) @ axes.T
    extent = np.ptp(body, axis=0) + 1.0
    with h5py.File(path, "w") as handle:
        if file_format is not None:
            handle.attrs["format"] = _text(file_format)
        handle.attrs["format_version"] = np.int64(format_version)
        handle.attrs["program_version"] = _text("0.1.0")
        handle.attrs["git_hash"] = _text("abc1234")
        handle.attrs["created"] = _text("2025-01-02T03:04:05+00:00")
        handle.attrs["mpi_ranks"] = np.int64(2)

        inputs = handle.create_group("input")
        inputs.attrs["source"] = _text("test.nml")
        inputs["namelist"] = _text("&shape\n  name = 'l_shape'\n/\n")

        units = handle.create_group("units")
        units.attrs["length"] = _text("d (bead diameter; bead radius a = d/2)")
        units.attrs["bead_diameter"] = 1.0

        shape = handle.create_group("shape")
        shape.attrs["name"] = _text(shape_name)
        shape.attrs["source"] = _text("built-in shape")
        shape.attrs["reference_length"] = float(reference_length)
        for name, value in parameters.items():
            shape.attrs[name] = float(value)

        geometry = handle.create_group("geometry")
        geometry.attrs["n_beads"] = np.int64(len(positions))
        geometry["positions"] = positions
        geometry["centre_of_mass"] = centre
        geometry["body_axes"] = axes
        geometry["extent"] = extent
        if mirror_planes is not None:
            geometry["mirror_planes"] = np.asarray(mirror_planes, dtype=float)
        if hydrodynamics is not None:
            write_hydrodynamics(handle, dict(hydrodynamics))
        for item in omit:
            del handle[item]
    return path


def write_hydrodynamics(handle: h5py.File, items: dict) -> None:
    """/hydrodynamics as beadmob writes it (see write_result_file)."""
    group = handle.create_group("hydrodynamics")
    friction = np.asarray(items.pop("friction"), dtype=float)
    group["friction"] = friction
    mobility = items.pop("mobility", "inverse")
    if isinstance(mobility, str):
        mobility = np.linalg.inv(friction)
    if mobility is not None:
        group["mobility"] = np.asarray(mobility, dtype=float)
    companion = items.pop("companion_friction", None)   # the error bar's companion (beadmob T14)
    if companion is not None:
        group["companion_friction"] = np.asarray(companion, dtype=float)
    attributes = {"multipole_order": 1, "lubrication": 0, "all_converged": 1,
                  "method": "synthetic", "reference_point": "centre of mass"}
    attributes.update(items)
    for name, value in attributes.items():
        group.attrs[name] = _text(value) if isinstance(value, str) else value


def friction_of_mobility(mobility: np.ndarray) -> np.ndarray:
    """The friction whose inverse is ``mobility`` (for building synthetic files)."""
    return np.linalg.inv(mobility)


def png_size(path) -> tuple[int, int]:
    """(width, height) in pixels from the IHDR chunk of a PNG file."""
    header = path.read_bytes()[:24]
    assert header[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG file"
    return struct.unpack(">II", header[16:24])


@pytest.fixture
def make_result_file(tmp_path: Path) -> Callable[..., Path]:
    """Factory ``make_result_file(name="result.h5", **options)`` writing into ``tmp_path``.

    The options are those of :func:`write_result_file`.
    """
    def make(name: str = "result.h5", **options) -> Path:
        return write_result_file(tmp_path / name, **options)

    return make


@pytest.fixture
def result_path(make_result_file: Callable[..., Path]) -> Path:
    """A valid synthetic result file of the 4-bead L shape."""
    return make_result_file()


@pytest.fixture
def beadmob_output_dir() -> Path:
    """Directory of result files written by the Fortran program (env BEADMOB_TEST_OUTPUT_DIR).

    Skips the test when the variable is unset; fails when it names no directory.
    """
    value = os.environ.get("BEADMOB_TEST_OUTPUT_DIR")
    if not value:
        pytest.skip("BEADMOB_TEST_OUTPUT_DIR is not set (no Fortran result files to test)")
    directory = Path(value)
    if not directory.is_dir():
        pytest.fail(f"BEADMOB_TEST_OUTPUT_DIR={value} is not a directory")
    return directory


@pytest.fixture
def real_hydro_file(beadmob_output_dir: Path) -> Path:
    """rpy_pyramid.h5 of the test suite: a small cone with /hydrodynamics at order 1."""
    path = beadmob_output_dir / "rpy_pyramid.h5"
    if not path.exists():
        pytest.fail(f"{path} missing: the CTest run rpy_pyramid writes it")
    return path


@pytest.fixture
def run_command() -> Callable[..., subprocess.CompletedProcess]:
    """Run the ``scripts/beadmob-post`` wrapper in a subprocess, capturing text output."""
    def run(*arguments: str | Path, cwd: Path | None = None) -> subprocess.CompletedProcess:
        environment = dict(os.environ, MPLBACKEND="Agg")
        environment.pop("PYTHONPATH", None)  # the wrapper must find the package by itself
        return subprocess.run(
            [sys.executable, str(COMMAND), *map(str, arguments)],
            capture_output=True, text=True, cwd=cwd, env=environment, timeout=120,
        )

    return run
