"""Benchmark / convergence tables (CSV) as written by ``bench/``; format "beadmob-bench 1".

One line per run, comma separated, a header line naming the columns, ``#`` comment lines
allowed anywhere. Columns (order free, unknown columns ignored):

* required: ``n_beads`` (N), ``wall_time_s`` (wall time of the run, seconds);
* optional: ``series`` (label grouping the lines into curves; default "all"),
  ``multipole_order``, ``lubrication`` (0/1), ``ranks``, ``mu11`` ... ``mu51`` (the paper's
  coefficients), ``error`` (relative error of the run, if the benchmark knows it),
  ``reference`` (1 on the line that is the reference of its series).

The error of a line without an ``error`` value is computed from its coefficients:
max_k |mu_k - mu_k(ref)| / max_k |mu_k(ref)| against the reference line of its series (the
line with ``reference`` = 1, else the one with the largest multipole order, then N).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from beadmob_post.paper import COEFFICIENT_NAMES

REQUIRED = ("n_beads", "wall_time_s")
NUMERIC = ("n_beads", "wall_time_s", "multipole_order", "lubrication", "ranks", "error",
           "reference", *COEFFICIENT_NAMES)


class BenchError(ValueError):
    """A benchmark CSV cannot be used; the message names the file and the problem."""


@dataclass(frozen=True)
class BenchRun:
    series: str
    values: dict[str, float]   # the numeric columns present on this line

    def get(self, name: str) -> float | None:
        return self.values.get(name)


def read_bench(path: str | Path) -> list[BenchRun]:
    path = Path(path)
    if not path.exists():
        raise BenchError(f"{path}: no such file")
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            lines = [line for line in handle if line.strip() and not line.lstrip().startswith("#")]
    except (OSError, UnicodeDecodeError) as exc:
        raise BenchError(f"{path}: cannot read the file: {exc}") from exc
    if not lines:
        raise BenchError(f"{path}: empty file (expected a header line and data)")
    reader = csv.DictReader(lines, skipinitialspace=True)
    header = [name.strip() for name in (reader.fieldnames or [])]
    reader.fieldnames = header
    missing = [name for name in REQUIRED if name not in header]
    if missing:
        raise BenchError(f"{path}: missing column(s) {', '.join(missing)} in the header "
                         f"(found: {', '.join(header)})")
    runs = []
    for number, row in enumerate(reader, start=1):
        values = {}
        for name in NUMERIC:
            text = (row.get(name) or "").strip()
            if not text:
                if name in REQUIRED:
                    raise BenchError(f"{path}: data line {number}: empty {name}")
                continue
            try:
                value = float(text)
            except ValueError:
                raise BenchError(f"{path}: data line {number}, column {name!r}: {text!r} is not a number") from None
            if not math.isfinite(value):
                raise BenchError(f"{path}: data line {number}, column {name!r} is not finite")
            values[name] = value
        if values["n_beads"] <= 0 or values["wall_time_s"] <= 0:
            raise BenchError(f"{path}: data line {number}: n_beads and wall_time_s must be positive")
        runs.append(BenchRun((row.get("series") or "all").strip() or "all", values))
    if not runs:
        raise BenchError(f"{path}: no data lines")
    return runs


def by_series(runs: list[BenchRun]) -> dict[str, list[BenchRun]]:
    groups: dict[str, list[BenchRun]] = {}
    for run in runs:
        groups.setdefault(run.series, []).append(run)
    return groups


def reference_run(runs: list[BenchRun]) -> BenchRun:
    marked = [run for run in runs if run.get("reference") == 1]
    if marked:
        return marked[0]
    return max(runs, key=lambda run: (run.get("multipole_order") or 0, run.values["n_beads"]))


def errors(runs: list[BenchRun]) -> list[tuple[BenchRun, float]]:
    """(run, relative error) of one series, the reference line left out (see module docstring)."""
    reference = reference_run(runs)
    ref = np.array([reference.get(n) if reference.get(n) is not None else np.nan for n in COEFFICIENT_NAMES])
    scale = np.nanmax(np.abs(ref)) if np.any(np.isfinite(ref)) else np.nan
    result = []
    for run in runs:
        if run.get("error") is not None:
            result.append((run, run.values["error"]))
            continue
        if run is reference:
            continue
        mu = np.array([run.get(n) if run.get(n) is not None else np.nan for n in COEFFICIENT_NAMES])
        usable = np.isfinite(mu) & np.isfinite(ref)
        if usable.any() and np.isfinite(scale) and scale > 0:
            result.append((run, float(np.max(np.abs(mu[usable] - ref[usable])) / scale)))
    return result


def power_law_exponent(n: np.ndarray, time: np.ndarray) -> float | None:
    """Slope of log(time) against log(N) by least squares (time ~ N^slope); None below 2 N."""
    n, time = np.asarray(n, float), np.asarray(time, float)
    if len(np.unique(n)) < 2:
        return None
    slope, _ = np.polyfit(np.log(n), np.log(time), 1)
    return float(slope)
