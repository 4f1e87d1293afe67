"""beadmob_post.brownian and `beadmob-post diffusion` on synthetic result files (h5py), against
exact references:

- a sphere of radius a: D_t = kT/(6 pi eta a), D_r = kT/(8 pi eta a^3), all five l = 2 relaxation
  times 1/(6 D_r) (Stokes; Einstein), [eta] = 5/2 with and without Brownian motion (Einstein 1906);
- the centre of diffusion of a sphere whose mobility is given about another point is its centre;
  for any mobility it makes the coupling symmetric and minimises tr D_tt;
- ellipsoids from beadmob_post.ellipsoid.ellipsoid_friction: Perrin's (1934) closed forms for the
  spheroid's D_t and D_parallel, D_perp (as in Koenig 1975, Biopolymers 14, 2421); Favro's five
  rates equal the eigenvalues of the rotational operator on l = 2 functions;
- the intrinsic viscosity of spheroids, with the stresslet built here from Eshelby's tensor at
  Poisson ratio 1/2 (Eshelby 1957; Mura 1987 section 11) and Jeffery's rotation: Simha's (1940)
  viscosity increments as tabulated by Scheraga (1955) and Simha's closed form in Jeffery's
  integrals; the Brownian part B^2 / (10 eta V M_rr,perp) of Hinch & Leal (1972);
- Bretherton's B = (r^2 - 1)/(r^2 + 1) of a spheroid in any orientation.
"""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

from beadmob_post import brownian
from beadmob_post.brownian import (BOLTZMANN, STRAIN_MODES, bretherton_form, centre_of_diffusion,
                                   diffusion_analysis, favro_relaxation_times, intrinsic_viscosity,
                                   mode_rotation, rotational_operator)
from beadmob_post.cli import main
from beadmob_post.ellipsoid import ellipsoid_friction
from beadmob_post.mobility import in_frame, shift_reference_point
from beadmob_post.results import ResultFileError, load_result

SPHERE = 1.7   # radius


def sphere_mobility(a: float = SPHERE) -> np.ndarray:
    return np.diag([1 / (6 * np.pi * a)] * 3 + [1 / (8 * np.pi * a**3)] * 3)


def add_flow(path, velocity, stresslet, modes=STRAIN_MODES, velocity_error=None, stresslet_error=None,
             transposed=False):
    """A /flow group as beadmob writes it (docs: [row, column] in h5py; ``transposed``: the other way)."""
    with h5py.File(path, "a") as handle:
        group = handle.create_group("flow")
        group["strain_modes"] = np.moveaxis(modes, 0, -1) if transposed else modes
        group["velocity_per_strain"] = np.asarray(velocity).T if transposed else velocity
        group["stresslet_per_strain"] = stresslet
        if velocity_error is not None:
            group["velocity_per_strain_error"] = velocity_error
        if stresslet_error is not None:
            group["stresslet_per_strain_error"] = stresslet_error
    return path


def result_with(make_result_file, mobility, name="r.h5", **options):
    return make_result_file(name=name, hydrodynamics={"friction": np.linalg.inv(mobility)}, **options)


# ------------------------------------------------------------------ exact ellipsoid in linear flow
def _q(function) -> float:
    return quad(function, 0, np.inf, epsabs=0, epsrel=1e-12, limit=500)[0]


def ellipsoid_stresslet(semi_axes) -> tuple[np.ndarray, float]:
    """T (5x5, eta = 1) of the free ellipsoid in its axes and its volume: the rigid inclusion in an
    incompressible matrix, T = 2 V_p (S^Esh)^-1 on traceless tensors, with Eshelby's tensor at
    nu = 1/2 (Mura 1987 eq. 11.16): S_iiii = 3 a_i^2 I_ii / 4 pi, S_iijj = a_j^2 I_ij / 4 pi,
    S_ijij = (a_i^2 + a_j^2) I_ij / 8 pi, I_ij = 2 pi a1 a2 a3 int dl / ((a_i^2+l)(a_j^2+l) Delta)."""
    a2 = np.asarray(semi_axes, float) ** 2
    volume = 4 / 3 * np.pi * np.prod(semi_axes)
    I = np.array([[2 * np.pi * np.prod(semi_axes) * _q(lambda l, i=i, j=j: 1 / ((a2[i] + l) * (a2[j] + l)
                                                                               * np.sqrt(np.prod(a2 + l))))
                   for j in range(3)] for i in range(3)])
    S = np.zeros((3, 3, 3, 3))
    for i in range(3):
        S[i, i, i, i] = 3 * a2[i] * I[i, i] / (4 * np.pi)
        for j in range(3):
            if i != j:
                S[i, i, j, j] = a2[j] * I[i, j] / (4 * np.pi)
                S[i, j, i, j] = S[i, j, j, i] = (a2[i] + a2[j]) * I[i, j] / (8 * np.pi)
    modes = np.einsum("kij,ijab,lab->kl", STRAIN_MODES, S, STRAIN_MODES)
    return 2 * volume * np.linalg.inv(modes), volume


def jeffery_rotation(semi_axes) -> np.ndarray:
    """C (3x5): Omega_i - Omega_inf_i = (a_j^2 - a_k^2)/(a_j^2 + a_k^2) E_jk (Jeffery 1922)."""
    a2 = np.asarray(semi_axes, float) ** 2
    rotation = np.zeros((3, 5))
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        rotation[i] = (a2[j] - a2[k]) / (a2[j] + a2[k]) * STRAIN_MODES[:, j, k]
    return rotation


def ellipsoid_file(make_result_file, semi_axes, axes=np.eye(3), name="e.h5", errors=False):
    """A result file of an ellipsoid whose semi-axes lie along the rows of ``axes`` (model coordinates)."""
    stresslet, volume = ellipsoid_stresslet(semi_axes)
    velocity = np.zeros((6, 5))
    velocity[3:6] = jeffery_rotation(semi_axes)
    turn = mode_rotation(axes)                       # body amplitudes = D(A) model amplitudes
    model_velocity = np.zeros((6, 5))
    model_velocity[3:6] = axes.T @ velocity[3:6] @ turn
    model_stresslet = turn.T @ stresslet @ turn
    mobility = in_frame(np.linalg.inv(ellipsoid_friction(semi_axes)), axes.T)
    path = result_with(make_result_file, mobility, name=name)
    bars = dict(velocity_error=np.full((6, 5), 1e-4), stresslet_error=np.full((5, 5), 1e-3)) if errors else {}
    return add_flow(path, model_velocity, model_stresslet, **bars), volume


# ------------------------------------------------------------------ diffusion
def test_sphere_diffusion_and_relaxation(make_result_file):
    d = diffusion_analysis(load_result(result_with(make_result_file, sphere_mobility())))
    assert d.translational == pytest.approx(1 / (6 * np.pi * SPHERE), rel=1e-12)
    assert d.stokes_radius == pytest.approx(SPHERE, rel=1e-12)
    assert d.rotational == pytest.approx([1 / (8 * np.pi * SPHERE**3)] * 3, rel=1e-12)
    tau = 1 / (6 / (8 * np.pi * SPHERE**3))
    assert d.relaxation_times == pytest.approx([tau] * 5, rel=1e-12)
    assert d.harmonic_mean_time == pytest.approx(tau, rel=1e-12)
    assert d.volume == pytest.approx(4.0)                    # 4 lattice cells of d^3
    assert d.flow is None


def test_sphere_in_si_units(make_result_file, capsys):
    path = result_with(make_result_file, sphere_mobility())
    status = main(["diffusion", str(path), "--temperature", "293.15", "--viscosity", "1.002e-3",
                   "--length-unit", "2e-8", "--json"])
    assert status == 0
    physical = json.loads(capsys.readouterr().out)["physical"]
    kT, eta, a = BOLTZMANN * 293.15, 1.002e-3, SPHERE * 2e-8
    assert physical["translational_diffusion_m2_s"] == pytest.approx(kT / (6 * np.pi * eta * a), rel=1e-12)
    assert physical["rotational_diffusion_1_s"] == pytest.approx([kT / (8 * np.pi * eta * a**3)] * 3, rel=1e-12)
    assert physical["relaxation_times_s"] == pytest.approx([8 * np.pi * eta * a**3 / (6 * kT)] * 5, rel=1e-12)
    assert physical["stokes_radius_m"] == pytest.approx(a, rel=1e-12)


def test_centre_of_diffusion_of_an_offset_sphere(make_result_file):
    """Mobility given about the centre of mass of the beads, the sphere centred elsewhere."""
    path = make_result_file(name="probe.h5")
    centre_of_mass = load_result(path).centre_of_mass
    centre = centre_of_mass + np.array([0.7, -0.3, 1.1])
    mobility = shift_reference_point(sphere_mobility(), centre_of_mass - centre)
    d = diffusion_analysis(load_result(result_with(make_result_file, mobility)))
    assert d.centre_of_diffusion == pytest.approx(centre, abs=1e-12)
    assert d.translational == pytest.approx(1 / (6 * np.pi * SPHERE), rel=1e-12)
    assert np.trace(mobility[:3, :3]) / 3 > d.translational   # larger about the centre of mass


def test_centre_of_diffusion_symmetrises_coupling_and_minimises_trace():
    rng = np.random.default_rng(7)
    a = rng.normal(size=(6, 6))
    mobility = a @ a.T + 6 * np.eye(6)
    centre, moved = centre_of_diffusion(mobility, np.zeros(3))
    assert np.abs(moved[3:6, 0:3] - moved[3:6, 0:3].T).max() < 1e-13
    assert moved == pytest.approx(shift_reference_point(mobility, centre), abs=1e-14)
    best = minimize(lambda r: np.trace(shift_reference_point(mobility, r)[:3, :3]), np.zeros(3),
                    method="BFGS", options={"gtol": 1e-12}).x
    assert centre == pytest.approx(best, abs=1e-6)


def test_centre_of_diffusion_is_beadmobs_centre_of_mobility(make_result_file):
    """The Fortran writes the point where the coupling of the mobility is symmetric; a file that
    records it (here computed as src/hydro/mobility.f90 does: axial(M_rt + M_rr [d]x) = 0)."""
    rng = np.random.default_rng(3)
    a = rng.normal(size=(6, 6))
    mobility = a @ a.T + 6 * np.eye(6)

    def axial(m):
        return 0.5 * np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])

    from beadmob_post.mobility import skew
    system = np.column_stack([axial(mobility[3:, 3:] @ skew(e)) for e in np.eye(3)])
    path = make_result_file(name="com.h5")
    centre_of_mass = load_result(path).centre_of_mass
    fortran = centre_of_mass + np.linalg.solve(system, -axial(mobility[3:, :3]))
    path = make_result_file(name="m.h5", hydrodynamics={"friction": np.linalg.inv(mobility)})
    with h5py.File(path, "a") as handle:
        handle["hydrodynamics/centre_of_mobility"] = fortran
    d = diffusion_analysis(load_result(path))
    assert d.centre_of_diffusion == pytest.approx(fortran, abs=1e-12)
    assert d.file_centre_of_mobility == pytest.approx(fortran, abs=1e-15)


@pytest.mark.parametrize("semi_axes", [(2.5, 1.0, 1.0), (1.0, 2.5, 2.5)])
def test_spheroid_diffusion_is_perrins(make_result_file, semi_axes):
    """Perrin (1934): prolate (a > b) D_t = ln((a + c)/b) / (6 pi c), c^2 = a^2 - b^2; oblate
    (a < b) arctan(c/a) / (6 pi c), c^2 = b^2 - a^2; prolate D_par = 3 (2a - b^2 S)/(32 pi (a^2 - b^2) b^2),
    D_perp = 3 ((2a^2 - b^2) S - 2a)/(32 pi (a^4 - b^4)), S = 2 ln((a + c)/b)/c."""
    axes = Rotation.from_euler("zyx", [30, -50, 110], degrees=True).as_matrix().T
    mobility = in_frame(np.linalg.inv(ellipsoid_friction(semi_axes)), axes.T)
    d = diffusion_analysis(load_result(result_with(make_result_file, mobility)))
    a, b = semi_axes[0], semi_axes[1]
    if a > b:
        c = np.sqrt(a * a - b * b)
        expected = np.log((a + c) / b) / (6 * np.pi * c)
        s = 2 * np.log((a + c) / b) / c
        parallel = 3 * (2 * a - b * b * s) / (32 * np.pi * (a * a - b * b) * b * b)
        perpendicular = 3 * ((2 * a * a - b * b) * s - 2 * a) / (32 * np.pi * (a**4 - b**4))
        assert sorted(d.rotational) == pytest.approx(sorted([parallel, perpendicular, perpendicular]), rel=1e-12)
    else:
        c = np.sqrt(b * b - a * a)
        expected = np.arctan(c / a) / (6 * np.pi * c)
    assert d.translational == pytest.approx(expected, rel=1e-12)
    assert d.stokes_radius == pytest.approx(1 / (6 * np.pi * expected), rel=1e-12)
    assert d.centre_of_diffusion == pytest.approx(load_result(result_with(make_result_file, mobility,
                                                                          name="c.h5")).centre_of_mass, abs=1e-12)


def test_favro_rates_are_the_rotational_operator_eigenvalues():
    mobility = np.linalg.inv(ellipsoid_friction([3.0, 2.0, 1.0]))
    rr = mobility[3:, 3:]
    rates = np.sort(-np.linalg.eigvalsh(rotational_operator(rr)))
    assert np.sort(1 / favro_relaxation_times(np.diag(rr))) == pytest.approx(rates, rel=1e-12)
    # symmetric top (Favro 1960): 6 D_perp, 5 D_perp + D_par (twice), 2 D_perp + 4 D_par (twice)
    rr = np.diag([0.3, 0.1, 0.1])
    expected = sorted([0.6, 0.8, 0.8, 1.4, 1.4])
    assert np.sort(-np.linalg.eigvalsh(rotational_operator(rr))) == pytest.approx(expected, rel=1e-12)
    assert np.sort(1 / favro_relaxation_times([0.3, 0.1, 0.1])) == pytest.approx(expected, rel=1e-12)


def test_mobility_error_bars_propagate(make_result_file):
    """Errors on the tt diagonal only: the centre of diffusion does not move, so the bar of
    D_t = tr(M_tt)/3 is the mean of the three bars."""
    bars = np.zeros((6, 6))
    bars[0, 0], bars[1, 1], bars[2, 2] = 1e-4, 2e-4, 6e-4
    path = make_result_file(name="bars.h5", hydrodynamics={
        "friction": np.linalg.inv(sphere_mobility()), "error_estimate_factors": np.ones(5)})
    with h5py.File(path, "a") as handle:
        handle["hydrodynamics/body_axes"] = np.eye(3)
        handle["hydrodynamics/body_mobility"] = sphere_mobility()
        handle["hydrodynamics/body_mobility_error"] = bars
    d = diffusion_analysis(load_result(path))
    assert d.errors["translational_diffusion"] == pytest.approx(3e-4, rel=1e-6)
    assert d.errors["rotational_diffusion"] == pytest.approx([0, 0, 0], abs=1e-12)


# ------------------------------------------------------------------ intrinsic viscosity, Bretherton
def test_sphere_intrinsic_viscosity_is_einstein(make_result_file):
    stresslet = 20 / 3 * np.pi * SPHERE**3 * np.eye(5)
    path = add_flow(result_with(make_result_file, sphere_mobility()), np.zeros((6, 5)), stresslet)
    d = diffusion_analysis(load_result(path), volume=4 / 3 * np.pi * SPHERE**3)
    assert d.flow.intrinsic_viscosity.high_frequency == pytest.approx(2.5, rel=1e-13)
    assert d.flow.intrinsic_viscosity.zero_shear == pytest.approx(2.5, rel=1e-13)
    assert d.flow.intrinsic_viscosity.brownian == 0.0


#: Simha's viscosity increments of spheroids as tabulated by Scheraga (1955, J. Chem. Phys. 23,
#: 1526) and Mehl, Oncley & Simha (1940, Science 92, 132): (semi-axis along the symmetry axis /
#: equatorial semi-axis, [eta]).
SIMHA_TABLE = [(2, 2.91), (5, 5.81), (10, 13.63), (1 / 2, 2.85), (1 / 5, 4.71), (1 / 10, 8.04)]


@pytest.mark.parametrize("ratio, tabulated", SIMHA_TABLE)
def test_spheroid_intrinsic_viscosity_is_simhas(make_result_file, ratio, tabulated):
    axes = Rotation.from_euler("zxz", [20, 70, -35], degrees=True).as_matrix().T
    path, volume = ellipsoid_file(make_result_file, (ratio, 1.0, 1.0), axes)
    d = diffusion_analysis(load_result(path), volume=volume)
    assert d.flow.intrinsic_viscosity.zero_shear == pytest.approx(tabulated, abs=0.006)
    assert d.flow.intrinsic_viscosity.zero_shear == pytest.approx(simha(ratio, 1.0), rel=1e-9)


def simha(a: float, b: float) -> float:
    """Simha's [eta] of the spheroid with semi-axis a along its axis and b across, in Jeffery's
    integrals (as quoted on the Wikipedia page 'Intrinsic viscosity', whose rotary-diffusion term N
    lacks the factor B = (a^2 - b^2)/(a^2 + b^2) restored here: N = 6 (a^2 - b^2) B / (a b^2 (a^2 J_a +
    b^2 J_b)), so that oblate bodies do not fall below 5/2)."""
    j_a = _q(lambda x: 1 / ((x + b * b) * (x + a * a) ** 1.5))
    j_b = _q(lambda x: 1 / ((x + b * b) ** 2 * (x + a * a) ** 0.5))
    j_a1 = _q(lambda x: 1 / ((x + b * b) ** 3 * (x + a * a) ** 0.5))
    j_b1 = _q(lambda x: 1 / ((x + b * b) ** 2 * (x + a * a) ** 1.5))
    j_a2 = _q(lambda x: x / ((x + b * b) ** 3 * (x + a * a) ** 0.5))
    j_b2 = _q(lambda x: x / ((x + b * b) ** 2 * (x + a * a) ** 1.5))
    m = 1 / (a * b**4 * j_a1)
    k = m / 2
    j = k * j_a2 / j_b2
    l = 2 / (a * b * b * (a * a + b * b) * j_b1)
    n = 6 * (a * a - b * b) ** 2 / (a * a + b * b) / (a * b * b * (a * a * j_a + b * b * j_b))
    return 4 / 15 * (j + k - l) + 2 / 3 * l + m / 3 + n / 15


def test_long_prolate_spheroid_approaches_simhas_asymptote():
    """Simha's large-p form 14/15 + p^2/(15 (ln 2p - 3/2)) + p^2/(5 (ln 2p - 1/2))."""
    p = 100.0
    stresslet, volume = ellipsoid_stresslet((p, 1.0, 1.0))
    mobility = np.linalg.inv(ellipsoid_friction((p, 1.0, 1.0)))
    value = intrinsic_viscosity(jeffery_rotation((p, 1.0, 1.0)), stresslet, mobility[3:, 3:], volume)
    log = np.log(2 * p)
    asymptote = 14 / 15 + p * p / (15 * (log - 1.5)) + p * p / (5 * (log - 0.5))
    assert value.zero_shear == pytest.approx(asymptote, rel=2e-3)
    assert value.zero_shear > 2 * value.high_frequency     # rotary Brownian motion dominates


def test_brownian_part_of_a_body_of_revolution_is_hinch_and_leal():
    """For Omega - Omega_inf = B p x (E.p), the Brownian stress 3 n kT B <pp> gives
    [eta]_B = B^2 / (10 eta V M_rr,perp), whatever the stresslet and the axial rotational mobility."""
    rng = np.random.default_rng(11)
    p = rng.normal(size=3)
    p /= np.linalg.norm(p)
    perpendicular, axial, b, volume = 0.07, 0.21, 0.83, 2.9
    rr = perpendicular * np.eye(3) + (axial - perpendicular) * np.outer(p, p)
    value = intrinsic_viscosity(b * bretherton_form(p), np.eye(5), rr, volume)
    assert value.brownian == pytest.approx(b * b / (10 * volume * perpendicular), rel=1e-12)
    assert value.high_frequency == pytest.approx(5 / (10 * volume), rel=1e-14)


def test_bretherton_constant_of_a_turned_spheroid(make_result_file, capsys):
    r = 4.0
    axes = Rotation.from_euler("xyz", [15, 40, -60], degrees=True).as_matrix().T
    path, volume = ellipsoid_file(make_result_file, (r, 1.0, 1.0), axes)
    flow = diffusion_analysis(load_result(path), volume=volume).flow
    assert flow.bretherton.constant == pytest.approx((r * r - 1) / (r * r + 1), rel=1e-12)
    assert abs(flow.bretherton.axis @ axes[0]) == pytest.approx(1.0, abs=1e-12)
    assert flow.bretherton.residual < 1e-12 and flow.bretherton.axisymmetric
    assert flow.bretherton.aspect_ratio == pytest.approx(r, rel=1e-12)
    assert flow.bretherton.jeffery_period == pytest.approx(2 * np.pi * (r + 1 / r), rel=1e-12)
    assert main(["diffusion", str(path), "--volume", str(volume)]) == 0
    out = capsys.readouterr().out
    assert "Bretherton B:     0.882353" in out and "a body of revolution" in out


def test_triaxial_jeffery_constants(make_result_file):
    semi = (3.0, 2.0, 1.0)
    path, volume = ellipsoid_file(make_result_file, semi)
    flow = diffusion_analysis(load_result(path), volume=volume).flow
    assert not flow.bretherton.axisymmetric
    # principal axes of D_rr, smallest D_r first: about x (largest rotational friction), ...
    lam = {0: (4 - 1) / 5, 1: (1 - 9) / 10, 2: (9 - 4) / 13}
    d = diffusion_analysis(load_result(path), volume=volume)
    for k, axis in enumerate(d.rotational_axes):
        which = int(np.argmax(np.abs(axis)))
        assert abs(flow.jeffery_constants[k]) == pytest.approx(abs(lam[which]), rel=1e-12)
    assert flow.jeffery_off_pattern < 1e-12


def test_file_modes_in_another_order_give_the_same_numbers(make_result_file):
    """/flow in another orthonormal basis of strain modes (permuted, signs flipped) and stored in
    the other index order: the results do not change."""
    semi = (2.0, 1.3, 0.8)
    reference_path, volume = ellipsoid_file(make_result_file, semi, name="ref.h5")
    reference = diffusion_analysis(load_result(reference_path), volume=volume).flow
    change = np.zeros((5, 5))
    for k, (l, sign) in enumerate([(3, 1), (0, -1), (4, 1), (1, 1), (2, -1)]):
        change[k, l] = sign
    modes = np.einsum("kl,lij->kij", change, STRAIN_MODES)        # F_k = sum_l P_kl E_l
    velocity = np.zeros((6, 5))
    velocity[3:6] = jeffery_rotation(semi) @ change.T
    stresslet = change @ ellipsoid_stresslet(semi)[0] @ change.T
    path = add_flow(result_with(make_result_file, np.linalg.inv(ellipsoid_friction(semi)), name="other.h5"),
                    velocity, stresslet, modes=modes, transposed=True)
    flow = diffusion_analysis(load_result(path), volume=volume).flow
    assert flow.intrinsic_viscosity.zero_shear == pytest.approx(reference.intrinsic_viscosity.zero_shear, rel=1e-12)
    assert flow.bretherton.constant == pytest.approx(reference.bretherton.constant, rel=1e-12)


def test_flow_error_bars(make_result_file, capsys):
    path, volume = ellipsoid_file(make_result_file, (2.0, 1.0, 1.0), errors=True)
    d = diffusion_analysis(load_result(path), volume=volume)
    errors = d.flow.errors
    # tr(T) moves by at most 5 x 1e-3: [eta]_inf by 5e-3 / (10 V)
    assert errors["high_frequency"] == pytest.approx(5e-3 / (10 * volume), rel=1e-6)
    assert 0 < errors["bretherton"] < 1e-3 and errors["zero_shear"] > errors["high_frequency"]
    assert main(["diffusion", str(path), "--volume", str(volume), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["flow"]["errors"]["high_frequency"] == pytest.approx(
        errors["high_frequency"])


def test_continuum_file_uses_its_mobility_volume_and_flow(tmp_path):
    from conftest import write_result_file
    path = write_result_file(tmp_path / "c.h5")
    centroid = np.array([0.5, -1.0, 2.0])
    with h5py.File(path, "a") as handle:
        group = handle.create_group("continuum")
        offset = np.array([0.1, 0.2, -0.3])   # the centroid lies at the sphere's centre - offset
        group["mobility"] = shift_reference_point(sphere_mobility(0.5), -offset)
        group["centroid"] = centroid - offset
        group.attrs["volume"] = 4 / 3 * np.pi * 0.125
        group["mobility_error"] = np.diag([1e-4] * 3 + [0] * 3)
        group["velocity_per_strain"] = np.zeros((6, 5))
        group["stresslet_per_strain"] = 20 / 3 * np.pi * 0.125 * np.eye(5)
        group.attrs["flow"] = 1
    d = diffusion_analysis(load_result(path))
    assert d.source == "continuum" and d.volume_source == "/continuum volume"
    assert d.centre_of_diffusion == pytest.approx(centroid, abs=1e-12)
    assert d.stokes_radius == pytest.approx(0.5, rel=1e-12)
    assert d.errors["translational_diffusion"] == pytest.approx(1e-4, rel=1e-6)
    assert d.flow.intrinsic_viscosity.zero_shear == pytest.approx(2.5, rel=1e-12)
    assert main(["orbit", str(path), "--strain", "5", "--json"]) == 0     # a sphere: x, y turn with -1/2


# ------------------------------------------------------------------ command line and reading
def test_diffusion_command_text_and_info(make_result_file, capsys):
    stresslet = 20 / 3 * np.pi * SPHERE**3 * np.eye(5)
    path = add_flow(result_with(make_result_file, sphere_mobility()), np.zeros((6, 5)), stresslet)
    assert main(["diffusion", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"Stokes radius:    {SPHERE:.6g} d" in out and "[eta] zero shear:" in out
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "diffusion:        D_t = " in out and "flow:             [eta] = " in out
    assert main(["info", "--json", str(path)]) == 0
    summary = json.loads(capsys.readouterr().out)["hydrodynamics"]["diffusion"]
    assert summary["stokes_radius"] == pytest.approx(SPHERE)


def test_diffusion_command_errors(make_result_file, capsys):
    path = result_with(make_result_file, sphere_mobility())
    assert main(["diffusion", str(path), "--temperature", "300"]) == 2
    assert "need --temperature (K), --viscosity (Pa s) and --length-unit" in capsys.readouterr().err
    assert main(["diffusion", str(path), "--volume", "-1"]) == 2
    assert "--volume must be positive" in capsys.readouterr().err
    plain = make_result_file(name="plain.h5")
    assert main(["diffusion", str(plain)]) == 2
    assert "no /hydrodynamics" in capsys.readouterr().err
    assert main(["diffusion", str(path)]) == 0
    assert "no /flow in the file" in capsys.readouterr().out


def test_flow_without_a_response_is_refused(make_result_file, capsys):
    path = add_flow(result_with(make_result_file, sphere_mobility()), np.zeros((6, 5)), np.eye(5))
    with h5py.File(path, "a") as handle:
        handle["flow"].attrs["response_available"] = 0
    assert main(["diffusion", str(path)]) == 2
    assert "/flow holds no response (response_available = 0" in capsys.readouterr().err


def test_malformed_strain_modes_are_refused(make_result_file):
    path = result_with(make_result_file, sphere_mobility())
    add_flow(path, np.zeros((6, 5)), np.eye(5), modes=2 * STRAIN_MODES)
    with pytest.raises(ResultFileError, match="not five orthonormal"):
        load_result(path)


def test_flow_is_read(make_result_file):
    velocity = np.arange(30.0).reshape(6, 5)
    path = add_flow(result_with(make_result_file, sphere_mobility()), velocity, np.eye(5),
                    velocity_error=np.ones((6, 5)))
    flow = load_result(path).flow
    assert flow.velocity_per_strain == pytest.approx(velocity)
    assert flow.stresslet_per_strain_error is None and flow.velocity_per_strain_error.shape == (6, 5)
    assert brownian.canonical_flow(flow)[0] == pytest.approx(velocity, rel=1e-14, abs=1e-14)


def test_real_spheroid_run(beadmob_output_dir, capsys):
    """The Fortran's flow test run of a 10:5:5 d spheroid of beads (flow/flow_spheroid.h5): with the
    spheroid's own volume, [eta] and B within 1 % of Simha's and Jeffery's values for r = 2, and
    D_t within 1 % of Perrin's."""
    path = beadmob_output_dir / "flow" / "flow_spheroid.h5"
    if not path.exists():
        pytest.skip(f"{path} missing (the Fortran's &hydrodynamics flow runs)")
    volume = 4 / 3 * np.pi * 10 * 5 * 5
    d = diffusion_analysis(load_result(path), volume=volume)
    assert d.flow.bretherton.constant == pytest.approx(0.6, rel=1e-2) and d.flow.bretherton.axisymmetric
    assert d.flow.intrinsic_viscosity.zero_shear == pytest.approx(simha(2.0, 1.0), rel=1e-2)
    c = np.sqrt(75.0)
    assert d.translational == pytest.approx(np.log((10 + c) / 5) / (6 * np.pi * c), rel=1e-2)
    assert main(["orbit", str(path), "--strain", "20", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["bretherton"]["orbit_constant_relative_change"] is None or \
        data["bretherton"]["orbit_constant_relative_change"] < 1e-8
    period = [item["period"] for name, item in data["axes"].items() if "symmetry" in name][0]
    assert period == pytest.approx(2 * np.pi * 2.5, rel=1e-2)


@pytest.mark.parametrize("name", ["flow_spheroid.h5", "flow_body.h5"])
def test_fortran_diffusion_group(beadmob_output_dir, name):
    """beadmob's own /diffusion group (src/hydro/brownian_numbers.f90) against this module on the
    same file: two implementations of the same formulas (this module's are checked against exact
    values above), so they agree to rounding; [eta] with the volume N d^3 both use."""
    path = beadmob_output_dir / "flow" / name
    if not path.exists():
        pytest.skip(f"{path} missing (the Fortran's &hydrodynamics flow runs)")
    with h5py.File(path) as f:
        g = f["diffusion"]
        fortran = {key: g.attrs[key] for key in g.attrs if not isinstance(g.attrs[key], (bytes, str))}
        centre, rotational = g["centre_of_diffusion"][()], g["rotational_diffusion"][()]
        times = g["relaxation_times"][()]
        n = int(f["geometry"].attrs["n_beads"])
    d = diffusion_analysis(load_result(path), volume=float(n))
    assert centre == pytest.approx(d.centre_of_diffusion, abs=1e-9)
    assert fortran["translational_diffusion"] == pytest.approx(d.translational, rel=1e-10)
    assert fortran["stokes_radius"] == pytest.approx(d.stokes_radius, rel=1e-10)
    assert rotational == pytest.approx(d.rotational, rel=1e-9)
    assert times == pytest.approx(d.relaxation_times, rel=1e-9)
    assert fortran["harmonic_mean_relaxation_time"] == pytest.approx(d.harmonic_mean_time, rel=1e-10)
    eta = d.flow.intrinsic_viscosity
    assert fortran["volume"] == n
    assert fortran["intrinsic_viscosity_high_frequency"] == pytest.approx(eta.high_frequency, rel=1e-10)
    assert fortran["intrinsic_viscosity_zero_shear"] == pytest.approx(eta.zero_shear, rel=1e-8)
