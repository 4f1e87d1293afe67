"""beadmob_post.continuum and `beadmob-post continuum` on a /continuum group written here with
level means on an exact quadratic in the bead diameter (c0 + c1 d + c2 d^2): the refit's
intercept must be c0 (a quadratic is its own continuum limit), the command prints the file's
values, draws the figure and refuses a file without the group. (beadmob's own fit of a real
ladder is checked against quadratic_fit in tests/e2e/check_continuum.py.)"""
from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from beadmob_post.cli import main
from beadmob_post.continuum import load_continuum, quadratic_fit

C0 = np.array([0.27, 0.27, 0.30, 0.057, -0.057])
C1 = np.array([-0.4, -0.4, -0.3, 0.02, -0.02])
C2 = np.array([1.0, 1.0, 0.8, 0.1, -0.1])


def write_continuum(path, with_group=True):
    d = 2.0 ** (-np.arange(7) / 3) * 0.5
    levels = C0 + np.outer(d, C1) + np.outer(d**2, C2)
    with h5py.File(path, "w") as f:
        f.create_group("geometry")
        if not with_group:
            return path
        c = f.create_group("continuum")
        c["bead_diameters"] = d
        c["level_coefficients"] = levels            # (K, 5) as beadmob's Fortran columns read in C order
        c["level_coefficient_error"] = np.full_like(levels, 1e-4)
        c.attrs["sample_level"] = np.repeat(np.arange(1, 8), 2).astype(np.int32)
        c["sample_coefficients"] = np.repeat(levels, 2, axis=0)
        c["coefficients"] = C0 + 1e-6
        c["coefficient_error"] = np.full(5, 2e-3)
        c["mobility"] = np.eye(6)
        c["mobility_error"] = np.full((6, 6), 1e-3)
        c.attrs["reference_length"] = 21.0
        c.attrs["volume"] = 1.0
    return path


def test_quadratic_levels_refit_to_their_intercept(tmp_path):
    result = load_continuum(write_continuum(tmp_path / "c.h5"))
    assert result.level_coefficients.shape == (7, 5)
    for k in range(5):
        c = quadratic_fit(result.bead_diameters, result.level_coefficients[:, k], result.level_coefficient_error[:, k])
        assert c == pytest.approx([C0[k], C1[k], C2[k]], rel=1e-9, abs=1e-12)


def test_command_prints_the_file_values_and_draws(tmp_path, capsys):
    path = write_continuum(tmp_path / "c.h5")
    figure = tmp_path / "conv.png"
    assert main(["continuum", str(path), "-o", str(figure)]) == 0
    out = capsys.readouterr().out
    assert "continuum" in out and f"{C0[0] + 1e-6:9.5f}" in out
    assert figure.stat().st_size > 1000
    assert main(["continuum", str(path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["coefficients"] == pytest.approx(list(C0 + 1e-6))
    assert data["reference_length"] == 21.0
    assert data["reference_length_from"] == "finest level"   # a file from before the attribute


def test_command_names_where_the_length_came_from(tmp_path, capsys):
    path = write_continuum(tmp_path / "c.h5")
    with h5py.File(path, "a") as f:
        f["continuum"].attrs["reference_length_from"] = "body"
    assert main(["continuum", str(path)]) == 0
    assert "coefficients with L = 21 (body)" in capsys.readouterr().out


def test_file_without_the_group_is_refused(tmp_path, capsys):
    path = write_continuum(tmp_path / "plain.h5", with_group=False)
    assert main(["continuum", str(path)]) == 2
    err = capsys.readouterr().err
    assert "no /continuum group" in err
