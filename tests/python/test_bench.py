"""Tests of the benchmark CSV format ("beadmob-bench 1") and its plots."""

from __future__ import annotations

import numpy as np
import pytest

from beadmob_post.bench import BenchError, by_series, errors, power_law_exponent, read_bench
from beadmob_post.plots import bench_figure, save

# Two series: the direct product (time ~ N^2) and the FFT operator (time ~ N log N); the
# coefficients of order 1, 2 converge towards the order-3 line of the "direct" series.
EXAMPLE = """\
# beadmob-bench 1: one line per run
series,shape,n_beads,multipole_order,lubrication,ranks,wall_time_s,mu11,mu22,mu33,mu42,mu51
direct,cone,100,1,0,2,0.01,0.300,0.300,0.330,0.060,-0.060
direct,cone,200,1,0,2,0.04,0.290,0.290,0.320,0.058,-0.058
direct,cone,400,2,1,2,0.16,0.272,0.272,0.305,0.0575,-0.0575
direct,cone,800,3,1,2,0.64,0.270,0.270,0.303,0.057,-0.057
fft, cone, 400, 1, 0, 2, 0.05, , , , ,
fft, cone, 800, 1, 0, 2, 0.11, , , , ,
"""


@pytest.fixture
def bench_csv(tmp_path):
    path = tmp_path / "bench.csv"
    path.write_text(EXAMPLE)
    return path


def test_read_and_group(bench_csv):
    runs = read_bench(bench_csv)
    groups = by_series(runs)
    assert list(groups) == ["direct", "fft"]
    assert [run.values["n_beads"] for run in groups["direct"]] == [100, 200, 400, 800]
    assert groups["fft"][0].get("mu11") is None
    assert groups["direct"][2].values["lubrication"] == 1


def test_power_law_exponent(bench_csv):
    direct = by_series(read_bench(bench_csv))["direct"]
    n = np.array([run.values["n_beads"] for run in direct])
    time = np.array([run.values["wall_time_s"] for run in direct])
    assert power_law_exponent(n, time) == pytest.approx(2.0)   # 0.01 (N/100)^2
    assert power_law_exponent(np.array([5.0, 5.0]), np.array([1.0, 2.0])) is None


def test_errors_against_the_reference_line(bench_csv):
    direct = by_series(read_bench(bench_csv))["direct"]
    found = {run.values["n_beads"]: error for run, error in errors(direct)}
    # Reference: the order-3 line (largest multipole order); scale max |mu_ref| = 0.303.
    assert set(found) == {100, 200, 400}
    assert found[100] == pytest.approx(0.030 / 0.303)
    assert found[200] == pytest.approx(0.020 / 0.303)
    assert found[400] == pytest.approx(0.002 / 0.303)


def test_explicit_error_and_reference_columns(tmp_path):
    path = tmp_path / "b.csv"
    path.write_text("n_beads,wall_time_s,mu11,reference,error\n"
                    "10,1,0.5,1,\n20,2,0.6,,\n30,3,0.7,,0.001\n")
    found = {run.values["n_beads"]: e for run, e in errors(read_bench(path))}
    assert found == {20: pytest.approx(0.2), 30: 0.001}


@pytest.mark.parametrize("kind", ["time-vs-n", "time-vs-error", "convergence"])
def test_plots_png_and_pdf(bench_csv, tmp_path, kind):
    runs = read_bench(bench_csv)
    png = save(bench_figure(runs, kind), tmp_path / f"{kind}.png", dpi=50)
    pdf = save(bench_figure(runs, kind, x="multipole_order"), tmp_path / f"{kind}.pdf")
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert pdf.read_bytes()[:5] == b"%PDF-"


def test_time_vs_n_legend_gives_the_exponent(bench_csv):
    figure = bench_figure(read_bench(bench_csv), "time-vs-n")
    labels = [text.get_text() for text in figure.axes[0].get_legend().get_texts()]
    assert labels[0] == "direct (time ~ N^2.00)"
    assert labels[1].startswith("fft (time ~ N^1.1")


def test_nothing_to_draw(tmp_path):
    path = tmp_path / "b.csv"
    path.write_text("n_beads,wall_time_s\n10,1\n20,2\n")
    with pytest.raises(ValueError, match="no line has an error"):
        bench_figure(read_bench(path), "time-vs-error")


@pytest.mark.parametrize(
    "content, message",
    [
        ("", "empty file"),
        ("n_beads,time\n1,2\n", r"missing column\(s\) wall_time_s"),
        ("n_beads,wall_time_s\n10,fast\n", "data line 1, column 'wall_time_s': 'fast' is not a number"),
        ("n_beads,wall_time_s\n10,-1\n", "must be positive"),
        ("n_beads,wall_time_s\n", "no data lines"),
        ("n_beads,wall_time_s\n,1\n", "empty n_beads"),
    ],
)
def test_bad_bench_files(tmp_path, content, message):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    with pytest.raises(BenchError, match=message):
        read_bench(path)
