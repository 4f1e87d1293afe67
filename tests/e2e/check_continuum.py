#!/usr/bin/env python3
"""check_continuum.py BEADMOB MPIEXEC RANKS WORKDIR: the continuum job (&continuum;
src/driver/continuum_job.f90, docs/theory.md T18), end to end.

1. A sphere of radius 1 (bead_diameter 0.25, four levels down to d = 0.16, two offsets each):
   the continuum translational and rotational mobility must hold the exact sphere's
   (Stokes: 1 / (6 pi a), 1 / (8 pi a^3)) within the job's own error bar; the ladder's bead
   diameters are a factor 2**(1/3) apart; every sample is kept (levels x offsets), every solve
   converged; the coefficients' length L is the sphere's diameter and mu11 = mu22 = mu33 hold
   Stokes' 1/3 within their bars; the continuum friction is the inverse of the continuum mobility; the volume from the
   moment fills is 4 pi / 3 within its standard error (4x); the continuum coefficients are numpy's
   weighted quadratic fit of the level means (beadmob_post.continuum.quadratic_fit), and their
   recorded excess scatter tau is scipy's root of the random-effects condition (level_excess).
2. Stopped after three samples (-stop_after_solves 3, deterministic: a kill would race the job):
   no result file, a checkpoint of exactly three samples; the rerun says it resumes with them and gives the uninterrupted run's continuum values
   within 1e-3 of their error bars (the resumed samples are read back to the last bit, the others
   solved again to the Krylov tolerance), and leaves no checkpoint.
3. A checkpoint of another input is not used ("starting over"; seen by a dry run).
4. Refused with a message and a non-zero exit: a bead file (not a filled shape), no bead_diameter,
   levels = 2, lattice_offset given, an accuracy target, a time budget no ladder fits, a
   finest_bead_diameter whose coarsest level would hold fewer than 100 beads, turned_lattices for
   an analytic shape (beadmob turns meshes only).
5. --estimate prints the ladder and writes nothing; the samples per level left out resolve to 2
   offsets and 6 control samples at order 2, to 4 plain offsets at order 1; it names the rest of
   the budget fill_budget spends (not with fill_budget = .false.). A run that buys 40 samples
   (-fill_samples 40, whatever the time): they are control samples on offsets of their own, levels
   unequal, the level means numpy's, the sphere within its bar of Stokes; started from its ladder's
   samples (its kept checkpoint, cut), stopped in the fill and resumed, it fills on from the
   checkpoint to the same 40.
6. A small cone's continuum coefficients are in the paper's frame (mu11 = mu22, mu33 > mu11,
   mu42 > 0 > mu51): the frame comes from the lattice without offset, which keeps the mirror planes.
7. Control samples (control_offsets = 3 beside offsets = 2, T18): the sphere again within its bar
   against Stokes; per level 2 samples solved at L = 2 and 3 control samples at L = 1 (their
   order-L values NaN, their controls finite and solved to 5e-3, fewer Krylov iterations per
   sample); each level's mean is numpy's mean of y - x over the full samples plus the mean of x
   over all five; stopped
   after three samples (the third a control sample) and resumed, the same values within 1e-3 of
   the bars. A flow job with control samples: the sphere's stresslet within its bar, its level means
   controlled alike. Refused: control_offsets with multipole_order = 1, below 0.
8. A budget's ladder checked by its levels: with -slow_samples 30 (the samples after the pilot
   count 30 times their time, a machine slowed down after the pilot) a 3-level ladder moves
   coarser once a level shows the rest would overrun; the result records the move, its ladder is
   the one before it shifted by whole levels (bead diameters times 2**(s/3)), every level holds
   its 2 full and 6 control samples on its own bead diameter, and the sphere is within its bar of
   Stokes. A level the budget runs out on keeps the samples it has.
9. The budget spent within a level: with -slow_samples 10000 no control sample fits once a level's
   full samples are solved; every level keeps its 2 full samples alone, the job says so per level
   and finishes, each level's mean the plain mean of its two samples. (The sphere's bar is not
   checked here: with two samples per level and three levels it missed Stokes by up to 1.08 of the
   bar in two of six entries when this test was written; the bar's coverage is the benches'.)"""
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts"))
from beadmob_post.continuum import level_excess, load_continuum, quadratic_fit  # noqa: E402
from beadmob_post.continuum_bar import moment_control_shift, moment_features  # noqa: E402
from checklist import check, failures  # noqa: E402

SPHERE = "&shape name = 'sphere', radius = 1.0, bead_diameter = 0.25 /\n&hydrodynamics /\n"
# Plain samples (control samples, the default, are section 7's).
LADDER = "&continuum levels = 4, offsets = 2, control_offsets = 0, finest_bead_diameter = 0.16 /\n"


def write_input(workdir, name, output, body):
    path = Path(workdir) / name
    path.write_text(f"&run output = '{output}' /\n" + body)
    return path


def run(beadmob, mpiexec, ranks, workdir, nml, *options):
    start = time.perf_counter()
    done = subprocess.run([mpiexec, "-n", str(ranks), beadmob, str(nml), *options], cwd=workdir,
                          capture_output=True, text=True)
    # Where the test's time goes (CTest's log), not checked.
    print(f"ran {Path(nml).name} {' '.join(options)}: {time.perf_counter() - start:.1f} s", flush=True)
    return done


def continuum(path):
    with h5py.File(path, "r") as f:
        c = f["continuum"]
        return {name: c[name][()] for name in c} | dict(c.attrs)


def main(beadmob, mpiexec, ranks, workdir):
    os.makedirs(workdir, exist_ok=True)
    # 1. The sphere against Stokes.
    nml = write_input(workdir, "sphere.nml", "sphere.h5", SPHERE + LADDER)
    done = run(beadmob, mpiexec, ranks, workdir, nml)
    if done.returncode != 0:
        sys.exit(f"the continuum job failed:\n{done.stdout}\n{done.stderr}")
    c = continuum(Path(workdir) / "sphere.h5")
    exact = np.array([1 / (6 * math.pi)] * 3 + [1 / (8 * math.pi)] * 3)
    deviation = np.abs(np.diag(c["mobility"]) - exact)
    check(np.all(deviation <= np.diag(c["mobility_error"])),
          f"sphere: |continuum - Stokes| {deviation / exact} within the error bar {np.diag(c['mobility_error']) / exact}")
    # The coefficients' length is the body's, 2 a (not a bead model's outer size, up to d more), so
    # mu11 = pi eta L mu_tt (paper, eq. "matrices") is Stokes' pi 2 a / (6 pi a) = 1/3 exactly.
    check(c["reference_length"] == 2.0 and c["reference_length_from"].decode() == "body",
          f"L is the sphere's diameter 2 ({c['reference_length']}, from {c['reference_length_from']})")
    check(np.all(np.abs(c["coefficients"][:3] - 1 / 3) <= c["coefficient_error"][:3]),
          f"sphere: mu11 mu22 mu33 {c['coefficients'][:3]} hold Stokes' 1/3 within {c['coefficient_error'][:3]}")
    check(np.all(np.diag(c["mobility_error"]) / exact < [0.05] * 3 + [0.15] * 3),
          "sphere: the error bar is of the ladder's size (< 5 % translation, 15 % rotation at d >= 0.16)")
    ratios = c["bead_diameters"][:-1] / c["bead_diameters"][1:]
    check(np.allclose(ratios, 2 ** (1 / 3), rtol=1e-12) and abs(c["bead_diameters"][-1] - 0.16) < 1e-15,
          f"ladder: bead diameters {c['bead_diameters']} a factor 2**(1/3) apart down to 0.16")
    check(len(c["sample_level"]) == 8 and sorted(c["sample_level"]) == [1, 1, 2, 2, 3, 3, 4, 4],
          f"every sample kept: levels {c['sample_level']}")
    check(c["all_converged"] == 1 and np.all(c["sample_converged"] == 1), "every solve converged")
    check(c["multipole_order"] == 2 and np.all(c["sample_friction_symmetry_error"] < 1e-6)
          and np.all(c["sample_true_relative_residual"] < 1e-2),
          f"recorded: L = {c['multipole_order']}, friction symmetry errors <= "
          f"{c['sample_friction_symmetry_error'].max():.1e}, true residuals <= {c['sample_true_relative_residual'].max():.1e}")
    check(np.allclose(c["friction"] @ c["mobility"], np.eye(6), atol=1e-10), "continuum friction = mobility^-1")
    with h5py.File(Path(workdir) / "sphere.h5", "r") as f:
        echoed = f["input/effective_namelist"][()]
    echoed = echoed.decode() if isinstance(echoed, bytes) else str(echoed)
    check("control_offsets = 0" in echoed and "offsets = 2" in echoed,
          "the plain job's effective input says control_offsets = 0 (left out, control samples would be used)")
    check(abs(c["volume"] - 4 * math.pi / 3) <= 4 * c["volume_standard_error"],
          f"volume {c['volume']} = 4 pi / 3 within 4 standard errors ({c['volume_standard_error']})")
    check(not (Path(workdir) / "sphere.h5.continuum_checkpoint").exists(), "no checkpoint left after a finished job")
    # beadmob's extrapolation (normal equations) against numpy's least squares on the same levels.
    levels = load_continuum(Path(workdir) / "sphere.h5")
    refit = np.array([quadratic_fit(levels.bead_diameters, levels.level_coefficients[:, k],
                                    levels.level_coefficient_error[:, k])[0] for k in range(5)])
    check(np.allclose(refit, levels.coefficients, rtol=1e-8, atol=1e-10 * np.abs(refit).max()),
          f"the continuum coefficients are numpy's quadratic fit of the level means ({refit} vs {levels.coefficients})")
    excess = np.array([level_excess(levels.bead_diameters, levels.level_coefficients[:, k],
                                    levels.level_coefficient_error[:, k]) for k in range(5)])
    check(np.allclose(excess, c["coefficient_level_excess"], rtol=1e-6, atol=1e-12 * np.abs(refit).max()),
          f"the levels' excess scatter (tau) is scipy's root of chi^2 = K - 3 ({excess} vs {c['coefficient_level_excess']})")

    # The coefficients' frame: a small cone (axis z, mirror planes x and y on the lattice without
    # offset, none on the shifted ones) must keep the paper's pattern: mu11 = mu22 (axisymmetric)
    # within the bars, mu33 > mu11 (broadside is slower than along the axis: paper, tab_mob_num),
    # mu42 > 0 > mu51.
    nml = write_input(workdir, "cone.nml", "cone.h5", "&shape name = 'cone', base_diameter = 2.0, height = 4.7, "
                      "bead_diameter = 0.2, reference_length = 2.1 /\n&hydrodynamics /\n"
                      "&continuum levels = 3, offsets = 2, finest_bead_diameter = 0.2 /\n")
    done = run(beadmob, mpiexec, ranks, workdir, nml)
    if done.returncode != 0:
        sys.exit(f"the cone's continuum job failed:\n{done.stdout}\n{done.stderr}")
    cone = continuum(Path(workdir) / "cone.h5")
    mu, bar = cone["coefficients"], cone["coefficient_error"]
    check(abs(mu[0] - mu[1]) <= bar[0] + bar[1] and mu[2] > mu[0] and mu[3] > 0 > mu[4],
          f"cone: the paper's frame and pattern (mu {mu}, +- {bar})")
    check(cone["reference_length"] == 2.1 and cone["reference_length_from"].decode() == "input",
          f"cone: L is the input's reference_length 2.1 ({cone['reference_length']}, {cone['reference_length_from']})")

    # 2. Stopped after three samples (-stop_after_solves counts a continuum job's samples: a stop
    #    at a known point, where a kill would race the job), then resumed.
    nml = write_input(workdir, "killed.nml", "killed.h5", SPHERE + LADDER)
    checkpoint = Path(workdir) / "killed.h5.continuum_checkpoint"
    checkpoint.unlink(missing_ok=True)
    (Path(workdir) / "killed.h5").unlink(missing_ok=True)   # the result of an earlier run of this test
    done = run(beadmob, mpiexec, ranks, workdir, nml, "-stop_after_solves", "3")
    check(done.returncode != 0 and "stopped after 3 samples" in done.stderr + done.stdout,
          f"stopped after three samples: exit {done.returncode}, {(done.stderr.strip().splitlines() or [''])[-1]!r}")
    kept = len(checkpoint.read_text().splitlines()) - 1 if checkpoint.exists() else 0
    check(kept == 3 and not (Path(workdir) / "killed.h5").exists(),
          f"stopped: no result file, a whole checkpoint of {kept} samples (3 expected)")
    done = run(beadmob, mpiexec, ranks, workdir, nml)
    said = [line for line in done.stdout.splitlines() if "resuming" in line]
    check(done.returncode == 0 and "resuming with 3 samples" in done.stdout,
          f"the rerun resumes with the 3 samples: {said}")
    resumed = continuum(Path(workdir) / "killed.h5")
    for name, error in (("coefficients", "coefficient_error"), ("mobility", "mobility_error")):
        difference = np.abs(resumed[name] - c[name])
        check(np.all(difference <= 1e-3 * c[error]),
              f"resumed {name} = uninterrupted within 1e-3 of the error bar (largest {np.max(difference / c[error]):.1e})")
    check(not checkpoint.exists(), "the resumed job removes its checkpoint")
    # -keep_checkpoint: the finished job keeps it; the rerun solves nothing and gives the same values.
    done = run(beadmob, mpiexec, ranks, workdir, nml, "-keep_checkpoint")
    again = run(beadmob, mpiexec, ranks, workdir, nml, "-keep_checkpoint")
    rerun = continuum(Path(workdir) / "killed.h5")
    check(done.returncode == 0 and again.returncode == 0 and checkpoint.exists()
          and "resuming with 8 samples" in again.stdout and "beadmob: continuum level" not in again.stdout
          and np.all(np.abs(rerun["mobility"] - c["mobility"]) <= 1e-3 * c["mobility_error"]),
          "-keep_checkpoint: the checkpoint kept; the rerun extrapolates its 8 samples again without a solve")
    checkpoint.unlink(missing_ok=True)

    # 3. A checkpoint of another input.
    checkpoint.write_text(f"beadmob-continuum-checkpoint 1 0123456789ABCDEF 1.25E-01\n")
    done = run(beadmob, mpiexec, ranks, workdir, nml, "--estimate")
    check(done.returncode == 0 and "is of another input; starting over" in done.stdout and "1.6000E-01" in done.stdout
          and "1.2500E-01" not in done.stdout, "a checkpoint of another input is not used (nor its finest level, 0.125)")
    checkpoint.unlink(missing_ok=True)

    # 4. Refusals.
    (Path(workdir) / "two.txt").write_text("0 0 0\n1 0 0\n")
    refusals = [
        ("&shape name = 'bead_file', file = 'two.txt' /\n&hydrodynamics /\n" + LADDER, "needs a shape that fills"),
        ("&shape name = 'sphere', radius = 4 /\n&hydrodynamics /\n" + LADDER, "needs the shape in its own unit"),
        (SPHERE + "&continuum levels = 2 /\n", "levels must be 3 to 12"),
        ("&shape name = 'sphere', radius = 1.0, bead_diameter = 0.25, lattice_offset = 0.5, 0.5, 0.5 /\n"
         "&hydrodynamics /\n" + LADDER, "leave &shape lattice_offset out"),
        ("&shape name = 'sphere', radius = 1.0, bead_diameter = 0.25 /\n&hydrodynamics accuracy = 0.01 /\n" + LADDER,
         "accuracy target"),
        (SPHERE + "&continuum time_budget = 0.01 /\n", "fits the time budget"),
        (SPHERE + "&continuum levels = 4, finest_bead_diameter = 0.5 /\n", "levels of this body needs finest_bead_diameter <="),
        (SPHERE + "&continuum turned_lattices = .true. /\n", "for meshes only, not for shape 'sphere'"),
    ]
    for body, expected in refusals:
        nml = write_input(workdir, "refused.nml", "refused.h5", body)
        (Path(workdir) / "refused.h5").unlink(missing_ok=True)   # of an earlier run of this test
        done = run(beadmob, mpiexec, ranks, workdir, nml)
        check(done.returncode != 0 and expected in done.stderr + done.stdout and not (Path(workdir) / "refused.h5").exists(),
              f"refused ({expected!r}): exit {done.returncode}, {(done.stderr.strip().splitlines() or [''])[-1]!r}")

    # 7. Control samples.
    controlled_ladder = "&continuum levels = 4, offsets = 2, control_offsets = 3, finest_bead_diameter = 0.16 /\n"
    nml = write_input(workdir, "controlled.nml", "controlled.h5", SPHERE + controlled_ladder)
    done = run(beadmob, mpiexec, ranks, workdir, nml)
    if done.returncode != 0:
        sys.exit(f"the controlled continuum job failed:\n{done.stdout}\n{done.stderr}")
    cc = continuum(Path(workdir) / "controlled.h5")
    deviation = np.abs(np.diag(cc["mobility"]) - exact)
    check(np.all(deviation <= np.diag(cc["mobility_error"])),
          f"controlled sphere: |continuum - Stokes| {deviation / exact} within the bar {np.diag(cc['mobility_error']) / exact}")
    full = np.asarray(cc["sample_full"]).reshape(-1)
    level = np.asarray(cc["sample_level"]).reshape(-1)
    check(len(level) == 20 and all(sorted(full[level == k]) == [0, 0, 0, 1, 1] for k in range(1, 5)),
          f"controlled: per level 2 full samples and 3 control samples (levels {level}, full {full})")
    mobility, control = (np.asarray(cc[name]).reshape(len(level), 36) for name in ("sample_mobility", "sample_control_mobility"))
    check(np.all(np.isnan(mobility[full == 0])) and np.all(np.isfinite(mobility[full == 1]))
          and np.all(np.isfinite(control)) and cc["control_offsets"] == 3,
          "controlled: control samples have no order-L values (NaN), every sample its order-L - 1 control")
    means = np.array([(mobility[(level == k) & (full == 1)] - control[(level == k) & (full == 1)]).mean(0)
                      + control[level == k].mean(0) for k in range(1, 5)])
    check(np.allclose(means, np.asarray(cc["level_mobility"]).reshape(4, 36), rtol=1e-12, atol=1e-15),
          "controlled: each level's mean is mean(y - x) over the full samples + mean(x) over all")
    # A control is solved to five times the job's Krylov tolerance (1e-3 by default), not ten: at
    # 1e-2 a handful of iterations meets the tolerance, and which one moved a control's solver error
    # by 0.26 % between samples (docs/theory.md T18, "Control samples"); those solves' true
    # residuals were 9.2e-3 to 9.9e-3.
    residual = np.asarray(cc["sample_true_relative_residual"]).reshape(-1)
    # (CG stops on the preconditioned residual, so the true one may exceed 5e-3 a little.)
    check(np.all(residual[full == 0] <= 8.0e-3) and np.all(residual[full == 0] > 0),
          f"controlled: control samples solved to 5e-3 (true relative residuals {residual[full == 0].max():.2e} at most)")
    # Iterations, not seconds: a test must not time a loaded machine.
    iterations = np.asarray(cc["sample_iterations"]).reshape(-1)
    check(np.max(iterations[(full == 0) & (level == 4)]) < np.min(iterations[(full == 1) & (level == 4)]),
          "controlled: a control sample (order 1 alone, looser tolerance) takes fewer Krylov iterations than a full "
          "one (order 2 and its control)")
    checkpoint = Path(workdir) / "controlled_stopped.h5.continuum_checkpoint"
    checkpoint.unlink(missing_ok=True)
    nml = write_input(workdir, "controlled_stopped.nml", "controlled_stopped.h5", SPHERE + controlled_ladder)
    stopped = run(beadmob, mpiexec, ranks, workdir, nml, "-stop_after_solves", "3")
    done = run(beadmob, mpiexec, ranks, workdir, nml)
    resumed = continuum(Path(workdir) / "controlled_stopped.h5") if done.returncode == 0 else None
    check(stopped.returncode != 0 and "resuming with 3 samples" in done.stdout and resumed is not None
          and np.all(np.abs(resumed["mobility"] - cc["mobility"]) <= 1e-3 * cc["mobility_error"]),
          "controlled: stopped after three samples (one a control sample) and resumed, the same values")
    for body, expected in (
            ("&shape name = 'sphere', radius = 1.0, bead_diameter = 0.25 /\n&hydrodynamics multipole_order = 1 /\n"
             + controlled_ladder, "needs multipole_order >= 2"),
            (SPHERE + "&continuum control_offsets = -1 /\n", "control_offsets must be 0 to 256")):
        nml = write_input(workdir, "refused.nml", "refused.h5", body)
        (Path(workdir) / "refused.h5").unlink(missing_ok=True)   # of an earlier run of this test
        done = run(beadmob, mpiexec, ranks, workdir, nml)
        check(done.returncode != 0 and expected in done.stderr + done.stdout and not (Path(workdir) / "refused.h5").exists(),
              f"refused ({expected!r}): exit {done.returncode}, {(done.stderr.strip().splitlines() or [''])[-1]!r}")

    # A flow job with control samples: the sphere's stresslet per unit strain of each orthonormal
    # mode, (20 / 3) pi a^3 (Batchelor 1970; Kim & Karrila 1991, ch. 3), within its bar, and each
    # level's mean of it mean(y - x) + mean(x) as for the mobility.
    nml = write_input(workdir, "flow.nml", "flow.h5", "&shape name = 'sphere', radius = 1.0, bead_diameter = 0.25 /\n"
                      "&hydrodynamics flow = .true. /\n" + controlled_ladder)
    done = run(beadmob, mpiexec, ranks, workdir, nml)
    if done.returncode != 0:
        sys.exit(f"the controlled flow job failed:\n{done.stdout}\n{done.stderr}")
    fc = continuum(Path(workdir) / "flow.h5")
    stresslet, bar = np.diag(fc["stresslet_per_strain"]), np.diag(fc["stresslet_per_strain_error"])
    check(np.all(np.abs(stresslet - 20 * math.pi / 3) <= bar) and np.all(bar < 0.15 * 20 * math.pi / 3),
          f"controlled flow: the sphere's stresslet {stresslet} = 20 pi / 3 within its bar {bar}")
    y = np.asarray(fc["sample_stresslet_per_strain"]).reshape(len(level), 25)
    x = np.asarray(fc["sample_control_stresslet_per_strain"]).reshape(len(level), 25)
    means = np.array([(y[(level == k) & (full == 1)] - x[(level == k) & (full == 1)]).mean(0) + x[level == k].mean(0)
                      for k in range(1, 5)])
    check(np.all(np.isnan(y[full == 0])) and np.all(np.isfinite(x))
          and np.allclose(means, np.asarray(fc["level_stresslet_per_strain"]).reshape(4, 25), rtol=1e-12, atol=1e-12),
          "controlled flow: each level's stresslet mean is mean(y - x) over the full samples + mean(x) over all")

    # 5. The dry run, and the samples per level an input leaves out: 2 offsets and 6 control
    #    samples of order 1 at the default order 2; 4 plain offsets at order 1.
    nml = write_input(workdir, "dry.nml", "dry.h5", SPHERE + "&continuum time_budget = 300 /\n")
    done = run(beadmob, mpiexec, ranks, workdir, nml, "--estimate")
    check(done.returncode == 0 and "continuum ladder of 7 levels x 2 offsets (+ 6 control samples of order 1)" in done.stdout
          and not (Path(workdir) / "dry.h5").exists(), "--estimate prints the ladder (default: 2 offsets + 6 control "
          "samples) and writes no result")
    nml = write_input(workdir, "dry.nml", "dry.h5", SPHERE.replace("&hydrodynamics /", "&hydrodynamics multipole_order = 1 /")
                      + "&continuum time_budget = 300 /\n")
    done = run(beadmob, mpiexec, ranks, workdir, nml, "--estimate")
    check(done.returncode == 0 and "levels x 4 offsets, bead diameters" in done.stdout,
          "at multipole_order = 1 the default is 4 plain offsets (no lower order to control with)")
    # fill_budget (the default): the dry run says what is left of the budget for control samples
    # after the ladder; off, it says nothing.
    nml = write_input(workdir, "dry.nml", "dry.h5", SPHERE + "&continuum time_budget = 20 /\n")
    done = run(beadmob, mpiexec, ranks, workdir, nml, "--estimate")
    plain = re.search(r"estimated time ([0-9.]+) s \(budget 20\. s", done.stdout)
    rest = re.search(r"fill_budget: the rest, about ([0-9.]+) s", done.stdout)
    check(plain is not None and rest is not None and abs(float(rest.group(1)) - (20 - float(plain.group(1)))) <= 1.0,
          f"fill_budget: the dry run names the rest of the budget ({rest.group(0) if rest else None})")
    nml = write_input(workdir, "dry.nml", "dry.h5", SPHERE + "&continuum time_budget = 20, fill_budget = .false. /\n")
    done = run(beadmob, mpiexec, ranks, workdir, nml, "--estimate")
    check(done.returncode == 0 and "estimated time" in done.stdout and "fill_budget" not in done.stdout,
          "fill_budget = .false.: the dry run leaves the rest unspent")
    # The run: the samples it bought are control samples (order L - 1 alone) on offsets of their
    # own, levels hold different numbers of samples, each level's mean is still mean(y - x) over its
    # full samples + mean(x) over all of them (numpy, on the unequal levels), and the sphere is
    # within its bar of Stokes's mobility. -fill_samples 40 buys 40 samples whatever the time (what
    # is left of the budget depends on the machine's load; the benches measure that rule).
    fill = 40
    # Four levels (the cheapest ladder of seven would hold 8.6k beads, a minute of the Debug build).
    nml = write_input(workdir, "filled.nml", "filled.h5", SPHERE + "&continuum levels = 4, time_budget = 20 /\n")
    (Path(workdir) / "filled.h5.continuum_checkpoint").unlink(missing_ok=True)
    done = run(beadmob, mpiexec, ranks, workdir, nml, "-fill_samples", str(fill), "-keep_checkpoint")
    if done.returncode != 0:
        sys.exit(f"the filled continuum job failed:\n{done.stdout}\n{done.stderr}")
    fc = continuum(Path(workdir) / "filled.h5")
    level = np.asarray(fc["sample_level"]).reshape(-1)
    full = np.asarray(fc["sample_full"]).reshape(-1)
    levels = len(np.asarray(fc["bead_diameters"]).reshape(-1))
    counts = np.bincount(level, minlength=levels + 1)[1:]
    check(fc["fill_budget"] == 1 and np.all(counts >= 8) and len(level) == levels * 8 + fill and counts.max() <= 64
          and all(np.sum(full[level == k]) == 2 for k in range(1, levels + 1)),
          f"fill_budget: 2 full samples per level, 6 control samples and the {fill} bought (per level {counts})")
    offsets = np.asarray(fc["sample_offset"]).reshape(len(level), 3)
    check(all(len({tuple(o) for o in offsets[level == k]}) == counts[k - 1] for k in range(1, levels + 1)),
          "fill_budget: every sample of a level on its own lattice offset")
    mobility, control = (np.asarray(fc[name]).reshape(len(level), 36) for name in ("sample_mobility", "sample_control_mobility"))
    # With the moment control (on by default; T18) every sample of an entry is shifted by what its
    # bead moments explain, x - shift: the shift from the postprocessor's second implementation of
    # the regression (scripts/beadmob_post/continuum_bar.py, tested against numpy's least squares).
    features, body_features = moment_features(np.asarray(fc["sample_moments"]).reshape(len(level), 13),
                                              np.asarray(fc["body_moments"]).reshape(13))
    shift = np.column_stack([moment_control_shift(control[:, q], level, features, body_features)[0] for q in range(36)])
    means = np.array([(mobility[(level == k) & (full == 1)] - control[(level == k) & (full == 1)]).mean(0)
                      + (control - shift)[level == k].mean(0) for k in range(1, levels + 1)])
    check(fc["moment_control"] == 1 and np.any(np.abs(shift) > 1e-9 * np.abs(control)),
          "fill_budget: the moment control engaged (72 samples on 4 levels)")
    check(np.allclose(means, np.asarray(fc["level_mobility"]).reshape(levels, 36), rtol=1e-10, atol=1e-15),
          "fill_budget: each level's mean is mean(y - x) over its full samples + mean(x - moment shift) over all, "
          "levels unequal")
    deviation = np.abs(np.diag(fc["mobility"]) - exact)
    check(np.all(deviation <= np.diag(fc["mobility_error"])),
          f"fill_budget: the sphere within its bar of Stokes ({deviation / exact} against {np.diag(fc['mobility_error']) / exact})")
    # Stopped in the fill and resumed: the checkpoint's samples come back as they were, and the fill
    # goes on from there with control samples on offsets not yet used. The stopped job starts from
    # the filled job's ladder (its kept checkpoint cut to the ladder's samples, which it resumes
    # without a solve) and stops two samples into the fill (-stop_after_solves counts the samples
    # solved in this run).
    base = levels * 8
    checkpoint = Path(workdir) / "filled.h5.continuum_checkpoint"
    whole = checkpoint.read_text().splitlines()
    checkpoint.write_text("\n".join(whole[:1 + base]) + "\n")
    (Path(workdir) / "filled.h5").unlink()
    stopped = run(beadmob, mpiexec, ranks, workdir, nml, "-stop_after_solves", "2", "-fill_samples", str(fill))
    check(stopped.returncode != 0 and f"resuming with {base} samples" in stopped.stdout
          and not (Path(workdir) / "filled.h5").exists(),
          f"fill_budget: the job resumed the {base} samples of the ladder and stopped two samples into the fill, "
          "no result written")
    kept = checkpoint.read_text().splitlines()[1:] if checkpoint.exists() else []
    done = run(beadmob, mpiexec, ranks, workdir, nml, "-fill_samples", str(fill))
    resumed = continuum(Path(workdir) / "filled.h5") if done.returncode == 0 else None
    if resumed is None:
        check(False, f"fill_budget: the resumed job failed:\n{done.stdout}\n{done.stderr}")
    else:
        level = np.asarray(resumed["sample_level"]).reshape(-1)
        full = np.asarray(resumed["sample_full"]).reshape(-1)
        offsets = np.asarray(resumed["sample_offset"]).reshape(len(level), 3)
        counts = np.bincount(level, minlength=levels + 1)[1:]
        check(stopped.returncode != 0 and len(kept) == base + 2 and f"resuming with {len(kept)} samples" in done.stdout
              and np.all(counts >= 8) and len(level) == levels * 8 + fill and np.all(full[len(kept):] == 0)
              and all(len({tuple(o) for o in offsets[level == k]}) == counts[k - 1] for k in range(1, levels + 1)),
              f"fill_budget: stopped in the fill with {len(kept)} samples and resumed, filled on to {len(level)} "
              f"(per level {counts}), every sample of a level on its own offset")

    # 8. The levels check the ladder (T18): the samples after the pilot count 30 times their time,
    # so the first level that is a fair share of the rest shows an overrun and the ladder moves
    # coarser. The ladder before the move is the last one printed before the move's message.
    nml = write_input(workdir, "slow.nml", "slow.h5",
                      SPHERE + "&continuum levels = 3, time_budget = 80, fill_budget = .false. /\n")
    done = run(beadmob, mpiexec, ranks, workdir, nml, "-slow_samples", "30")
    moved = re.search(r"the ladder moves (\d+) level\(s\) coarser \(bead diameters (\S+) \.\.\. (\S+),", done.stdout)
    before = re.findall(r"bead diameters \(coarsest first\):\n(.*)\n", done.stdout[:moved.start()] if moved else "")
    if done.returncode != 0 or moved is None or not before:
        check(False, f"slow samples: the job ran and moved its ladder coarser:\n{done.stdout}\n{done.stderr}")
    else:
        sc = continuum(Path(workdir) / "slow.h5")
        steps = int(moved.group(1))
        diameters = np.asarray(sc["bead_diameters"]).reshape(-1)
        planned = np.array([float(x) for x in before[-1].split()])
        level = np.asarray(sc["sample_level"]).reshape(-1)
        full = np.asarray(sc["sample_full"]).reshape(-1)
        counts = np.bincount(level, minlength=4)[1:]
        check(steps >= 1 and sc["ladder_moved_coarser"] == steps and len(diameters) == 3
              and np.allclose(diameters, planned * 2.0 ** (steps / 3.0), rtol=1e-3)
              and np.isclose(diameters[0], float(moved.group(2)), rtol=1e-3)
              and np.isclose(diameters[-1], float(moved.group(3)), rtol=1e-3),
              f"slow samples: the ladder {planned} moved {steps} level(s) coarser to {diameters}, recorded")
        # Each sample's beads fill the sphere at its level's bead diameter: N d^3 is its volume
        # 4 pi / 3 within 20 % (the neighbouring levels' would be off by a factor 2).
        filled = np.asarray(sc["sample_beads"]).reshape(-1) * diameters[level - 1] ** 3 / (4 * math.pi / 3)
        # A level the budget ran out on keeps the samples it had (the warning says how many).
        kept = {int(k): int(n) for k, n in re.findall(r"level (\d+) keeps (\d+) of its 8 samples", done.stdout)}
        check(all(counts[k - 1] == kept.get(k, 8) for k in range(1, 4)) and all(np.sum(full[level == k]) == 2 for k in range(1, 4))
              and np.all(np.abs(filled - 1) < 0.2),
              f"slow samples: every level of the moved ladder holds its 2 + 6 samples at its bead diameter "
              f"(per level {counts}, cut short by the budget {kept}; N d^3 / V from {filled.min():.3f} to {filled.max():.3f})")
        deviation = np.abs(np.diag(sc["mobility"]) - exact)
        check(np.all(deviation <= np.diag(sc["mobility_error"])),
              f"slow samples: the sphere within its bar of Stokes ({deviation / exact} against "
              f"{np.diag(sc['mobility_error']) / exact})")

    # 9. The budget runs out within a level (T18, "The ladder"): with -slow_samples 10000 every
    # sample after the pilot counts hours, so once a level's full samples are solved no control
    # sample fits in what is left, and each level keeps its 2 full samples alone (the ladder cannot
    # be checked by a complete level: none is). The job still finishes and says so per level.
    nml = write_input(workdir, "cut.nml", "cut.h5",
                      SPHERE + "&continuum levels = 3, time_budget = 30, fill_budget = .false. /\n")
    done = run(beadmob, mpiexec, ranks, workdir, nml, "-slow_samples", "10000")
    cut = continuum(Path(workdir) / "cut.h5") if done.returncode == 0 else None
    if cut is None:
        check(False, f"budget spent within a level: the job failed:\n{done.stdout}\n{done.stderr}")
    else:
        level = np.asarray(cut["sample_level"]).reshape(-1)
        full = np.asarray(cut["sample_full"]).reshape(-1)
        warned = re.findall(r"level (\d+) keeps 2 of its 8 samples: its next control sample", done.stdout)
        check(len(level) == 6 and np.all(full == 1) and np.all(np.bincount(level, minlength=4)[1:] == 2)
              and sorted(int(k) for k in warned) == [1, 2, 3],
              f"budget spent within a level: each level keeps its 2 full samples, no control sample, and says so "
              f"(levels {level}, full {full}, warned for {warned})")
        # Without control samples a level's controlled mean, mean(y - x) + mean(x) over the same two
        # samples, is the plain mean of their order-L mobility (numpy).
        mobility = np.asarray(cut["sample_mobility"]).reshape(len(level), 36)
        means = np.array([mobility[level == k].mean(0) for k in range(1, 4)])
        check(np.all(np.isfinite(mobility)) and np.allclose(means, np.asarray(cut["level_mobility"]).reshape(3, 36),
                                                            rtol=1e-12, atol=1e-15)
              and np.all(np.diag(cut["mobility_error"]) > 0),
              "budget spent within a level: each level's mean is the plain mean of its two full samples, every "
              "diagonal entry with a bar")

    if failures:
        sys.exit(f"{len(failures)} check(s) failed")
    print("check_continuum: all checks passed")


if __name__ == "__main__":
    main(*sys.argv[1:5])
