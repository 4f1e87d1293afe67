"""Tables of many result files (CSV, Markdown, LaTeX) and the comparison with the paper.

The columns follow Table `tab_mob_num` of the paper: object, L/d, number of beads, mu11, mu22,
mu33, mu42, mu51, |mu51/mu42|, (mu51 + mu42)/|mu51|; then the family (settler, ...), the
multipole order and lubrication of the run and the off-pattern measure. Files without
/hydrodynamics (geometry-only runs) get their geometry columns and empty coefficients.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from beadmob_post.classify import classify
from beadmob_post.mobility import Coefficients, compute_coefficients
from beadmob_post.paper import (
    CITATION,
    COEFFICIENT_NAMES,
    PAPER_LUBRICATION,
    PAPER_MULTIPOLE_ORDER,
    PaperBeadModel,
    paper_counterpart,
)
from beadmob_post.results import BeadResult, load_result

FORMATS = ("csv", "md", "tex")
_LATEX_NAMES = {"mu11": r"$\mu_{11}$", "mu22": r"$\mu_{22}$", "mu33": r"$\mu_{33}$",
                "mu42": r"$\mu_{42}$", "mu51": r"$\mu_{51}$"}


@dataclass(frozen=True)
class Row:
    """One result file in a table."""

    path: str
    shape: str
    label: str
    length_over_d: float | None
    n_beads: int
    coefficients: Coefficients | None
    family: str | None
    #: the Table `tab_mob_num` row of the same shape and L/d, if any
    paper: PaperBeadModel | None = None

    @property
    def values(self) -> dict[str, float | None]:
        c = self.coefficients
        base = dict.fromkeys(COEFFICIENT_NAMES)
        if c is None:
            return {**base, "ratio_51_42": None, "sum_over_51": None}
        return {**c.as_dict(), "ratio_51_42": c.ratio_51_42, "sum_over_51": c.sum_over_51}

    @property
    def errors(self) -> dict[str, float | None]:
        """The run's estimated error of each coefficient (None without an error bar)."""
        bar = None if self.coefficients is None else self.coefficients.error_bar
        if bar is None:
            return dict.fromkeys(COEFFICIENT_NAMES)
        return dict(zip(COEFFICIENT_NAMES, bar.errors))

    @property
    def extrapolated(self) -> dict[str, float | None]:
        """The coefficients extrapolated in L and their estimated errors (None without)."""
        bar = None if self.coefficients is None else self.coefficients.error_bar
        if bar is None:
            return {**dict.fromkeys(COEFFICIENT_NAMES), **dict.fromkeys(f"{n}_error" for n in COEFFICIENT_NAMES)}
        return {**dict(zip(COEFFICIENT_NAMES, bar.extrapolated)),
                **{f"{n}_error": e for n, e in zip(COEFFICIENT_NAMES, bar.extrapolated_errors)}}


def collect(paths: Sequence[str | Path], allow_unconverged: bool = False,
            friction: str = "default") -> list[Row]:
    """Rows of the table, in the order given; every file is checked as by ``coefficients``.

    ``friction`` is that of :func:`beadmob_post.mobility.compute_coefficients`.
    """
    rows = []
    for path in paths:
        result = load_result(path)
        rows.append(row_of(result, allow_unconverged, friction))
    return rows


def row_of(result: BeadResult, allow_unconverged: bool = False, friction: str = "default") -> Row:
    coefficients = family = None
    if result.hydrodynamics is not None:
        coefficients = compute_coefficients(result, allow_unconverged=allow_unconverged,
                                            friction=friction)
        family = classify(coefficients).family
    paper = paper_counterpart(result.shape_name, result.reference_length)
    return Row(
        path=str(result.path), shape=result.shape_name,
        label=paper.label if paper is not None else result.shape_name,
        length_over_d=result.reference_length, n_beads=result.n_beads,
        coefficients=coefficients, family=family, paper=paper,
    )


def _number(value: float | None, digits: int = 4) -> str:
    if value is None:
        return ""
    if math.isinf(value):
        return "inf"
    return f"{value:.{digits}f}"


def _with_error(value: float | None, error: float | None, fmt: str, digits: int = 4) -> str:
    """'0.2688 +- 0.0008' (md; $\\pm$ in tex), or the value alone without an error bar."""
    if error is None or value is None:
        return _number(value, digits)
    sign = r" $\pm$ " if fmt == "tex" else " ± "
    return f"{value:.{digits}f}{sign}{error:.{digits}f}"


def _method(row: Row) -> tuple[str, str, str]:
    c = row.coefficients
    if c is None:
        return "", "", ""
    order = "" if c.multipole_order is None else str(c.multipole_order)
    lubrication = "" if c.lubrication is None else ("yes" if c.lubrication else "no")
    return order, lubrication, f"{c.off_pattern:.2g}"


HEADER = ["object", "L/d", "N", *COEFFICIENT_NAMES, "|mu51/mu42|", "(mu51+mu42)/|mu51|",
          "family", "multipole_order", "lubrication", "off_pattern", "friction", "file",
          *[f"{n}_error" for n in COEFFICIENT_NAMES], *[f"{n}_extrapolated" for n in COEFFICIENT_NAMES],
          *[f"{n}_extrapolated_error" for n in COEFFICIENT_NAMES]]

#: The /hydrodynamics dataset each ``--friction`` choice reads.
FRICTION_DATASETS = {"default": "friction", "multipole": "multipole_friction"}


def method_note(rows: Sequence[Row]) -> str:
    """One sentence naming how the coefficients of ``rows`` were computed ('' without any)."""
    described = []
    for row in rows:
        c = row.coefficients
        if c is None:
            continue
        order = "?" if c.multipole_order is None else str(c.multipole_order)
        if c.friction == "multipole":
            text = (f"multipole order {order}, the order-L friction /hydrodynamics/multipole_friction"
                    + (" without the run's lubrication correction" if c.run_lubrication else ""))
        else:
            text = (f"multipole order {order}, /hydrodynamics/friction"
                    + {True: " with the lubrication correction", False: " without lubrication",
                       None: ""}[c.lubrication])
        if text not in described:
            described.append(text)
    return f"beadmob: {'; '.join(described)}." if described else ""


def error_note(rows: Sequence[Row]) -> str:
    """What the +- means, when a row has an error bar."""
    if not any(row.coefficients is not None and row.coefficients.error_bar is not None for row in rows):
        return ""
    return (" +-: the run's own estimated truncation error (its order L against its companion of order "
            "L - 1, beadmob docs/theory.md T14).")


def format_table(rows: Sequence[Row], fmt: str) -> str:
    """The batch table as ``csv`` (full precision), ``md`` or ``tex`` (paper's rounding)."""
    if fmt == "csv":
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(HEADER)
        for row in rows:
            values = row.values
            writer.writerow([
                row.label, "" if row.length_over_d is None else f"{row.length_over_d:g}",
                row.n_beads,
                *["" if values[n] is None else repr(values[n]) for n in COEFFICIENT_NAMES],
                "" if values["ratio_51_42"] is None else repr(values["ratio_51_42"]),
                "" if values["sum_over_51"] is None else repr(values["sum_over_51"]),
                row.family or "", *_method(row),
                "" if row.coefficients is None else FRICTION_DATASETS[row.coefficients.friction],
                row.path,
                *["" if row.errors[n] is None else repr(row.errors[n]) for n in COEFFICIENT_NAMES],
                *["" if row.extrapolated[n] is None else repr(row.extrapolated[n]) for n in COEFFICIENT_NAMES],
                *["" if row.extrapolated[f"{n}_error"] is None else repr(row.extrapolated[f"{n}_error"])
                  for n in COEFFICIENT_NAMES],
            ])
        return out.getvalue()
    cells = []
    for row in rows:
        values = row.values
        cells.append([
            row.label, "" if row.length_over_d is None else f"{row.length_over_d:g}",
            str(row.n_beads),
            *[_with_error(values[n], row.errors[n], fmt) for n in COEFFICIENT_NAMES],
            _number(values["ratio_51_42"], 3), _number(values["sum_over_51"], 3),
            row.family or "", *_method(row)[:2],
        ])
    if fmt == "md":
        header = ["Object", "L/d", "N", *COEFFICIENT_NAMES, "\\|mu51/mu42\\|",
                  "(mu51+mu42)/\\|mu51\\|", "family", "L", "lubrication"]
        note = method_note(rows) + error_note(rows)
        return _markdown(header, cells) + (f"\n{note}\n" if note else "")
    if fmt == "tex":
        header = ["Object (shape)", "$L/d$", "Number of beads",
                  *[_LATEX_NAMES[n] for n in COEFFICIENT_NAMES], r"$|\mu_{51}/\mu_{42}|$",
                  r"$\frac{\mu_{51}+\mu_{42}}{|\mu_{51}|}$", "family", "order $L$", "lubrication"]
        note = method_note(rows) + error_note(rows)
        caption = ("Dimensionless mobility coefficients (eq.~(matrices) of the settlers paper) "
                   "computed by beadmob." + (" " + _latex_escape(note) if note else ""))
        return _latex(header, cells, caption, "tab:beadmob_coefficients")
    raise ValueError(f"unknown table format {fmt!r}; use one of {', '.join(FORMATS)}")


def relative_difference(value: float | None, reference: float) -> float | None:
    """(value - reference)/|reference|; None when either is missing or the reference is 0."""
    if value is None or reference == 0:
        return None
    return (value - reference) / abs(reference)


COMPARED = ("L/d", "N", *COEFFICIENT_NAMES)


def comparison(rows: Sequence[Row]) -> list[tuple[Row, list[tuple[str, float | None, float, float | None]]]]:
    """For each row with a paper counterpart: (quantity, beadmob, paper, relative difference); the
    run's estimated error of a coefficient is ``row.errors``."""
    compared = []
    for row in rows:
        paper = row.paper
        if paper is None:
            continue
        values = row.values
        items = [("L/d", row.length_over_d, float(paper.length_over_d)),
                 ("N", float(row.n_beads), float(paper.n_beads))]
        items += [(name, values[name], value) for name, value in zip(COEFFICIENT_NAMES, paper.coefficients())]
        compared.append((row, [(q, v, p, relative_difference(v, p)) for q, v, p in items]))
    return compared


def format_comparison(rows: Sequence[Row], fmt: str) -> str:
    """beadmob beside Table `tab_mob_num`: CSV one line per quantity; md/tex one per object."""
    compared = comparison(rows)
    note = (f"Paper: Table tab_mob_num of the {CITATION}; multipole order "
            f"{PAPER_MULTIPOLE_ORDER}{' with lubrication' if PAPER_LUBRICATION else ''}.")
    if fmt == "csv":
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(["object", "quantity", "beadmob", "paper", "relative_difference",
                         "multipole_order", "lubrication", "friction", "file", "estimated_error"])
        for row, items in compared:
            order, lubrication, _ = _method(row)
            friction = "" if row.coefficients is None else FRICTION_DATASETS[row.coefficients.friction]
            for quantity, value, paper_value, difference in items:
                error = row.errors.get(quantity)
                writer.writerow([row.label, quantity, "" if value is None else repr(value),
                                 repr(paper_value), "" if difference is None else repr(difference),
                                 order, lubrication, friction, row.path, "" if error is None else repr(error)])
        return out.getvalue()

    def cell(quantity: str, value, paper_value, difference, error) -> str:
        integer = quantity in ("L/d", "N")
        shown = "n/a" if value is None else (f"{value:g}" if integer else _with_error(value, error, fmt))
        paper_text = f"{paper_value:g}" if integer else f"{paper_value:.3f}"
        diff = "" if difference is None else f"; {100 * difference:+.{2 if integer else 1}f} %"
        if fmt == "tex":
            diff = diff.replace("%", r"\%")
        return f"{shown} ({paper_text}{diff})"

    cells = [[row.label, *[cell(*item, row.errors.get(item[0])) for item in items], _method(row)[0]]
             for row, items in compared]
    if fmt == "md":
        header = ["Object", *COMPARED, "L"]
        beadmob = method_note([row for row, _ in compared])
        return (_markdown(header, cells)
                + f"\nCells: beadmob (paper; relative difference). {note}" + error_note([row for row, _ in compared])
                + (f" {beadmob}" if beadmob else "") + "\n")
    if fmt == "tex":
        header = ["Object", "$L/d$", "$N$", *[_LATEX_NAMES[n] for n in COEFFICIENT_NAMES], "order $L$"]
        beadmob = method_note([row for row, _ in compared])
        caption = ("beadmob (paper; relative difference) beside Table tab\\_mob\\_num of the "
                   f"settlers paper (multipole order {PAPER_MULTIPOLE_ORDER}, with lubrication)."
                   + (" " + _latex_escape(beadmob) if beadmob else ""))
        return _latex(header, cells, caption, "tab:beadmob_vs_paper")
    raise ValueError(f"unknown table format {fmt!r}; use one of {', '.join(FORMATS)}")


def format_fit_table(fits, fmt: str) -> str:
    """The form of Table `tab:fitting_param`: object, A, 1/tau, R^2 (standard errors)."""
    if fmt == "csv":
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(["file", "n", "A", "A_error", "rate_per_unit_t", "rate_error", "tau",
                         "r_squared", "weighting"])
        for f in fits:
            writer.writerow([f.path, f.n, repr(f.amplitude), repr(f.amplitude_error), repr(f.rate),
                             repr(f.rate_error), repr(f.tau), repr(f.r_squared), f.weighting])
        return out.getvalue()
    pm = r" $\pm$ " if fmt == "tex" else " ± "
    cells = [[Path(f.path).stem, f"{f.amplitude:.3f}{pm}{f.amplitude_error:.3f}",
              f"{f.rate:.4f}{pm}{f.rate_error:.4f}", f"{f.r_squared:.3f}"] for f in fits]
    if fmt == "md":
        return _markdown(["Series", "A", "1/tau", "R^2"], cells)
    if fmt == "tex":
        return _latex(["Series", "A", r"$1/\tilde{\tau}$ (s$^{-1}$)", "$R^2$"], cells,
                      "Weighted fit of eq.~(eq:exp\\_exp) (form of Table tab:fitting\\_param).",
                      "tab:beadmob_fit")
    raise ValueError(f"unknown table format {fmt!r}; use one of {', '.join(FORMATS)}")


def _markdown(header: list[str], cells: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(c.replace("|", "\\|") if i == 0 else c for i, c in enumerate(row)) + " |"
              for row in cells]
    return "\n".join(lines) + "\n"


def _latex_escape(text: str) -> str:
    return text.replace("_", r"\_").replace("&", r"\&")


def _latex(header: list[str], cells: list[list[str]], caption: str, label: str) -> str:
    lines = [r"\begin{table}[h!]", r"  \centering",
             r"  \begin{tabular}{" + "|".join("c" * len(header)) + "}", r"    \hline",
             "    " + " & ".join(header) + r" \\ \hline"]
    for row in cells:
        lines.append("    " + " & ".join([_latex_escape(row[0]), *row[1:]]) + r" \\")
    lines += [r"    \hline", r"  \end{tabular}", f"  \\caption{{{caption}}}",
              f"  \\label{{{label}}}", r"\end{table}"]
    return "\n".join(lines) + "\n"


def format_for_path(path: Path, default: str = "csv") -> str:
    """Table format from an output suffix: .csv, .md, .tex."""
    suffix = path.suffix.lower().lstrip(".")
    if suffix in FORMATS:
        return suffix
    if suffix == "markdown":
        return "md"
    if suffix == "latex":
        return "tex"
    raise ValueError(f"{path}: unknown table format {path.suffix or '(no suffix)'!r}; "
                     f"use .csv, .md or .tex")
