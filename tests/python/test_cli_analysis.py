"""The analysis commands of beadmob-post, in process (fast) and as a subprocess (errors)."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest

from beadmob_post.cli import main
from beadmob_post.paper import TAB_MOB_NUM
from test_cli import assert_one_line_error
from test_mobility import dimensionless_pattern, hydro_file
from test_tables import paper_like_file


def run(capsys, *arguments) -> tuple[int, str, str]:
    status = main([str(a) for a in arguments])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.fixture
def settler_file(make_result_file):
    return hydro_file(make_result_file, dimensionless_pattern(), np.eye(3), np.eye(3), name="s.h5")


def test_help_lists_the_analysis_commands(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    for command in ("coefficients", "classify", "dynamics", "fit", "table", "compare",
                    "plot-coefficients", "plot-bench", "report"):
        assert command in text


def test_coefficients_text_and_json(capsys, settler_file):
    status, out, _ = run(capsys, "coefficients", settler_file)
    assert status == 0
    assert "mu51:             -0.030000" in out
    off_pattern = float(out.split("off-pattern:")[1].split()[0])
    assert off_pattern < 1e-12   # the synthetic mobility has exactly the paper's form
    status, out, _ = run(capsys, "coefficients", "--json", settler_file)
    data = json.loads(out)
    assert data["coefficients"]["mu42"] == pytest.approx(0.05)
    assert len(data["off_pattern_entries"]) == 19
    assert data["paper_class"] is True


def test_classify_with_physical_units(capsys, settler_file):
    status, out, _ = run(capsys, "classify", settler_file, "--json", "--length-m", "0.005",
                         "--viscosity", "4.85", "--force", "0.001", "--fluid-density", "970")
    assert status == 0
    data = json.loads(out)
    assert data["family"] == "settler"
    unit = np.pi * 4.85 * 0.005**2 / 0.001                   # eq. eq:time
    assert data["time_unit_s"] == pytest.approx(unit)
    assert data["tau51_s"] == pytest.approx(unit / -0.03)     # eq. eq:mobility
    assert data["tau42_s"] == pytest.approx(unit / 0.05)
    assert data["terminal_velocity_m_s"] == pytest.approx(0.45 * 0.001 / (np.pi * 4.85 * 0.005))
    status, out, _ = run(capsys, "classify", settler_file)
    assert "family:      settler" in out and "tau51 = 1/mu51 = -33.3333" in out


def test_classify_density_difference_uses_the_bead_volume(capsys, settler_file):
    # 4 beads, L = 3 d = 3 mm: d = 1 mm, V = 4 pi/6 mm^3; F = 1000 kg/m^3 V g.
    status, out, _ = run(capsys, "classify", settler_file, "--json", "--length-m", "0.003",
                         "--viscosity", "1", "--density-difference", "1000")
    assert status == 0
    assert json.loads(out)["force_N"] == pytest.approx(1000 * 4 * np.pi / 6 * 1e-9 * 9.80665)


def test_dynamics_plane_writes_figure_and_csv(capsys, settler_file, tmp_path):
    figure, table = tmp_path / "d.pdf", tmp_path / "d.csv"
    status, out, _ = run(capsys, "dynamics", settler_file, "--plane", "x", "--theta", "150",
                         "-o", figure, "--csv", table, "--samples", "50")
    assert status == 0
    assert "closed form tan(theta/2) = A exp(-mu42 t)" in out
    deviation = float(out.split("largest difference ")[1].split()[0])
    assert deviation < 1e-5
    assert figure.read_bytes()[:5] == b"%PDF-"
    rows = list(csv.DictReader(io.StringIO(table.read_text())))
    assert len(rows) == 50 and float(rows[0]["theta_deg"]) == pytest.approx(150.0)
    assert float(rows[-1]["theta_deg"]) < 1e-3


def test_dynamics_general_start_with_seconds(capsys, settler_file, tmp_path):
    table = tmp_path / "d.csv"
    status, out, _ = run(capsys, "dynamics", settler_file, "--theta", "120", "--phi", "20",
                         "--psi", "50", "--t-end", "10", "--samples", "11", "-o",
                         tmp_path / "d.png", "--csv", table, "--length-m", "0.003",
                         "--viscosity", "2", "--force", "1e-3")
    assert status == 0
    rows = list(csv.DictReader(io.StringIO(table.read_text())))
    unit = np.pi * 2 * 0.003**2 / 1e-3
    assert float(rows[-1]["t_s"]) == pytest.approx(10 * unit)
    assert (tmp_path / "d.png").stat().st_size > 10_000


def test_paper_coefficients_without_a_file(capsys, tmp_path):
    # Crescent moon of tab_mob_num: a settler whose rotation about y = Y picks up rotation
    # about z while theta > pi/2 (section "Discussion and conclusions").
    status, out, _ = run(capsys, "classify", "--paper", "crescent_moon", "--json")
    data = json.loads(out)
    assert data["family"] == "settler" and data["tau42"] == pytest.approx(1 / 0.381)
    table = tmp_path / "moon.csv"
    status, out, _ = run(capsys, "dynamics", "--paper", "crescent_moon", "--theta", "175",
                         "--psi", "10", "-o", tmp_path / "moon.png", "--csv", table)
    assert status == 0 and "Table tab_mob_num" in out
    rows = list(csv.DictReader(io.StringIO(table.read_text())))
    psi = np.array([float(row["psi_deg"]) for row in rows])
    theta = np.array([float(row["theta_deg"]) for row in rows])
    assert psi[theta > 90].max() > 3 * psi[0]       # spin about z grows while theta > 90 deg
    assert abs(psi[-1]) < 1.0 and theta[-1] < 0.1   # and dies out at the stable orientation
    status, _, err = run(capsys, "classify")
    assert status == 2 and "give a result FILE or --paper SHAPE" in err


def test_fit_table_and_mu(capsys, tmp_path):
    t = np.arange(0.0, 30.0)
    paths = []
    for name, amplitude, rate in (("cone", 2.743, 0.1244), ("ring", 2.865, 0.0407)):
        path = tmp_path / f"{name}.csv"
        theta = np.degrees(2 * np.arctan(amplitude * np.exp(-rate * t)))
        np.savetxt(path, np.column_stack([t, theta]), delimiter=",", header="t,theta_deg",
                   comments="# trial\n")
        paths.append(path)
    status, out, _ = run(capsys, "fit", *paths, "--plot-dir", tmp_path)
    assert status == 0
    assert "| cone | 2.743 ± 0.000 | 0.1244 ± 0.0000 | 1.000 |" in out
    assert (tmp_path / "ring_fit.png").exists()
    status, out, _ = run(capsys, "fit", paths[0], "--format", "tex")
    assert r"2.743 $\pm$ 0.000" in out
    # Cone, tab:mobility_velocity: 1/tau = 0.113 1/s gives mu ~ 0.030 with L = 4.39 mm,
    # F = 1.10 mN, eta = 4.85 Pa s; here 1/tau = 0.1244 (tab:fitting_param) gives 0.033.
    status, out, _ = run(capsys, "fit", paths[0], "--axis", "y", "--length-m", "4.39e-3",
                         "--force", "1.10e-3", "--viscosity", "4.85")
    mu51 = float(out.split("mu51 = ")[1].split()[0])
    assert mu51 == pytest.approx(-0.1244 * np.pi * 4.85 * 4.39e-3**2 / 1.10e-3, rel=1e-3)


def test_table_and_compare_outputs(capsys, make_result_file, tmp_path):
    cone = paper_like_file(make_result_file, "cone", "cone.h5")
    out_csv = tmp_path / "t.csv"
    status, out, _ = run(capsys, "table", cone, "-o", out_csv)
    assert status == 0 and out.strip() == f"wrote {out_csv}"
    assert next(csv.DictReader(out_csv.open()))["object"] == "Cone"
    bars = tmp_path / "bars.png"
    status, out, _ = run(capsys, "compare", cone, "--plot", bars)
    assert status == 0
    assert "| Cone | 21 (21; +0.00 %) | 4 (5088; -99.92 %) | 0.2690 (0.269; +0.0 %)" in out
    assert bars.stat().st_size > 10_000


def test_plot_coefficients_and_bench(capsys, settler_file, tmp_path):
    status, out, _ = run(capsys, "plot-coefficients", settler_file, "-o", tmp_path / "c.pdf")
    assert status == 0 and (tmp_path / "c.pdf").read_bytes()[:5] == b"%PDF-"
    bench = tmp_path / "bench.csv"
    bench.write_text("n_beads,wall_time_s\n100,1\n200,4\n")
    status, out, _ = run(capsys, "plot-bench", bench)
    assert status == 0 and (tmp_path / "bench_time-vs-n.png").exists()


def test_report_writes_tables_and_figures(capsys, make_result_file, tmp_path):
    cone = paper_like_file(make_result_file, "cone", "cone.h5")
    geometry_only = make_result_file(name="g.h5")
    directory = tmp_path / "report"
    status, out, _ = run(capsys, "report", cone, geometry_only, "-o", directory)
    assert status == 0
    names = sorted(p.name for p in directory.iterdir())
    assert names == sorted([
        "coefficients.csv", "coefficients.md", "coefficients.tex", "comparison.csv",
        "comparison.md", "comparison.tex", "coefficients_vs_paper.png",
        "coefficients_vs_paper.pdf", "cone_beads.png", "g_beads.png"])


def test_real_files_end_to_end(capsys, beadmob_output_dir, real_hydro_file, tmp_path):
    status, out, _ = run(capsys, "classify", real_hydro_file)
    assert status == 0 and "family:      settler" in out
    status, out, _ = run(capsys, "coefficients", "--json", real_hydro_file)
    data = json.loads(out)
    assert data["multipole_order"] >= 1 and data["all_converged"] is True
    paper_files = [beadmob_output_dir / f"{row.shape}.h5" for row in TAB_MOB_NUM]
    status, out, _ = run(capsys, "report", *paper_files, real_hydro_file, "-o", tmp_path,
                         "--no-beads")
    assert status == 0
    comparison = (tmp_path / "comparison.md").read_text().splitlines()
    assert sum(line.startswith("| ") for line in comparison) == 1 + 7  # header + 7 shapes
    table = list(csv.DictReader((tmp_path / "coefficients.csv").open()))
    assert len(table) == 8 and table[-1]["family"] == "settler"
    # dynamics of the real file -> its theta(t) CSV -> fit gives back 1/tau = -mu51.
    series = tmp_path / "pyramid.csv"
    status, out, _ = run(capsys, "dynamics", real_hydro_file, "--plane", "y", "--theta", "170",
                         "--samples", "60", "-o", tmp_path / "p.png", "--csv", series)
    assert status == 0
    status, out, _ = run(capsys, "fit", series, "-o", tmp_path / "fit.csv")
    fit = next(csv.DictReader((tmp_path / "fit.csv").open()))
    assert float(fit["rate_per_unit_t"]) == pytest.approx(-data["coefficients"]["mu51"], rel=1e-6)
    assert float(fit["r_squared"]) == pytest.approx(1.0, abs=1e-9)


# ---------------------------------------------------------------- errors, as the user sees them
def test_errors_are_one_line(run_command, make_result_file, tmp_path):
    friction = np.diag([3 * np.pi] * 3 + [np.pi] * 3)
    friction[4, 4] = 0.0
    singular = make_result_file(name="singular.h5", hydrodynamics={"friction": friction, "mobility": None})
    unconverged = hydro_file(make_result_file, dimensionless_pattern(), np.eye(3), np.eye(3),
                             name="unconverged.h5", hydro={"all_converged": 0})
    geometry_only = make_result_file(name="g.h5")
    other = tmp_path / "other.csv"
    other.write_text("a,b\n1,2\n")
    assert_one_line_error(run_command("coefficients", singular), "friction matrix is singular")
    assert_one_line_error(run_command("classify", unconverged), "not converged", "all_converged = 0")
    assert_one_line_error(run_command("dynamics", geometry_only), "no /hydrodynamics")
    assert_one_line_error(run_command("compare", other), "is not an HDF5 file")
    assert_one_line_error(run_command("fit", other), "must name columns 't'")
    assert_one_line_error(run_command("table", tmp_path / "missing.h5"), "no such file")
    # A file without the order-L friction (older beadmob) cannot give --friction multipole.
    assert_one_line_error(run_command("compare", unconverged, "--friction", "multipole",
                                      "--allow-unconverged"),
                          "no /hydrodynamics/multipole_friction")


def test_usage_errors(capsys, settler_file, tmp_path):
    status, _, err = run(capsys, "classify", settler_file, "--length-m", "0.01", "--force", "1")
    assert status == 2 and "give the viscosity" in err
    status, _, err = run(capsys, "dynamics", settler_file, "--plane", "y", "--phi", "3")
    assert status == 2 and "--plane fixes phi and psi" in err
    status, _, err = run(capsys, "compare", settler_file)
    assert status == 2 and "nothing to compare" in err
    status, _, err = run(capsys, "plot-coefficients", tmp_path / "none.h5", "-o", tmp_path / "x.png")
    assert status == 2 and "no such file" in err
    status, _, err = run(capsys, "table", settler_file, "-o", tmp_path / "t.txt")
    assert status == 2 and "unknown table format '.txt'" in err
    status, _, err = run(capsys, "coefficients", settler_file, "--reference-length", "0")
    assert status == 2 and "--reference-length must be positive" in err


def test_real_unconverged_file_as_the_user_sees_it(run_command, beadmob_output_dir):
    path = beadmob_output_dir / "max_it" / "rpy_pyramid.h5"
    if not path.exists():
        pytest.skip(f"{path} not written (CTest test flagged_nonconvergence_np2 writes it)")
    assert_one_line_error(run_command("classify", path), str(path), "not converged")


def test_info_reports_hydrodynamics(capsys, make_result_file):
    path = hydro_file(make_result_file, dimensionless_pattern(), np.eye(3), np.eye(3),
                      name="u.h5", hydro={"all_converged": 0, "multipole_order": 2, "lubrication": 1})
    status, out, _ = run(capsys, "info", path)
    assert status == 0
    assert "hydrodynamics:    multipole order 2, lubrication yes, NOT CONVERGED" in out
    status, out, _ = run(capsys, "info", "--json", path)
    assert json.loads(out)["hydrodynamics"]["all_converged"] is False
    status, out, _ = run(capsys, "info", "--json", make_result_file(name="g.h5"))
    assert json.loads(out)["hydrodynamics"] is None
