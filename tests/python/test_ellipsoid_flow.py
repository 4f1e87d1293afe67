"""Tests of beadmob_post.ellipsoid in an ambient linear flow (strain modes, ellipsoid_flow,
pair_integrals, intrinsic_viscosity), each against a source other than the module's formulas:

- the strain conventions: orthonormality, the tensor route against the 5x5 representation;
- the sphere: T = (20/3) pi eta a^3 I_5, V = 0 in any orientation, Einstein's 5/2;
- spheroids: the rotation against Bretherton's form of Jeffery's equation,
  Omega - Omega_inf = B p x (E.p) with B = (r^2 - 1)/(r^2 + 1) (Bretherton 1962, J. Fluid
  Mech. 14, 284); the stresslet against the closed-form resistance functions X^M, Y^M, Z^M, Y^H
  in the eccentricity (Kim & Karrila, Microhydrodynamics, 1991, Table 3.4), the fixed body's
  stresslet corrected by the coupling to Jeffery's rotation; oblate bodies by the same
  functions continued to imaginary eccentricity (checked on the module's Y^C, itself tested
  against quadrature in test_ellipsoid.py);
- the intrinsic viscosity of spheroids against Simha's formula in Jeffery's integrals
  (Simha 1940, J. Phys. Chem. 44, 25), by quadrature, without its rotary-diffusion term;
- triaxial bodies: the integrals by quadrature, the stresslet by a second route (the full
  Eshelby tensor at Poisson ratio 1/2 from quadrature, projected on the modes and inverted),
  covariance under rotations and relabelled axes, symmetry (reciprocity, not imposed by the
  module) and positivity, continuity to the spheroid and the sphere, the isotropic average.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from beadmob_post.ellipsoid import (
    ellipsoid_flow,
    ellipsoid_friction,
    intrinsic_viscosity,
    pair_integrals,
    strain_amplitudes,
    strain_modes,
    strain_rotation,
    strain_tensor,
)


def random_rotation(seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def rotation_about(axis, angle: float) -> np.ndarray:
    """Rodrigues' formula."""
    n = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    cross = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    return np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross


def random_strain(seed: int) -> np.ndarray:
    g = np.random.default_rng(seed).normal(size=(3, 3))
    e = 0.5 * (g + g.T)
    return e - np.trace(e) / 3 * np.eye(3)


def volume(semi_axes) -> float:
    return 4 * np.pi * float(np.prod(semi_axes)) / 3


def q_integral(f) -> float:
    return quad(f, 0, np.inf, epsabs=0, epsrel=1e-13, limit=200)[0]


# --- strain conventions -------------------------------------------------------------------------

def test_strain_modes_orthonormal_symmetric_traceless():
    modes = strain_modes()
    assert modes.shape == (5, 3, 3)
    assert np.allclose(np.einsum("kij,lij->kl", modes, modes), np.eye(5), atol=1e-15)
    assert np.allclose(modes, modes.transpose(0, 2, 1))
    assert np.allclose(np.trace(modes, axis1=1, axis2=2), 0)
    s = 1 / np.sqrt(2)
    assert modes[0][0, 1] == pytest.approx(s) and modes[2][1, 2] == pytest.approx(s)
    assert np.allclose(np.diag(modes[4]), np.array([-1, -1, 2]) / np.sqrt(6))


def test_amplitudes_round_trip_and_refusals():
    e = random_strain(1)
    amplitudes = strain_amplitudes(e)
    assert np.allclose(strain_tensor(amplitudes), e, atol=1e-14)
    assert np.sum(amplitudes**2) == pytest.approx(np.sum(e * e), rel=1e-13)
    with pytest.raises(ValueError, match="symmetric and traceless"):
        strain_amplitudes(e + np.eye(3))
    with pytest.raises(ValueError, match="symmetric and traceless"):
        strain_amplitudes(e + np.array([[0, 1, 0], [0, 0, 0], [0, 0, 0]]))


def test_strain_rotation_is_the_representation():
    q1, q2 = random_rotation(2), random_rotation(3)
    d1 = strain_rotation(q1)
    assert np.allclose(strain_rotation(np.eye(3)), np.eye(5), atol=1e-15)
    assert np.allclose(d1 @ d1.T, np.eye(5), atol=1e-14)
    assert np.allclose(strain_rotation(q1 @ q2), d1 @ strain_rotation(q2), atol=1e-14)
    e = random_strain(4)
    assert np.allclose(strain_amplitudes(q1 @ e @ q1.T), d1 @ strain_amplitudes(e), atol=1e-14)
    with pytest.raises(ValueError, match="orthogonal"):
        strain_rotation(2 * np.eye(3))


# --- sphere -------------------------------------------------------------------------------------

def test_sphere_einstein():
    a, eta = 1.7, 2.3
    for rotation in (None, random_rotation(5)):
        velocity, stresslet = ellipsoid_flow([a, a, a], viscosity=eta, rotation=rotation)
        assert np.allclose(stresslet, 20 / 3 * np.pi * eta * a**3 * np.eye(5), rtol=1e-14, atol=1e-12)
        assert np.abs(velocity).max() < 1e-14
    # eta_eff = eta (1 + [eta] phi): n <S> = (phi / V_p) tr(T)/5 E = 2 eta [eta] phi E.
    assert intrinsic_viscosity([a, a, a]) == pytest.approx(2.5, rel=1e-14)


def test_isotropic_average_is_the_trace():
    """<D T D^T> over all orientations is tr(T)/5 I (Schur): the 60 rotations of the icosahedron
    already average exactly, their restriction of the l = 2 representation being irreducible."""
    phi = (1 + np.sqrt(5)) / 2
    generators = [rotation_about([0, 1, phi], 2 * np.pi / 5), rotation_about([1, 1, 1], 2 * np.pi / 3)]
    group = [np.eye(3)]
    frontier = [np.eye(3)]
    while frontier:
        new = []
        for g in frontier:
            for h in generators:
                p = h @ g
                if not any(np.allclose(p, k, atol=1e-9) for k in group):
                    group.append(p)
                    new.append(p)
        frontier = new
    assert len(group) == 60
    _, stresslet = ellipsoid_flow([3.0, 2.0, 1.0])
    average = sum(strain_rotation(g) @ stresslet @ strain_rotation(g).T for g in group) / 60
    assert np.allclose(average, np.trace(stresslet) / 5 * np.eye(5), rtol=1e-12, atol=1e-11)
    assert intrinsic_viscosity([3.0, 2.0, 1.0]) == pytest.approx(np.trace(stresslet) / (10 * volume([3, 2, 1])))


# --- spheroids ----------------------------------------------------------------------------------

@pytest.mark.parametrize("ratio", [5.0, 0.2, 1.5])
def test_spheroid_rotation_is_bretherton(ratio):
    b = 0.8
    q = random_rotation(6)
    p = q[:, 0]                                   # the symmetry axis, semi-axis ratio * b
    velocity, _ = ellipsoid_flow([ratio * b, b, b], rotation=q)
    bretherton = (ratio**2 - 1) / (ratio**2 + 1)
    for seed in (7, 8):
        e = random_strain(seed)
        assert np.abs(velocity[:3] @ strain_amplitudes(e)).max() < 1e-14
        # Omega - Omega_inf = p x p_dot with p_dot = B (E.p - (p.E.p) p) the strain part
        expected = bretherton * np.cross(p, e @ p)
        assert np.allclose(velocity[3:] @ strain_amplitudes(e), expected, atol=1e-14)


def kim_karrila(e: complex) -> dict[str, float]:
    """Resistance functions of a spheroid of polar semi-axis a and eccentricity e
    (b^2 = a^2 (1 - e^2)), Kim & Karrila 1991 Table 3.4; e imaginary for oblate bodies (the
    functions are analytic in e^2, L -> 2i arctan |e|)."""
    e = complex(e)
    L = np.log((1 + e) / (1 - e))
    values = {
        "XM": 8 / 15 * e**5 / ((3 - e**2) * L - 6 * e),
        "YM": 4 / 5 * e**5 * (2 * e * (1 - 2 * e**2) - (1 - e**2) * L)
        / ((2 * e * (2 * e**2 - 3) + 3 * (1 - e**2) * L) * (-2 * e + (1 + e**2) * L)),
        "ZM": 16 / 5 * e**5 * (1 - e**2) / (3 * (1 - e**2) ** 2 * L - 2 * e * (3 - 5 * e**2)),
        "YH": 4 / 3 * e**5 / (-2 * e + (1 + e**2) * L),
        "XC": 4 / 3 * e**3 * (1 - e**2) / (2 * e - (1 - e**2) * L),
        "YC": 4 / 3 * e**3 * (2 - e**2) / (-2 * e + (1 + e**2) * L),
    }
    assert all(abs(v.imag) < 1e-12 * abs(v) for v in values.values())
    return {k: v.real for k, v in values.items()}


def eccentricity(a: float, b: float) -> complex:
    e2 = 1 - (b / a) ** 2
    return np.sqrt(e2) if e2 >= 0 else 1j * np.sqrt(-e2)


def test_kim_karrila_functions_sane():
    # Sphere limit: 1, and Y^H -> 0 as B ~ e^2 / 2; the continuation reproduces the module's
    # rotational friction.
    near_sphere = kim_karrila(0.01)
    assert near_sphere.pop("YH") == pytest.approx(0.5e-4, rel=1e-3)
    assert all(v == pytest.approx(1, abs=1e-3) for v in near_sphere.values())
    for a, b in [(2.0, 1.0), (1.0, 3.0)]:
        f = kim_karrila(eccentricity(a, b))
        friction = np.diag(ellipsoid_friction([a, b, b]))
        assert friction[3] == pytest.approx(8 * np.pi * a**3 * f["XC"], rel=1e-12)
        assert friction[4] == pytest.approx(8 * np.pi * a**3 * f["YC"], rel=1e-12)


@pytest.mark.parametrize("a, b", [(1.0, 0.6), (1.0, 0.2), (1.0, 0.05), (0.6, 1.0), (0.2, 1.0), (0.05, 1.0)])
def test_spheroid_stresslet_kim_karrila(a, b):
    f = kim_karrila(eccentricity(a, b))
    bretherton = (a**2 - b**2) / (a**2 + b**2)
    # Jeffery's rotation is the ratio of the torque couplings: Y^H / Y^C = B.
    assert f["YH"] / f["YC"] == pytest.approx(bretherton, rel=1e-11)
    eta = 1.4
    q = random_rotation(9)
    d = q[:, 0]
    dd = np.outer(d, d)

    def free_stresslet(e):
        ed, ded = e @ d, d @ e @ d
        part0 = 1.5 * (dd - np.eye(3) / 3) * ded
        part1 = np.outer(d, ed) + np.outer(ed, d) - 2 * dd * ded
        part2 = e - part0 - part1
        # S = (20/3) pi eta a^3 [X^M d0 + Y^M d1 + Z^M d2]:E + H:(Omega_inf - Omega), where the
        # rotation coupling H:w = 4 pi eta a^3 Y^H [(w x d) d + d (w x d)] (the transpose of the
        # torque 8 pi eta a^3 Y^H d x (E.d)) at Omega - Omega_inf = B d x (E.d) gives
        # -4 pi eta a^3 Y^H B part1.
        return 20 / 3 * np.pi * eta * a**3 * (f["XM"] * part0 + (f["YM"] - 0.6 * bretherton * f["YH"]) * part1
                                             + f["ZM"] * part2)

    modes = strain_modes()
    expected = np.array([[np.sum(modes[k] * free_stresslet(modes[l])) for l in range(5)] for k in range(5)])
    _, stresslet = ellipsoid_flow([a, b, b], viscosity=eta, rotation=q)
    assert np.allclose(stresslet, expected, rtol=0, atol=1e-11 * np.abs(expected).max())


@pytest.mark.parametrize("a, b", [(2.0, 1.0), (5.0, 1.0), (20.0, 1.0), (1.0, 2.0), (1.0, 5.0), (1.0, 20.0)])
def test_spheroid_intrinsic_viscosity_simha(a, b):
    """Simha's [eta] for a spheroid of polar semi-axis a and equatorial b, in Jeffery's integrals,
    is (4/15)(J + K - L) + (2/3) L + M/3 + N/15; N/15 = zeta_perp B / (10 eta V_p) is the rotary
    Brownian stress (3 n kT <pp - I/3>, <pp - I/3> = B E / (15 D_r) at weak flow), absent here."""
    j_alpha = q_integral(lambda x: 1 / ((x + b * b) * (x + a * a) ** 1.5))
    j_alpha_p = q_integral(lambda x: 1 / ((x + b * b) ** 3 * (x + a * a) ** 0.5))
    j_beta_p = q_integral(lambda x: 1 / ((x + b * b) ** 2 * (x + a * a) ** 1.5))
    j_alpha_pp = q_integral(lambda x: x / ((x + b * b) ** 3 * (x + a * a) ** 0.5))
    j_beta_pp = q_integral(lambda x: x / ((x + b * b) ** 2 * (x + a * a) ** 1.5))
    m = 1 / (a * b**4 * j_alpha_p)
    k = m / 2
    j = k * j_alpha_pp / j_beta_pp
    ell = 2 / (a * b * b * (a * a + b * b) * j_beta_p)
    simha_hydrodynamic = 4 / 15 * (j + k - ell) + 2 / 3 * ell + m / 3
    assert intrinsic_viscosity([a, b, b]) == pytest.approx(simha_hydrodynamic, rel=1e-10)
    assert intrinsic_viscosity([b, a, b]) == pytest.approx(simha_hydrodynamic, rel=1e-12)
    # Its N/15 is the Brownian stress written with the module's friction (a consistency check
    # of that reading, not of the module).
    j_beta = q_integral(lambda x: 1 / ((x + b * b) ** 2 * (x + a * a) ** 0.5))
    n_term = 6 / (a * b * b) * (a * a - b * b) / (a * a * j_alpha + b * b * j_beta) / 15
    zeta_perp = ellipsoid_friction([a, b, b])[4, 4]
    assert n_term == pytest.approx(zeta_perp * (a * a - b * b) / (a * a + b * b) / (10 * volume([a, b, b])),
                                   rel=1e-10)


# --- triaxial -----------------------------------------------------------------------------------

@pytest.mark.parametrize("semi_axes", [(3.0, 2.0, 1.0), (1.0, 0.5, 0.01), (0.7, 4.0, 1.3)])
def test_pair_integrals_by_quadrature(semi_axes):
    squares = np.asarray(semi_axes) ** 2
    beta = pair_integrals(semi_axes)
    for i in range(3):
        for j in range(3):
            exact = q_integral(lambda t: 1 / ((squares[i] + t) * (squares[j] + t) * np.sqrt(np.prod(squares + t))))
            assert beta[i, j] == pytest.approx(exact, rel=1e-11)


def eshelby_route(semi_axes, viscosity: float) -> np.ndarray:
    """T from the whole Eshelby tensor at Poisson ratio 1/2 (Mura 1987, section 11: S_iiii =
    Q a_i^2 I_ii, S_iijj = (Q/3) a_j^2 I_ij, S_ijij = S_ijji = (Q/6)(a_i^2 + a_j^2) I_ij, the rest 0,
    Q = 3/(4 pi)), its integrals I_ij = 2 pi a_1 a_2 a_3 beta_ij by quadrature, projected on the
    modes and inverted: the rigid free body's eigenstrain solves S:eps* = -E, S_p = -2 eta V_p eps*."""
    squares = np.asarray(semi_axes) ** 2
    scale = 2 * np.pi * np.prod(semi_axes)
    big_i = np.array([[scale * q_integral(lambda t, i=i, j=j: 1 / ((squares[i] + t) * (squares[j] + t)
                                                                    * np.sqrt(np.prod(squares + t))))
                       for j in range(3)] for i in range(3)])
    q = 3 / (4 * np.pi)
    tensor = np.zeros((3, 3, 3, 3))
    for i in range(3):
        for j in range(3):
            if i == j:
                tensor[i, i, i, i] = q * squares[i] * big_i[i, i]
            else:
                tensor[i, i, j, j] = q / 3 * squares[j] * big_i[i, j]
                tensor[i, j, i, j] = tensor[i, j, j, i] = q / 6 * (squares[i] + squares[j]) * big_i[i, j]
    modes = strain_modes()
    projected = np.einsum("kij,ijmn,lmn->kl", modes, tensor, modes)
    return 2 * viscosity * volume(semi_axes) * np.linalg.inv(projected)


@pytest.mark.parametrize("semi_axes", [(3.0, 2.0, 1.0), (0.7, 4.0, 1.3), (1.0, 0.5, 0.05)])
def test_triaxial_stresslet_by_eshelby_quadrature(semi_axes):
    _, stresslet = ellipsoid_flow(semi_axes, viscosity=0.9)
    assert np.allclose(stresslet, eshelby_route(semi_axes, 0.9), rtol=0, atol=1e-10 * np.abs(stresslet).max())


def test_triaxial_jeffery_rotation():
    semi_axes = np.array([3.0, 2.0, 1.0])
    s = semi_axes**2
    velocity, _ = ellipsoid_flow(semi_axes)
    e = random_strain(10)
    spin = velocity[3:] @ strain_amplitudes(e)
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        assert spin[i] == pytest.approx((s[j] - s[k]) / (s[j] + s[k]) * e[j, k], abs=1e-14)
    # Simple shear u = (y, 0, 0): a body long along x turns slower than the fluid (-1/2 about z).
    shear = np.array([[0, 1, 0], [0, 0, 0], [0, 0, 0]], dtype=float)
    spin = -0.5 * np.array([0, 0, 1]) + velocity[3:] @ strain_amplitudes(0.5 * (shear + shear.T))
    assert -0.5 < spin[2] < 0


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_triaxial_covariance(seed):
    """A turned body, through the tensors (not D): Omega_lab = Q Omega(Q^T E Q), S_lab = Q S Q^T."""
    semi_axes = [2.5, 1.2, 0.7]
    q = random_rotation(seed)
    velocity_body, stresslet_body = ellipsoid_flow(semi_axes)
    velocity_lab, stresslet_lab = ellipsoid_flow(semi_axes, rotation=q)
    e_lab = random_strain(seed + 100)
    e_body = strain_amplitudes(q.T @ e_lab @ q)
    assert np.allclose(velocity_lab @ strain_amplitudes(e_lab),
                       np.concatenate([q @ velocity_body[:3] @ e_body, q @ velocity_body[3:] @ e_body]), atol=1e-13)
    s_lab = strain_tensor(stresslet_lab @ strain_amplitudes(e_lab))
    assert np.allclose(s_lab, q @ strain_tensor(stresslet_body @ e_body) @ q.T, atol=1e-12)


def test_relabelled_axes():
    """The same body given with its semi-axes in another order along permuted (proper) axes."""
    velocity, stresslet = ellipsoid_flow([3.0, 2.0, 1.0])
    x, y, z = np.eye(3)
    for semi_axes, columns in [([2.0, 1.0, 3.0], [y, z, x]), ([2.0, 3.0, 1.0], [y, x, -z]),
                               ([1.0, 3.0, 2.0], [-z, x, -y])]:
        q = np.column_stack(columns)
        turned_velocity, turned_stresslet = ellipsoid_flow(semi_axes, rotation=q)
        assert np.allclose(turned_velocity, velocity, atol=1e-14)
        assert np.allclose(turned_stresslet, stresslet, rtol=1e-13, atol=1e-12)
    with pytest.raises(ValueError, match="proper"):
        ellipsoid_flow([2.0, 3.0, 1.0], rotation=np.column_stack([y, x, z]))


def test_triaxial_symmetric_positive_definite():
    rng = np.random.default_rng(14)
    for _ in range(20):
        semi_axes = np.exp(rng.uniform(-2.5, 2.5, size=3))
        _, stresslet = ellipsoid_flow(semi_axes, rotation=random_rotation(int(rng.integers(1000))))
        assert np.abs(stresslet - stresslet.T).max() < 1e-12 * np.abs(stresslet).max()
        assert np.linalg.eigvalsh(stresslet).min() > 0


def test_continuity_to_spheroid_and_sphere():
    spheroid_v, spheroid_t = ellipsoid_flow([3.0, 1.0, 1.0])
    for delta in (1e-4, 1e-8):
        v, t = ellipsoid_flow([3.0, 1.0 + delta, 1.0])
        assert np.abs(t - spheroid_t).max() < 10 * delta * np.abs(spheroid_t).max()
        assert np.abs(v - spheroid_v).max() < delta
    _, t = ellipsoid_flow([1.0, 1.0 + 1e-9, 1.0 - 1e-9])
    assert np.allclose(t, 20 / 3 * np.pi * np.eye(5), rtol=1e-8, atol=1e-8)
