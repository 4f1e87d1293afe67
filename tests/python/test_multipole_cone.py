"""The postprocessor on real L = 2 output: multipole_cone.h5 of the test suite.

tests/e2e/inputs/multipole_cone.nml: an 80-bead cone (base 6 d, height 7 d, mirror planes x and y
only: the paper's class) at multipole order 2 with the lubrication correction and bead_forces.
CTest writes it into the run directory named by BEADMOB_TEST_OUTPUT_DIR (fixture
results_multipole_cone); without that variable these tests are skipped.

The references do not come from the postprocessor's own numbers:
* symmetry: a quarter turn about z maps the cone on itself, so mu11 = mu22 and mu42 = -mu51;
* beadmob's Fortran chain (friction -> mobility -> frame -> coefficients), stored in the file as
  /hydrodynamics/coefficients and multipole_coefficients;
* the friction rebuilt from the per-bead forces and torques (/hydrodynamics/bead_forces);
* beadmob's centre of mobility and the mobility about it (a second Fortran path), and the
  mechanics of a body sedimenting about it;
* the closed forms of the orientation dynamics (planar tan(theta/2) = A exp(mu51 t); for
  mu42 = -mu51 the conserved |g_x|^mu42 |g_y|^mu51 fixes the spin psi) and the terminal
  velocity mu33 of the settled body.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from beadmob_post.cli import main
from beadmob_post.mobility import checked_mobility, compute_coefficients, shift_reference_point
from beadmob_post.results import load_result
from test_cli import assert_one_line_error


def run(capsys, *arguments) -> tuple[int, str, str]:
    status = main([str(a) for a in arguments])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.fixture
def cone_file(beadmob_output_dir: Path) -> Path:
    path = beadmob_output_dir / "multipole_cone.h5"
    if not path.exists():
        pytest.fail(f"{path} missing: the CTest run multipole_cone writes it")
    return path


@pytest.fixture
def stored(cone_file: Path) -> dict:
    """What beadmob wrote, read with h5py directly (not through beadmob_post)."""
    with h5py.File(cone_file, "r") as f:
        h = f["hydrodynamics"]
        data = {name: h[name][()] for name in (
            "friction", "multipole_friction", "mobility", "coefficients", "multipole_coefficients",
            "body_axes", "centre_of_mobility", "mobility_at_centre_of_mobility", "bead_forces")}
        data.update(multipole_order=int(h.attrs["multipole_order"]),
                    lubrication=int(h.attrs["lubrication"]),
                    length=float(f["shape"].attrs["reference_length"]),
                    positions=f["geometry/positions"][()],
                    centre_of_mass=f["geometry/centre_of_mass"][()])
    return data


def coefficients_json(capsys, path, *options) -> dict:
    status, out, err = run(capsys, "coefficients", "--json", path, *options)
    assert status == 0, err
    return json.loads(out)


def values(data: dict) -> np.ndarray:
    return np.array([data["coefficients"][n] for n in ("mu11", "mu22", "mu33", "mu42", "mu51")])


def test_the_file_is_the_l2_lubricated_cone(stored):
    assert stored["multipole_order"] == 2 and stored["lubrication"] == 1
    assert stored["length"] == 7.0 and len(stored["positions"]) == 80
    assert stored["bead_forces"].shape == (80, 36)


def test_coefficients_match_fortran_and_symmetry(capsys, cone_file, stored):
    data = coefficients_json(capsys, cone_file)
    mu = values(data)
    # Fortran computed the same five numbers from the same friction by its own code.
    np.testing.assert_allclose(mu, stored["coefficients"], rtol=1e-9, atol=1e-14)
    mu11, mu22, mu33, mu42, mu51 = mu
    assert mu11 == pytest.approx(mu22, rel=1e-9)          # quarter turn about z
    assert mu42 == pytest.approx(-mu51, rel=1e-9)
    assert mu51 < 0 < mu42                                 # theta = 0 stable (paper frame)
    assert data["lubrication"] is True and data["friction"] == "default"
    assert data["multipole_order"] == 2 and data["all_converged"] is True
    assert data["paper_class"] is True and data["off_pattern"] < 1e-9
    np.testing.assert_allclose(data["body_axes"], stored["body_axes"], atol=1e-12)


def test_multipole_friction_option_matches_fortran(capsys, cone_file, stored):
    lubricated = values(coefficients_json(capsys, cone_file))
    data = coefficients_json(capsys, cone_file, "--friction", "multipole")
    order_l = values(data)
    np.testing.assert_allclose(order_l, stored["multipole_coefficients"], rtol=1e-9, atol=1e-14)
    assert data["friction"] == "multipole" and data["lubrication"] is False
    assert data["run_lubrication"] is True
    assert order_l[0] == pytest.approx(order_l[1], rel=1e-9)
    assert order_l[3] == pytest.approx(-order_l[4], rel=1e-9)
    # The correction adds a positive semi-definite friction, so every mobility shrinks.
    added = stored["friction"] - stored["multipole_friction"]
    assert np.linalg.eigvalsh(0.5 * (added + added.T)).min() > -1e-9 * np.abs(added).max()
    assert np.all(lubricated[:3] < order_l[:3])
    status, out, _ = run(capsys, "coefficients", cone_file, "--friction", "multipole")
    assert "lubrication no (/hydrodynamics/multipole_friction" in out


def test_order_l_coefficients_from_the_bead_forces(capsys, cone_file, stored):
    """Friction rebuilt from the per-bead forces (plain Krylov solutions, tolerance 1e-6)."""
    forces = stored["bead_forces"].reshape(-1, 6, 6)       # bead, motion, (F, T)
    arms = stored["positions"] - stored["centre_of_mass"]
    friction = np.zeros((6, 6))
    for m in range(6):
        f, t = forces[:, m, 0:3], forces[:, m, 3:6]
        friction[0:3, m] = f.sum(axis=0)
        friction[3:6, m] = (t + np.cross(arms, f)).sum(axis=0)
    mobility = np.linalg.inv(0.5 * (friction + friction.T))
    axes = np.kron(np.eye(2), stored["body_axes"])          # Fortran's paper frame
    body = axes @ mobility @ axes.T
    length = stored["length"]
    reference = np.pi * np.array([length * body[0, 0], length * body[1, 1], length * body[2, 2],
                                  length**2 * body[3, 1], length**2 * body[4, 0]])
    order_l = values(coefficients_json(capsys, cone_file, "--friction", "multipole"))
    np.testing.assert_allclose(order_l, reference, rtol=1e-5)


def test_centre_of_mobility(cone_file, stored):
    """beadmob's mobility about the centre of mobility C, and the sedimentation mechanics."""
    result = load_result(cone_file)
    hydro = result.hydrodynamics
    np.testing.assert_allclose(hydro.centre_of_mobility, stored["centre_of_mobility"])
    mobility = checked_mobility(result)                    # about the centre of mass
    offset = stored["centre_of_mobility"] - stored["centre_of_mass"]
    about_c = shift_reference_point(mobility, offset)
    scale = np.abs(stored["mobility_at_centre_of_mobility"]).max()
    np.testing.assert_allclose(about_c, stored["mobility_at_centre_of_mobility"],
                               atol=1e-9 * scale)
    # About C the coupling vanishes for this symmetric body ...
    assert np.abs(about_c[3:6, 0:3]).max() < 1e-9 * np.abs(about_c[3:6, 3:6]).max()
    # ... so gravity at the centre of mass, a distance s below C along body z, turns the body
    # with Omega = M_rr (r x F): (M_rt)_yx = -s M_rr,yy, i.e. mu51 = -pi L^2 s M_rr,yy, and
    # theta = 0 (body z up) is stable when body z points from the centre of mass to C.
    c = compute_coefficients(result)
    s = float(offset @ c.body_axes[2])
    assert s > 0
    rotation = np.kron(np.eye(2), c.body_axes)
    rr = (rotation @ about_c @ rotation.T)[3:6, 3:6]
    length = stored["length"]
    assert c.mu51 == pytest.approx(-np.pi * length**2 * s * rr[1, 1], rel=1e-9)
    assert c.mu42 == pytest.approx(np.pi * length**2 * s * rr[0, 0], rel=1e-9)


def test_classify_as_settler_with_times(capsys, cone_file, stored):
    status, out, err = run(capsys, "classify", "--json", cone_file, "--length-m", "1e-3",
                           "--viscosity", "1", "--force", "1e-3")
    assert status == 0, err
    data = json.loads(out)
    mu11, mu22, mu33, mu42, mu51 = stored["coefficients"]
    assert data["family"] == "settler"                      # mu42 mu51 < 0
    assert data["theta0_stable_rotation_about_y"] and data["theta0_stable_rotation_about_x"]
    assert any("neutral" in remark for remark in data["remarks"])   # mu42 + mu51 = 0
    assert data["tau51"] == pytest.approx(1 / mu51, rel=1e-9)
    assert data["tau42"] == pytest.approx(1 / mu42, rel=1e-9)
    # pi eta L^2 / F = pi * 1 * 1e-6 / 1e-3 s; U_f = mu33 F / (pi eta L) = mu33 / pi m/s.
    assert data["time_unit_s"] == pytest.approx(np.pi * 1e-3, rel=1e-12)
    assert data["tau51_s"] == pytest.approx(np.pi * 1e-3 / mu51, rel=1e-9)
    assert data["terminal_velocity_m_s"] == pytest.approx(mu33 / np.pi, rel=1e-9)
    status, out, _ = run(capsys, "classify", cone_file, "--friction", "multipole")
    assert status == 0 and "family:      settler" in out
    assert f"{stored['multipole_coefficients'][4]:.6g}" in out


def test_table_of_real_files(capsys, cone_file, stored, beadmob_output_dir):
    pyramid = beadmob_output_dir / "rpy_pyramid.h5"      # order 1, no lubrication
    with h5py.File(pyramid, "r") as f:
        pyramid_coefficients = f["hydrodynamics/coefficients"][()]
    for friction, cone_values, lubrication, dataset in (
            ("default", stored["coefficients"], "yes", "friction"),
            ("multipole", stored["multipole_coefficients"], "no", "multipole_friction")):
        status, out, err = run(capsys, "table", cone_file, pyramid, "--format", "csv",
                               "--friction", friction)
        assert status == 0, err
        rows = list(csv.DictReader(io.StringIO(out)))
        assert [r["N"] for r in rows] == ["80", "29"]
        names = ("mu11", "mu22", "mu33", "mu42", "mu51")
        np.testing.assert_allclose([float(rows[0][n]) for n in names], cone_values, rtol=1e-9)
        # Without lubrication the order-L friction is the friction: the same numbers.
        np.testing.assert_allclose([float(rows[1][n]) for n in names], pyramid_coefficients,
                                   rtol=1e-8)
        assert rows[0]["lubrication"] == lubrication and rows[1]["lubrication"] == "no"
        assert rows[0]["friction"] == dataset and rows[0]["family"] == "settler"
        assert rows[0]["multipole_order"] == "2" and rows[1]["multipole_order"] == "1"
        assert float(rows[0]["|mu51/mu42|"]) == pytest.approx(1.0, rel=1e-9)
    status, out, _ = run(capsys, "table", cone_file, "--friction", "multipole")
    assert "without the run's lubrication correction" in out.splitlines()[-1]


def test_compare_matches_only_the_papers_models(capsys, cone_file, beadmob_output_dir, run_command):
    # The small cone (L/d = 7) is not the paper's cone (L/d = 21): it has no row to compare.
    paper_cone = beadmob_output_dir / "cone.h5"
    status, out, err = run(capsys, "compare", cone_file, paper_cone, "--format", "csv")
    assert status == 0, err
    rows = list(csv.DictReader(io.StringIO(out)))
    assert {r["file"] for r in rows} == {str(paper_cone)}
    assert {r["quantity"]: r["beadmob"] for r in rows}["N"] == "5088.0"
    assert_one_line_error(run_command("compare", cone_file), "nothing to compare")


def test_dynamics_planar_closed_form(capsys, cone_file, stored, tmp_path):
    series = tmp_path / "planar.csv"
    status, out, err = run(capsys, "dynamics", cone_file, "--plane", "y", "--theta", "170",
                           "--samples", "80", "-o", tmp_path / "planar.png", "--csv", series)
    assert status == 0, err
    data = np.genfromtxt(series, delimiter=",", names=True)
    mu11, mu22, mu33, mu42, mu51 = stored["coefficients"]
    # tan(theta/2) = A exp(mu51 t), with beadmob's mu51.
    slope = np.polyfit(data["t"], np.log(data["tan_half_theta"]), 1)[0]
    assert slope == pytest.approx(mu51, rel=1e-6)
    assert data["theta_deg"][0] == pytest.approx(170.0) and data["theta_deg"][-1] < 1.0
    # Once upright the body falls at the terminal velocity mu33 (unit F/(pi eta L)).
    fall = -np.diff(data["Z_over_L"][-10:]) / np.diff(data["t"][-10:])
    np.testing.assert_allclose(fall, mu33, rtol=1e-6)
    assert (tmp_path / "planar.png").stat().st_size > 0


def test_dynamics_three_dimensional_start(capsys, cone_file, stored, tmp_path):
    """mu42 = -mu51 conserves g_x/g_y in the body: psi and phi stay, theta relaxes to 0."""
    series = tmp_path / "tilted.csv"
    mu51 = stored["coefficients"][4]
    t_end = 3.0 / abs(mu51)
    status, out, err = run(capsys, "dynamics", cone_file, "--theta", "120", "--phi", "30",
                           "--psi", "40", "--t-end", str(t_end), "--samples", "60",
                           "-o", tmp_path / "tilted.png", "--csv", series)
    assert status == 0, err
    data = np.genfromtxt(series, delimiter=",", names=True)
    np.testing.assert_allclose(data["psi_deg"], 40.0, atol=1e-6)
    np.testing.assert_allclose(data["phi_deg"], 30.0, atol=1e-6)
    # The tilt is planar in the plane of body z and lab Z: the closed form holds again.
    closed = 2 * np.degrees(np.arctan(np.tan(np.radians(60.0)) * np.exp(mu51 * data["t"])))
    np.testing.assert_allclose(data["theta_deg"], closed, atol=1e-6)
    assert data["theta_deg"][-1] < 10.0


def test_info_shows_what_hydrodynamics_holds(capsys, cone_file, stored):
    status, out, err = run(capsys, "info", "--json", cone_file)
    assert status == 0, err
    hydro = json.loads(out)["hydrodynamics"]
    assert hydro["lubrication"] is True and hydro["lubrication_cutoff"] == 2.0
    assert hydro["operator"] in ("direct", "fft")
    np.testing.assert_allclose(hydro["multipole_coefficients"], stored["multipole_coefficients"])
    np.testing.assert_allclose(hydro["centre_of_mobility"], stored["centre_of_mobility"])
    assert hydro["phase_seconds"]["total"] >= hydro["phase_seconds"]["solve"] > 0
    status, out, _ = run(capsys, "info", cone_file)
    assert "lubrication yes (cutoff 2 d), all solves converged, operator " in out
    assert "  order L alone:  " in out
