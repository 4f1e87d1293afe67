"""tests/e2e/compare_result_files.py (the comparison of two runs of one job) can fail: a friction
moved beyond the file's own solver error bound, or one exact item changed, is a difference;
a move within the bound is not (docs/theory.md T5, "Solver error bound")."""

from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path

import h5py
import numpy as np

_E2E = Path(__file__).resolve().parents[1] / "e2e"
sys.path.insert(0, str(_E2E))   # compare_result_files imports solver_promise beside it
_spec = importlib.util.spec_from_file_location("compare_result_files", _E2E / "compare_result_files.py")
compare = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(compare)


def _copy(beadmob_output_dir: Path, tmp_path: Path, name: str) -> tuple[Path, Path]:
    source = beadmob_output_dir / "rpy_pyramid.h5"
    first, second = tmp_path / "first.h5", tmp_path / name
    shutil.copy(source, first)
    shutil.copy(source, second)
    return first, second


def _move_friction(path: Path, factor: float) -> None:
    """Moves zeta_12 and zeta_21 by factor x bound x sqrt(zeta_11 zeta_22)."""
    with h5py.File(path, "r+") as f:
        hydro = f["hydrodynamics"]
        bound = float(hydro.attrs["solver_error_bound"])
        for name in ("friction", "multipole_friction"):
            zeta = hydro[name][()]
            step = factor * bound * np.sqrt(zeta[0, 0] * zeta[1, 1])
            zeta[0, 1] += step
            zeta[1, 0] += step
            hydro[name][...] = zeta


def test_identical_copies_agree(beadmob_output_dir: Path, tmp_path: Path) -> None:
    first, second = _copy(beadmob_output_dir, tmp_path, "same.h5")
    assert compare.main(str(first), str(second)) == 0


def test_friction_within_the_promise_agrees(beadmob_output_dir: Path, tmp_path: Path) -> None:
    # Both copies claim the bound b, so up to 2b apart is promised; 1.5b is inside.
    first, second = _copy(beadmob_output_dir, tmp_path, "within.h5")
    _move_friction(second, 1.5)
    assert compare.main(str(first), str(second)) == 0


def test_friction_beyond_the_promise_differs(beadmob_output_dir: Path, tmp_path: Path, capsys) -> None:
    first, second = _copy(beadmob_output_dir, tmp_path, "beyond.h5")
    _move_friction(second, 2.5)
    assert compare.main(str(first), str(second)) == 1
    assert "differs beyond the promised" in capsys.readouterr().out


def test_exact_item_changed_differs(beadmob_output_dir: Path, tmp_path: Path) -> None:
    first, second = _copy(beadmob_output_dir, tmp_path, "positions.h5")
    with h5py.File(second, "r+") as f:
        positions = f["geometry/positions"][()]
        positions[0, 0] = np.nextafter(positions[0, 0], np.inf)
        f["geometry/positions"][...] = positions
    assert compare.main(str(first), str(second)) == 1
