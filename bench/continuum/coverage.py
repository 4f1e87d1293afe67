#!/usr/bin/env python3
"""coverage.py [--exe BUILD/beadmob] [--budget S] [--bodies KEY,...] [--forms analytic,mesh] [--continuum TEXT]
[--keep DIR] [--reuse DIR] [--out FILE] [--list]: does the continuum job's error bar hold?

Twelve bodies with exact mobilities, each a continuum job on 2 ranks with `&continuum time_budget =
S /` (default 120 s; every other setting default: 7 levels x 2 offsets and 6 control samples, 4 plain offsets before 2026-11-28, 32 moment fills; a mesh none since 2026-11-29), in two
forms where beadmob has the analytic shape:

* analytic: `sphere` (radius 1) or `spheroid` (semi_axes a, b, c along x, y, z), smallest semi-axis
  1 in the shape's unit, bead_diameter 1/8 of it (the ordinary run of bench/continuum/continuum.py;
  the budget chooses the ladder among bead_diameter * 2^(j/3));
* mesh: the same body as a binary STL written here (an icosphere of 20480 triangles, 5 subdivisions
  of the icosahedron, stretched to the semi-axes, its vertices pushed out by a common factor,
  1.00018, so that the polyhedron's volume is the ellipsoid's: within 1.8e-4 of the surface in the
  sphere's frame), turned by a random rotation R and moved to a random centre c (x = R p + c;
  p the principal coordinates). R is the unit quaternion of 4 standard normals and c uniform in
  [-3, 3]^3, both from numpy's default_rng([seed, i]), i the body's place in the list below and the
  seed 44 unless --seed gives another (fixed, so a body keeps its placement whichever subset runs;
  another seed turns and moves every mesh anew); R and c are in each job's meta.json.

Bodies (`--bodies` keys): sphere; prolate spheroids 2:1, 4:1, 10:1 (semi-axes a:1:1) and oblate
1:2, 1:4, 1:10 (1:b:b); triaxial ellipsoids 3:2:1 and 2.7:1.6:1; two equal spheres of radius 1 at
gaps 0.1, 0.5 and 2 radii (line of centres along p_x, mesh only: beadmob has no analytic union),
bead_diameter 1/8.

Exact values, the diagonal of the mobility about the centre in the principal frame: the ellipsoid
from scripts/beadmob_post/ellipsoid.py (Oberbeck 1876, Jeffery 1922 via Carlson's integrals), all
six entries; the two spheres from scripts/beadmob_post/two_spheres.py, translation along the line of
centres (Stimson & Jeffery 1926) and rotation about it, the doublet turning as one rigid body
(Jeffery 1915's bispherical swirl), two entries (no closed form for the others).

The job's mobility (docs/output.md: about the body's centroid, in the input's axes) is turned to
the principal frame, Q^T M Q with Q = diag(R, R), and its diagonal compared with the exact one.
The error bar of a turned entry is the job's own estimator (docs/theory.md T18) applied to that
entry: each sample's e_i^T Q^T M_s Q e_i, the level means and standard errors, the weighted
quadratic, the model spread and the volume term as beadmob does them
(scripts/beadmob_post/continuum_bar.py; on every job it reproduces the file's own 36 bars and
diagonal values to `replay` below). For the analytic forms Q = 1 and the bar is the file's.
`held`: |value - exact| <= bar. `bar / error`: the bar over the true error |value - exact|
(the error bar's overestimate; below 1 a miss).

--continuum TEXT adds settings to every job's &continuum group (e.g. `turned_lattices = .true.`, for
the mesh form only: beadmob turns meshes only); they are in each job's meta.json.

--keep DIR (default bench/continuum/coverage_runs): each job runs in DIR/<key>-<form>/ and stays
there (job.nml, job.h5, job.log, body.stl, meta.json with the wall time, R and c); --reuse DIR
reads those instead of solving (the analysis rerun without a solve; bodies missing there are
reported missing). A job that fails is reported with its message and counts in no total.
The table goes to --out (default bench/continuum/coverage.md); a `## Reading` section already in
that file is kept below the regenerated part."""
import argparse
import datetime
import json
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from continuum_jobs import ROOT, JobFailed, run, spheroid

sys.path.insert(0, str(ROOT / "scripts"))
from beadmob_post.continuum_bar import entry_power, principal_diagonal, read_samples, replay_discrepancy  # noqa: E402
from beadmob_post.ellipsoid import ellipsoid_friction  # noqa: E402
from beadmob_post.two_spheres import doublet_mobility  # noqa: E402

SEED = 44
SUBDIVISIONS = 5
ENTRIES = ("t1", "t2", "t3", "r1", "r2", "r3")
FORMS = ("analytic", "mesh")


@dataclass(frozen=True)
class Body:
    key: str
    label: str
    semi_axes: tuple = None     # an ellipsoid
    gap: float = None           # two spheres of radius 1, gap in radii

    @property
    def forms(self):
        return FORMS if self.semi_axes is not None else ("mesh",)

    @property
    def bead_diameter(self):
        return (min(self.semi_axes) if self.semi_axes is not None else 1.0) / 8

    def exact(self):
        """The principal diagonal of the exact mobility about the centre (NaN: no exact value)."""
        if self.semi_axes is not None:
            return np.diag(np.linalg.inv(ellipsoid_friction(self.semi_axes)))
        translation, rotation = doublet_mobility(2.0 + self.gap, 1.0)
        return np.array([translation, np.nan, np.nan, rotation, np.nan, np.nan])


BODIES = [Body("sphere", "sphere", (1, 1, 1)),
          Body("prolate2", "prolate 2:1", (2, 1, 1)), Body("prolate4", "prolate 4:1", (4, 1, 1)),
          Body("prolate10", "prolate 10:1", (10, 1, 1)),
          Body("oblate2", "oblate 1:2", (1, 2, 2)), Body("oblate4", "oblate 1:4", (1, 4, 4)),
          Body("oblate10", "oblate 1:10", (1, 10, 10)),
          Body("tri321", "triaxial 3:2:1", (3, 2, 1)), Body("tri2.7", "triaxial 2.7:1.6:1", (2.7, 1.6, 1)),
          Body("pair0.1", "two spheres, gap 0.1 a", gap=0.1), Body("pair0.5", "two spheres, gap 0.5 a", gap=0.5),
          Body("pair2", "two spheres, gap 2 a", gap=2.0)]


# ---- meshes ---------------------------------------------------------------------------------------

def icosphere(subdivisions):
    """Vertices on the unit sphere and outward (counter-clockwise) triangles of the subdivided icosahedron."""
    t = (1 + 5**0.5) / 2
    vertices = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                         [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=float)
    faces = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
                      [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
                      [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    vertices /= np.linalg.norm(vertices, axis=1)[:, None]
    for _ in range(subdivisions):
        edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
        unique, index = np.unique(edges, axis=0, return_inverse=True)
        middle = vertices[unique].mean(axis=1)
        middle /= np.linalg.norm(middle, axis=1)[:, None]
        m = len(vertices) + index.reshape(3, -1)          # midpoints of edges 01, 12, 20 of each face
        a, b, c = faces.T
        faces = np.concatenate([np.stack([a, m[0], m[2]], 1), np.stack([b, m[1], m[0]], 1),
                                np.stack([c, m[2], m[1]], 1), np.stack([m[0], m[1], m[2]], 1)])
        vertices = np.concatenate([vertices, middle])
    return vertices, faces


def unit_sphere_mesh():
    """Triangles (F, 3, 3) of the icosphere scaled so that its volume is 4 pi / 3, and its largest
    distance from the unit sphere (over the vertices and the triangles' centroids)."""
    vertices, faces = icosphere(SUBDIVISIONS)
    triangles = vertices[faces]
    volume = np.sum(np.einsum("ij,ij->i", triangles[:, 0], np.cross(triangles[:, 1], triangles[:, 2]))) / 6
    triangles = triangles * (4 * np.pi / 3 / volume) ** (1 / 3)
    radii = np.concatenate([np.linalg.norm(triangles[:, 0], axis=1), np.linalg.norm(triangles.mean(axis=1), axis=1)])
    return triangles, float(np.max(np.abs(radii - 1)))


def placement(index, seed=SEED):
    """(R, c): a random rotation (columns: the principal axes in the input frame) and centre."""
    rng = np.random.default_rng([seed, index])
    w, x, y, z = (q := rng.standard_normal(4)) / np.linalg.norm(q)
    rotation = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                         [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                         [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    return rotation, rng.uniform(-3.0, 3.0, 3)


def body_triangles(body, rotation, centre):
    sphere, deviation = unit_sphere_mesh()
    if body.semi_axes is not None:
        principal = sphere * np.asarray(body.semi_axes, dtype=float)
    else:
        shift = np.array([1.0 + body.gap / 2, 0.0, 0.0])
        principal = np.concatenate([sphere - shift, sphere + shift])
    return principal @ rotation.T + centre, deviation


def write_stl(path, triangles):
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    record = np.dtype([("normal", "<f4", 3), ("vertices", "<f4", (3, 3)), ("attribute", "<u2")])
    data = np.zeros(len(triangles), dtype=record)
    data["normal"], data["vertices"] = normals, triangles
    with open(path, "wb") as f:
        f.write(b"beadmob bench/continuum/coverage.py".ljust(80, b" "))
        f.write(np.uint32(len(triangles)).tobytes())
        f.write(data.tobytes())


# ---- jobs -----------------------------------------------------------------------------------------

def build_version(exe):
    """`beadmob --version`: the commit the build was made from (-dirty: with uncommitted changes)."""
    return subprocess.run([str(exe), "--version"], capture_output=True, text=True).stdout.strip()


def solve(exe, body, index, form, budget, folder, extra="", seed=SEED):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "meta.json").unlink(missing_ok=True)
    rotation, centre = np.eye(3), np.zeros(3)
    meta = {"body": body.key, "form": form, "budget": budget, "seed": seed, "exe": str(exe), "source": build_version(exe),
            "date": datetime.date.today().isoformat(), "continuum": extra}
    if form == "analytic":
        if body.semi_axes == (1, 1, 1):
            shape = f"&shape name = 'sphere', radius = 1, bead_diameter = {body.bead_diameter:g} /\n&hydrodynamics /\n"
        else:
            shape = spheroid(body.semi_axes, body.bead_diameter)
    else:
        rotation, centre = placement(index, seed)
        triangles, deviation = body_triangles(body, rotation, centre)
        write_stl(folder / "body.stl", triangles)
        meta.update(triangles=len(triangles), mesh_deviation=deviation)
        shape = f"&shape name = 'mesh', file = 'body.stl', bead_diameter = {body.bead_diameter:g} /\n&hydrodynamics /\n"
    meta.update(rotation=rotation.tolist(), centre=centre.tolist())
    try:
        # -keep_checkpoint: the samples stay, so a later build's estimate reruns them in seconds.
        _, wall = run(exe, shape + f"&continuum time_budget = {budget:g}{', ' + extra if extra else ''} /\n", folder,
                      fatal=False,
                      options=("-keep_checkpoint",))
        meta["wall"] = wall
        meta.update(solve_record(folder / "job.h5"))
    except JobFailed as failure:
        lines = [line.strip() for line in str(failure).splitlines() if line.strip() and not line.startswith("---")]
        meta["failed"] = next((line for line in lines if "error" in line.lower()), lines[-1] if lines else "?")
    (folder / "meta.json").write_text(json.dumps(meta, indent=1))
    return meta


def solve_record(path):
    """What a freshly solved job's file says about its ladder and samples (kept in meta.json, since a
    refit rewrites the file: its estimate is then the uncalibrated one of the kept ladder)."""
    with h5py.File(path) as f:
        c = f["continuum"]
        return {"estimated": float(c.attrs["estimated_seconds"]),
                "calibration": float(c.attrs.get("estimate_calibration", np.nan)),
                "sample_seconds": float(np.sum(c["sample_seconds"][()])), "result_git_hash": f.attrs["git_hash"].decode()}


def refit(exe, folder):
    """The kept job's extrapolation redone by this build from its checkpoint (every sample is in it:
    no solve): the same input with -keep_checkpoint. The solve's wall time and build stay in
    meta.json; the refit's are added."""
    meta_path = folder / "meta.json"
    if not meta_path.exists() or not (folder / "job.h5.continuum_checkpoint").exists():
        return None
    meta = json.loads(meta_path.read_text())
    if "estimated" not in meta and (folder / "job.h5").exists():
        meta.update(solve_record(folder / "job.h5"))
    text = (folder / "job.nml").read_text().split("\n", 1)[1]      # without the &run line run() writes
    if (folder / "job.log").exists() and not (folder / "solve.log").exists():
        (folder / "job.log").rename(folder / "solve.log")           # what the solve printed stays
    try:
        _, wall = run(exe, text, folder, fatal=False, options=("-keep_checkpoint",), fresh=False)
    except JobFailed as failure:
        sys.exit(f"refit of {folder} failed:\n{failure}")
    if "resuming" not in (folder / "job.log").read_text():
        # not resumed (a mesh's checkpoint is keyed by the mesh file's absolute path: a moved folder
        # starts over): the job solved its samples again, so it is the solve now
        print(f"warning: {folder}: the checkpoint was not resumed; solved again", flush=True)
        meta.update(wall=wall, source=build_version(exe), date=datetime.date.today().isoformat(),
                    resolved_by_refit=True, **solve_record(folder / "job.h5"))
        meta.pop("estimated_from", None)
    meta.update(refit_source=build_version(exe), refit_wall=wall, refit_date=datetime.date.today().isoformat())
    meta_path.write_text(json.dumps(meta, indent=1))
    return meta


def analyse(body, form, folder):
    """A row: the job's ladder and time, and per principal diagonal entry (exact, value, bar)."""
    meta_path = folder / "meta.json"
    if not meta_path.exists():
        return {"body": body, "form": form, "missing": True}
    meta = json.loads(meta_path.read_text())
    row = {"body": body, "form": form, "meta": meta}
    if "failed" in meta:
        return row
    path = folder / "job.h5"
    rotation = np.array(meta["rotation"])
    samples = read_samples(path)
    with h5py.File(path) as f:
        c = f["continuum"]
        chosen_by = c.attrs.get("ladder_chosen_by", b"time_budget").decode()
        levels, beads = np.asarray(c.attrs["sample_level"]), np.asarray(c.attrs["sample_beads"])
        row.update(diameters=c["bead_diameters"][()], beads=int(np.max(beads)), coarsest=int(np.min(beads[levels == 1])),
                   estimated=meta.get("estimated", float(c.attrs["estimated_seconds"]) if chosen_by != "checkpoint"
                                      else np.nan),
                   converged=int(c.attrs["all_converged"]), git_hash=f.attrs["git_hash"].decode(), chosen_by=chosen_by,
                   sample_seconds=float(np.sum(c["sample_seconds"][()])))
    q = np.zeros((6, 6))
    q[:3, :3] = q[3:, 3:] = rotation
    turned = q.T @ samples.mobility @ q
    replayed = principal_diagonal(samples, rotation)
    exact = body.exact()
    row["replay"] = replay_discrepancy(samples)
    # the replayed value against the turned file value, on the scale of the bar
    row["value_shift"] = max(abs(v - turned[i, i]) / bar for i, (v, bar, _) in enumerate(replayed))
    # alternatives: the file's bars carried through Q entry by entry (|Q|^T E |Q|), and the job's own
    # input-frame diagonal against the exact mobility turned into that frame (ellipsoids)
    linear = np.diag(np.abs(q).T @ samples.mobility_error @ np.abs(q))
    row["entries"] = []
    for i in range(6):
        if np.isnan(exact[i]):
            continue
        value, bar, fit = turned[i, i], replayed[i][1], replayed[i][2]
        row["entries"].append(dict(name=ENTRIES[i], exact=exact[i], value=value, bar=bar, linear_bar=linear[i],
                                   error=value - exact[i], spread=fit.model_spread, sigma=fit.standard_error,
                                   chi2=fit.plain_reduced_chi2,
                                   volume_term=bar - fit.fit_error, power=entry_power(i, i)))
    if body.semi_axes is not None:
        exact_input = q @ np.diag(exact) @ q.T
        row["input_frame"] = [abs(samples.mobility[i, i] - exact_input[i, i]) <= samples.mobility_error[i, i]
                              for i in range(6)]
    return row


# ---- the table ------------------------------------------------------------------------------------

def percent(x):
    return f"{100 * x:.3f}"


def ratio_text(bar, error):
    return "inf" if error == 0 else f"{bar / abs(error):.2f}"


def tables(rows):
    lines = ["| body | form | bead diameters | beads (coarsest - finest) | held | median bar / error | worst error % (its bar %) | "
             "wall (s) | estimated (s) | samples (s) | result file |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    entry_lines = ["| body | form | " + " | ".join(ENTRIES) + " |", "|---|---|" + "---|" * 6]
    for row in rows:
        body, form = row["body"], row["form"]
        head = f"| {body.label} | {form} |"
        if row.get("missing"):
            lines.append(head + " not run | | | | | | | | |")
            continue
        if "failed" in row["meta"]:
            lines.append(head + f" failed: {row['meta']['failed']} | | | | | | | | |")
            continue
        entries = row["entries"]
        held = sum(abs(e["error"]) <= e["bar"] for e in entries)
        ratios = [e["bar"] / abs(e["error"]) if e["error"] else np.inf for e in entries]
        worst = max(entries, key=lambda e: abs(e["error"]) / e["exact"])
        d = row["diameters"]
        lines.append(f"{head} {d[0]:.4f} - {d[-1]:.4f} | {row['coarsest']} - {row['beads']} | {held} / {len(entries)} | "
                     f"{np.median(ratios):.2f} | {worst['name']} {percent(worst['error'] / worst['exact'])} "
                     f"({percent(worst['bar'] / worst['exact'])}) | {row['meta']['wall']:.0f} | {row['estimated']:.0f}"
                     + (f" (x{row['meta']['calibration']:.1f})" if "calibration" in row["meta"] else "") + f" | "
                     f"{row['sample_seconds']:.0f} | {row['git_hash'][:7]}, "
                     f"{'re-extrapolated' if row['chosen_by'] == 'checkpoint' else 'solved'} |")
        cells = {e["name"]: (f"{percent(e['error'] / e['exact'])} / {percent(e['bar'] / e['exact'])}"
                             + ("" if abs(e["error"]) <= e["bar"] else " **miss**")) for e in entries}
        entry_lines.append(head + " " + " | ".join(cells.get(name, "-") for name in ENTRIES) + " |")
    return "\n".join(lines), "\n".join(entry_lines)


def coverage(entries):
    if not entries:
        return "none"
    held = sum(abs(e["error"]) <= e["bar"] for e in entries)
    ratios = [e["bar"] / abs(e["error"]) if e["error"] else np.inf for e in entries]
    return (f"{held} / {len(entries)} = {100 * held / len(entries):.1f} % inside, median bar / error "
            f"{np.median(ratios):.2f}")


PARTS = (lambda e: 2 * e["sigma"], lambda e: e["spread"], lambda e: e["volume_term"])


def summary(rows):
    done = [row for row in rows if "entries" in row]
    every = [e | {"row": row} for row in done for e in row["entries"]]
    out = ["| entries | coverage (target >= 95 %), median bar / error (target <= 4) |", "|---|---|"]
    groups = [("all", every),
              ("analytic forms", [e for e in every if e["row"]["form"] == "analytic"]),
              ("mesh forms", [e for e in every if e["row"]["form"] == "mesh"]),
              ("ellipsoids, translation", [e for e in every if e["row"]["body"].semi_axes and e["power"] == 1]),
              ("ellipsoids, rotation", [e for e in every if e["row"]["body"].semi_axes and e["power"] == 3]),
              ("two spheres", [e for e in every if e["row"]["body"].gap is not None])]
    out += [f"| {name} | {coverage(group)} |" for name, group in groups]
    text = "\n".join(out)
    if not every:
        return text
    worst = max(every, key=lambda e: abs(e["error"]) / e["exact"])
    misses = sorted((e for e in every if abs(e["error"]) > e["bar"]), key=lambda e: e["bar"] / abs(e["error"]))
    failed = [row for row in rows if "meta" in row and "failed" in row["meta"]]
    missing = [row for row in rows if row.get("missing")]
    wall = sum(row["meta"]["wall"] for row in done)
    text += (f"\n\nWorst error: {percent(abs(worst['error']) / worst['exact'])} % ({worst['row']['body'].label}, "
             f"{worst['row']['form']}, {worst['name']}; its bar {percent(worst['bar'] / worst['exact'])} %). "
             f"Wall time of the {len(done)} jobs: {wall:.0f} s ({wall / 60:.1f} min; {wall / max(len(done), 1):.0f} s "
             f"per job).")
    if misses:
        text += "\n\nMisses (error % against bar %, the bar's parts: 2 sigma, model spread, volume term):\n\n"
        text += "\n".join(f"- {e['row']['body'].label}, {e['row']['form']}, {e['name']}: error "
                          f"{percent(e['error'] / e['exact'])} %, bar {percent(e['bar'] / e['exact'])} % "
                          f"(bar / error {e['bar'] / abs(e['error']):.2f}; 2 sigma {percent(2 * e['sigma'] / e['exact'])}, "
                          f"spread {percent(e['spread'] / e['exact'])}, volume {percent(e['volume_term'] / e['exact'])})"
                          for e in misses)
    closest = sorted((e for e in every if abs(e["error"]) <= e["bar"]), key=lambda e: e["bar"] / abs(e["error"]))[:8]
    if closest:
        text += ("\n\nClosest to a miss (bar / error; the bar's parts 2 sigma, spread, volume term as % of the exact value): "
                 + "; ".join(f"{e['row']['body'].label} {e['row']['form']} {e['name']} {e['bar'] / abs(e['error']):.2f} "
                             f"(error {percent(e['error'] / e['exact'])} %, bar {percent(e['bar'] / e['exact'])} %: "
                             f"{percent(2 * e['sigma'] / e['exact'])}, {percent(e['spread'] / e['exact'])}, "
                             f"{percent(e['volume_term'] / e['exact'])})" for e in closest)
                 + f". Entries with bar / error below 1.5: {sum(e['bar'] < 1.5 * abs(e['error']) for e in every)}; below 2: "
                 f"{sum(e['bar'] < 2 * abs(e['error']) for e in every)}.")
    if failed or missing:
        text += "\n\nNot in the totals: " + "; ".join(
            f"{row['body'].label} ({row['form']}) {'failed: ' + row['meta']['failed'] if 'meta' in row else 'not run'}"
            for row in failed + missing) + "."
    text += "\n\nThe bar's parts (medians over the entries of each group, as fractions of the bar), and what each part alone " \
            "would cover (entries inside / median part / error):\n\n| entries | 2 sigma | model spread | volume term | " \
            "2 sigma alone | spread alone |\n|---|---|---|---|---|---|\n"
    for name, group in groups:
        if not group:
            continue
        parts = [np.median([part(e) / e["bar"] for e in group]) for part in PARTS]
        alone = []
        for part in PARTS[:2]:
            inside = sum(abs(e["error"]) <= part(e) for e in group)
            alone.append(f"{inside} / {len(group)}, {np.median([part(e) / abs(e['error']) for e in group]):.2f}")
        text += f"| {name} | " + " | ".join(f"{100 * x:.0f} %" for x in parts) + " | " + " | ".join(alone) + " |\n"
    summed = sum(abs(e["error"]) <= sum(part(e) for part in PARTS) for e in every)
    text += (f"\nWith the parts added instead (2 sigma + spread + volume term, the bar before 241d8d3): {summed} / "
             f"{len(every)} inside, median bar / error "
             f"{np.median([sum(part(e) for part in PARTS) / abs(e['error']) for e in every]):.2f}.\n")
    text += ("\nThe true error in units of the fit's sigma, |error| / sigma (a normal error would give a median of "
             "0.67), and the quadratic's reduced chi^2 over the levels with weights 1 / s_k^2 alone (1 when the level "
             "means scatter as their standard errors from the offsets say; above 1 the fit adds the excess tau^2), "
             "medians: "
             + "; ".join(f"{name} {np.median([abs(e['error']) / e['sigma'] for e in group]):.2f} and "
                         f"{np.median([e['chi2'] for e in group]):.2f}" for name, group in groups if group) + ".")
    linear = sum(abs(e["error"]) <= e["linear_bar"] for e in every)
    turned = [e for e in every if e["row"]["form"] == "mesh"]
    linear_ratio = np.median([e["linear_bar"] / abs(e["error"]) for e in turned]) if turned else np.nan
    input_frame = [held for row in done if row["form"] == "mesh" and "input_frame" in row for held in row["input_frame"]]
    text += ("\n\nChecks and other readings of the turned bodies' bars: the replayed estimator gives every job's own 36 "
             f"bars and 6 diagonal values within {max(row['replay'] for row in done):.1e} (relative); the replayed "
             f"values differ from the turned file values by at most {max(row['value_shift'] for row in done):.3f} of "
             f"the bar. With the file's bars carried through Q entry by entry (|Q|^T E |Q|, an upper bound if the "
             f"entries' errors were independent worst cases) instead of the replay: {linear} / {len(every)} inside, "
             f"the mesh forms' median bar / error {linear_ratio:.2f}. The mesh ellipsoids' own input-frame diagonal "
             f"against the exact mobility turned into the input frame: {sum(input_frame)} / {len(input_frame)} inside.")
    return text


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--budget", type=float, default=120.0)
    parser.add_argument("--continuum", default="", help="settings added to every job's &continuum group")
    parser.add_argument("--bodies", default=",".join(body.key for body in BODIES))
    parser.add_argument("--forms", default=",".join(FORMS))
    parser.add_argument("--keep", default=str(Path(__file__).with_name("coverage_runs")))
    parser.add_argument("--reuse", default=None, help="analyse the jobs kept in this folder, solve nothing")
    parser.add_argument("--refit", action="store_true",
                        help="with --reuse: first redo each kept job's extrapolation with --exe from its checkpoint")
    parser.add_argument("--out", default=str(Path(__file__).with_name("coverage.md")))
    parser.add_argument("--list", action="store_true", help="print the bodies and their placements and stop")
    parser.add_argument("--seed", type=int, default=SEED,
                        help=f"the meshes' random placements (default {SEED}; another seed: bodies turned anew)")
    arguments = parser.parse_args()
    keys = arguments.bodies.split(",")
    forms = arguments.forms.split(",")
    unknown = [k for k in keys if k not in {b.key for b in BODIES}] + [f for f in forms if f not in FORMS]
    if unknown:
        parser.error(f"unknown bodies or forms: {', '.join(unknown)} (bodies: {', '.join(b.key for b in BODIES)})")
    selected = [(i, body, form) for form in forms for i, body in enumerate(BODIES) if body.key in keys and form in body.forms]
    if arguments.list:
        for i, body, form in selected:
            rotation, centre = placement(i, arguments.seed)
            print(body.key, form, body.label, "exact", body.exact(), "centre", centre if form == "mesh" else "-")
        return
    keep = Path(arguments.reuse or arguments.keep).resolve()
    rows = []
    for i, body, form in selected:
        folder = keep / f"{body.key}-{form}"
        if arguments.reuse and arguments.refit:
            meta = refit(Path(arguments.exe).resolve(), folder)
            print(f"{body.key} {form}: " + ("no checkpoint kept" if meta is None else f"refit in {meta['refit_wall']:.0f} s"),
                  flush=True)
        if not arguments.reuse:
            meta = solve(Path(arguments.exe).resolve(), body, i, form, arguments.budget, folder, arguments.continuum,
                         arguments.seed)
            print(f"{body.key} {form}: " + (f"failed: {meta['failed']}" if "failed" in meta else f"{meta['wall']:.0f} s"),
                  flush=True)
        rows.append(analyse(body, form, folder))
    body_table, entry_table = tables(rows)
    metas = [row["meta"] for row in rows if "meta" in row]
    budgets = sorted({m["budget"] for m in metas})
    command = " ".join(["bench/continuum/coverage.py", *(shlex.quote(a) for a in sys.argv[1:])])
    dates = sorted({m["date"] for m in metas})
    sources = sorted({m["source"] for m in metas})
    refits = sorted({m["refit_source"] for m in metas if "refit_source" in m})
    paragraphs = __doc__.split("\n\n")
    text = (f"# Coverage of the continuum job's error bar\n\n"
            f"Written by `{command}` (2 ranks, this machine; jobs solved {', '.join(dates)} with the build of "
            f"{', '.join(sources)}; budgets {', '.join(f'{b:g}' for b in budgets)} s"
            + "".join(sorted({f"; &continuum {m['continuum']}" for m in metas if m.get("continuum")}))
            + (f"; the extrapolations redone from the jobs' checkpoints (no solve) by the build of {', '.join(refits)}"
               if refits else "")
            + ").\n\n"
            + "\n\n".join(paragraphs[1:6]) + "\n\n## Summary\n\n" + summary(rows)
            + "\n\n## Per body\n\n`held`: the principal diagonal entries with an exact value inside the bar; "
              "`beads`: the fewest of the coarsest level's samples and the most of the finest's (below 200 on the coarsest: "
              "the cheapest ladder the job allows, whose coarsest level must hold 100); `worst error`: the largest "
              "|value / exact - 1| with its bar; `wall`: the solving job's whole process; `estimated`: "
              "its estimate of its ladder (the dry run's, calibrated by the pilot, whose factor is in brackets: what the "
              "budget was held against); "
              "`samples`: the solve time of the samples in the file; `result file`: the build that wrote it, and whether "
              "it solved the samples or re-extrapolated kept ones (-keep_checkpoint).\n\n" + body_table
            + "\n\n## Per entry\n\nerror % / bar %, both relative to the exact value (t1 t2 t3: translation along the "
              "principal axes a, b, c, the two spheres' line of centres first; r1 r2 r3: rotation about them).\n\n"
            + entry_table + "\n")
    out = Path(arguments.out)
    if out.exists() and "\n## Reading" in out.read_text():
        text += "\n## Reading" + out.read_text().split("\n## Reading", 1)[1]
    out.write_text(text)
    print(f"written {out}")


if __name__ == "__main__":
    main()
