"""Tests of beadmob_post.two_sphere_flow (two equal spheres rigidly joined, in a linear flow).

Independent routes:

- the two-sphere resistance functions against H. J. Wilson's Lamb's-method / reflection code
  (Wilson 2013, J. Comput. Phys. 245, 302), whose lambda = 1 values are tabulated in A. K.
  Townsend's stokesian-dynamics repository (find_resistance_scalars/
  scalars_general_resistance_text_midfield.txt, 8 digits; a different method from the
  twin-multipole series used here);
- X^A_11 + X^A_12 against Stimson & Jeffery's bispherical solution (two_spheres.py), the doublet's
  axial friction against two_spheres.doublet_mobility;
- the lowest series coefficients against single reflections (Stokeslet, rotlet and Einstein
  stresslet of one sphere acting on the other through Faxen's laws, derived in the docstrings);
- the lambda = 1 summed recurrences against the three-index recurrences as printed (JO 1984,
  J92, with Townsend 2018's corrections);
- the rigid doublet far apart: B = 1 - (16/3)(a/r)^2 + 6 (a/r)^3, T_22 -> (20/3) pi a^3 (2 + 6/5 B),
  T_11 = (40/3) pi a^3 (Z^M_11 + Z^M_12), T_55 = 2 pi a r^2 (1 + 3a/2r + 9a^2/4r^2) + (40/3) pi a^3
  (module docstring, item 2); symmetry, positivity, the pattern of V and T.
"""

from __future__ import annotations

from functools import lru_cache
from math import comb

import numpy as np
import pytest
from scipy.special import zeta

from beadmob_post import two_sphere_flow as tsf
from beadmob_post.two_spheres import corotation_torque, doublet_mobility, stimson_jeffery

UNIT = 20.0 / 3.0 * np.pi

# Wilson's values (lambda = 1), scaled by eta 6 pi a^n: JO's A, B, C, G, H, M are these times
# 1, 3/2, 3/4, 3/2, 3/4, 9/10. Rows: s' = r/a, then the 11 and the 12 functions.
WILSON_NAMES = ("XA", "YA", "YB", "XC", "YC", "XG", "YG", "YH", "XM", "YM", "ZM")
WILSON_TO_JO = {"XA": 1.0, "YA": 1.0, "YB": 1.5, "XC": 0.75, "YC": 0.75, "XG": 1.5, "YG": 1.5,
                "YH": 0.75, "XM": 0.9, "YM": 0.9, "ZM": 0.9}
WILSON = {
    2.5: ([1.72266492e+00, 1.16486474e+00, -8.27660438e-02, 1.34268751e+00, 1.40365025e+00, 5.22723233e-01,
           3.04763286e-02, -4.33705849e-03, 1.38953869e+00, 1.16156629e+00, 1.11373712e+00],
          [-1.04974951e+00, -4.01078941e-01, 1.98020641e-01, -8.64623805e-02, 5.56205916e-02, -6.82049709e-01,
           -4.51905225e-02, 1.20137623e-01, 4.17824160e-01, -9.55135477e-02, -2.27824529e-02]),
    3.0: ([1.36847902e+00, 1.09210175e+00, -3.78309879e-02, 1.33594554e+00, 1.35731422e+00, 2.17291663e-01,
           1.08029518e-02, -2.08308736e-03, 1.20594364e+00, 1.12726645e+00, 1.11168893e+00],
          [-6.70174540e-01, -2.97175857e-01, 1.23592085e-01, -4.95271369e-02, 2.88862269e-02, -3.53518375e-01,
           -1.93321752e-02, 6.42077874e-02, 2.02516469e-01, -6.79884966e-02, -9.14283310e-03]),
    4.0: ([1.16947007e+00, 1.04330302e+00, -1.35542800e-02, 1.33372854e+00, 1.33896764e+00, 7.33516506e-02,
           2.37612675e-03, -4.41652985e-04, 1.13400291e+00, 1.11392927e+00, 1.11116693e+00],
          [-4.27211758e-01, -2.04476858e-01, 6.54348510e-02, -2.08409285e-02, 1.12773649e-02, -1.70261146e-01,
           -5.65700187e-03, 2.62674844e-02, 8.24986486e-02, -3.48401770e-02, -2.17005162e-03]),
}

# The module docstring's table: r/a -> (B, T_11, T_22, T_55), T in units of (20/3) pi eta a^3.
TABLE = {
    2.5: (0.667345875423615, 1.963718518994716, 2.496252320335530, 4.837210358392880),
    3.0: (0.724360616378102, 1.984582976731173, 2.655213198299416, 5.984676761710165),
    4.0: (0.805366275376166, 1.996194387138847, 2.859177266651000, 8.684434458393314),
    6.0: (0.892339611089492, 1.999489412988909, 3.035756573843650, 15.766673705601521),
    10.0: (0.954783993766200, 1.999960063090517, 3.137871306401701, 36.929918341024489),
}


@pytest.mark.parametrize("s", sorted(WILSON))
def test_scalars_match_wilsons_lamb_method(s):
    scalars = tsf.resistance_scalars(s)
    eleven, twelve = WILSON[s]
    for i, name in enumerate(WILSON_NAMES):
        factor = WILSON_TO_JO[name]
        assert scalars[name][0] == pytest.approx(factor * eleven[i], abs=5e-6), (name, 11)
        assert scalars[name][1] == pytest.approx(factor * twelve[i], abs=5e-6), (name, 12)


def _three_index_coefficients(order):
    """f_k(lambda = 1) from the recurrences in their printed three-index form P_npq (JO eq. 3.9-3.10,
    4.6-4.11, 7.3-7.5; J92 eq. 48, 58, 73-76; as corrected by Townsend 2018), summed over q."""

    def make(kind, start):
        first = 2 if kind == "z" else 1

        def binom(n, s):
            return comb(n + s, n + {"x": 0, "y": 1, "z": 2}[kind])

        @lru_cache(maxsize=None)
        def P(n, p, q):
            if p < 0 or q < 0:
                return 0.0
            if p == 0 and q == 0:
                return float(start.get("P") == n)
            total = 0.0
            for s in range(first, q + 1):
                c = binom(n, s)
                if kind == "x":
                    total += c * (n * (2 * n + 1) * (2 * n * s - n - s + 2) / (2 * (n + 1) * (2 * s - 1) * (n + s))
                                  * P(s, q - s, p - n + 1) - n * (2 * n - 1) / (2 * (n + 1)) * P(s, q - s, p - n - 1)
                                  - n * (4 * n * n - 1) / (2 * (n + 1) * (2 * s + 1)) * V(s, q - s - 2, p - n + 1))
                elif kind == "y":
                    total += c * ((2 * n + 1) / (2 * (n + 1)) * (3 * (n + s) - (n * s + 1) * (2 * n * s - s - n + 2))
                                  / (s * (n + s) * (2 * s - 1)) * P(s, q - s, p - n + 1)
                                  + n * (2 * n - 1) / (2 * (n + 1)) * P(s, q - s, p - n - 1)
                                  + n * (4 * n * n - 1) / (2 * (n + 1) * (2 * s + 1)) * V(s, q - s - 2, p - n + 1)
                                  - 2 * (4 * n * n - 1) / (3 * (n + 1)) * Q(s, q - s - 1, p - n + 1))
                else:
                    total += c * (-2 * (2 * n + 1) * (2 * n - 1) / (n + 1) * Q(s, q - s - 1, p - n + 1)
                                  + n * (2 * n + 1) * (2 * n - 1) / (2 * (n + 1) * (2 * s + 1))
                                  * V(s, q - s - 2, p - n + 1)
                                  + (2 * n + 1) / (n + 1)
                                  * (n * s * (n + s - 2 * n * s - 2) - 4 * (2 * n * s - 4 * s - 4 * n + 2))
                                  / (2 * s * (n + s) * (2 * s - 1)) * P(s, q - s, p - n + 1)
                                  + n * (2 * n - 1) / (2 * (n + 1)) * P(s, q - s, p - n - 1))
            return total

        @lru_cache(maxsize=None)
        def V(n, p, q):
            if p < 0 or q < 0:
                return 0.0
            if p == 0 and q == 0:
                return float(start.get("V") == n)
            sign = -1.0 if kind == "x" else 1.0
            return P(n, p, q) + sign * 2 * n / ((n + 1) * (2 * n + 3)) * sum(
                binom(n, s) * P(s, q - s, p - n - 1) for s in range(first, q + 1))

        @lru_cache(maxsize=None)
        def Q(n, p, q):
            if kind == "x" or p < 0 or q < 0:
                return 0.0
            if p == 0 and q == 0:
                return float(start.get("Q") == n)
            c3 = 3 / 2 if kind == "y" else 2.0
            return sum(binom(n, s) * (s / (n + 1) * Q(s, q - s - 1, p - n)
                                      - c3 / (n * s * (n + 1)) * P(s, q - s, p - n))
                       for s in range(first, q + 1))

        return P, Q

    def f(fn, n0, factor=1.0):
        return np.array([factor * 2.0**k * sum(fn(n0, k - q, q) for q in range(k + 1)) for k in range(order + 1)])

    pa, _ = make("x", {"P": 1, "V": 1})
    pb, qb = make("y", {"P": 1, "V": 1})
    pc, qc = make("y", {"Q": 1})
    pm, _ = make("x", {"P": 2, "V": 2})
    pn, _ = make("y", {"P": 2, "V": 2})
    pz, _ = make("z", {"P": 2, "V": 2})
    return {"XA": f(pa, 1), "XG": f(pa, 2, 0.75), "YA": f(pb, 1), "YB": f(qb, 1, 2.0), "YG": f(pb, 2, 0.75),
            "YC": f(qc, 1), "YH": f(pc, 2, -0.375), "XM": f(pm, 2), "YM": f(pn, 2), "ZM": f(pz, 2)}


def test_summed_recurrences_equal_the_three_index_form():
    order = 18
    printed = _three_index_coefficients(order)
    summed = tsf.series_coefficients(order)
    for name, values in printed.items():
        scale = np.maximum(1.0, np.abs(values))
        assert np.max(np.abs(summed[name] - values) / scale) < 1e-12, name
    # Ichiki's generated tables (libstokes XA.c, XG.c) at lambda = 1: f_3^XA = -4 + 27 - 4, f_5^XG = -168 + 405 + 360
    assert summed["XA"][3] == pytest.approx(19.0, abs=1e-12)
    assert summed["XG"][5] == pytest.approx(597.0, abs=1e-10)


def test_lowest_coefficients_are_single_reflections():
    """One sphere (1) moving with U, the other (2) held, t = a/(2r):

    - along d: 2 sees the Stokeslet 6 pi eta a U at r, velocity 3aU/(2r): force 9 pi eta a^2 U/r on 2,
      X^A_12 = -3/(2s) (f_1 = 3); its reaction back on 1 gives X^A_11 = 1 + 9/(4 s^2) (f_2 = 9);
      across d the Oseen tensor is half: Y^A_12 = -3/(4s), Y^A_11 = 1 + 9/(16 s^2);
    - the Stokeslet's vorticity at 2 turns it: torque 6 pi eta a^4 (d x U)/r^2, Y^B_12 = 3/(2 s^2)
      (-f_2 t^2 with f_2 = -6);
    - its strain (3aU/4r^2)(3dd - I) at 2 gives the Einstein stresslet 15 pi eta a^4 U/r^2 (dd - I/3):
      X^G_12 = -15/(4 s^2) (f_2 = 15); 2's reflected Stokeslet -9 pi eta a^2 U/r strains 1:
      X^G_11 = 45/(8 s^3) (f_3 = 45);
    - sphere 1 turning with Omega across d: the rotlet a^3 Omega x x / r^3 turns 2 at -a^3 Omega/(2r^3):
      Y^C_12 = 1/(2 s^3) (f_3 = 4)."""
    f = tsf.series_coefficients(6)
    assert f["XA"][:3] == pytest.approx([1.0, 3.0, 9.0])
    assert f["YA"][:3] == pytest.approx([1.0, 1.5, 2.25])
    assert f["YB"][:3] == pytest.approx([0.0, 0.0, -6.0])
    assert f["XG"][:4] == pytest.approx([0.0, 0.0, 15.0, 45.0])
    assert f["YC"][:4] == pytest.approx([1.0, 0.0, 0.0, 4.0])
    for name in ("XM", "YM", "ZM"):
        assert f[name][0] == 1.0 and f[name][1] == 0.0 and f[name][2] == 0.0
    s = 40.0
    sc = tsf.resistance_scalars(s)
    assert sc["XA"][1] == pytest.approx(-1.5 / s, rel=2e-3)
    assert sc["YB"][1] == pytest.approx(1.5 / s**2, rel=3e-2)
    assert sc["XG"][1] == pytest.approx(-15 / 4 / s**2, rel=2e-3)
    assert sc["YC"][1] == pytest.approx(0.5 / s**3, rel=1e-3)


@pytest.mark.parametrize("r", [2.5, 3.0, 4.0, 8.0])
def test_axial_translation_is_stimson_jeffery(r):
    sc = tsf.resistance_scalars(r)
    assert sc["XA"][0] + sc["XA"][1] == pytest.approx(stimson_jeffery(r), rel=1e-13)
    assert sc["XC"][0] + sc["XC"][1] == pytest.approx(corotation_torque(r), rel=1e-14)


@pytest.mark.parametrize("r", [2.5, 3.0, 6.0])
def test_doublet_friction_matches_two_spheres(r):
    out = tsf.doublet_flow(r, radius=0.7, viscosity=1.3)
    translation, rotation = doublet_mobility(r * 0.7, radius=0.7, viscosity=1.3)
    friction = out["friction"]
    assert friction[2, 2] == pytest.approx(1 / translation, rel=1e-13)
    assert friction[5, 5] == pytest.approx(1 / rotation, rel=1e-13)
    assert np.allclose(friction, friction.T, rtol=0, atol=1e-12 * np.abs(friction).max())
    assert np.all(np.linalg.eigvalsh(friction) > 0)


def test_counterrotation_limits():
    for r in (20.0, 40.0):
        assert tsf.counterrotation_torque(r) == pytest.approx(1 + r**-3, abs=4 * r**-6)
    # near contact X^C_11 - X^C_12 = zeta(3) - (1/4) xi ln(1/xi) + O(xi), xi = r/a - 2 (JO sec. 6,
    # Townsend 2018 eq. 26-27 at lambda = 1); co-rotation (3/4) zeta(3) + O(xi)
    for alpha in (1e-2, 1e-3):
        r = 2 * np.cosh(alpha)
        xi = r - 2
        assert tsf.counterrotation_torque(r) == pytest.approx(zeta(3) - 0.25 * xi * np.log(1 / xi), abs=2 * xi)
        assert corotation_torque(r) == pytest.approx(0.75 * zeta(3), abs=2 * xi)


@pytest.mark.parametrize("r", [2.5, 3.0, 6.0])
def test_grand_resistance_symmetric_positive(r):
    R = tsf.grand_resistance(r, radius=1.1, viscosity=0.9)
    assert np.abs(R - R.T).max() < 1e-13 * np.abs(R).max()
    assert np.linalg.eigvalsh(R).min() > 0.0


def test_grand_resistance_far_apart_is_two_single_spheres():
    a, eta = 0.5, 2.0
    R = tsf.grand_resistance(1e4, radius=a, viscosity=eta)
    single = np.diag([6 * np.pi * eta * a] * 3 + [8 * np.pi * eta * a**3] * 3 + [20 / 3 * np.pi * eta * a**3] * 5)
    order = [0, 1, 2, 6, 7, 8, 12, 13, 14, 15, 16]
    assert np.allclose(R[np.ix_(order, order)], single, rtol=2e-4, atol=1e-9)


@pytest.mark.parametrize("r", [2.5, 4.0, 10.0])
def test_doublet_pattern(r):
    out = tsf.doublet_flow(r)
    V, T, B = out["velocity_per_strain"], out["stresslet_per_strain"], out["bretherton"]
    expected = np.zeros((6, 5))
    expected[4, 1] = B / np.sqrt(2.0)          # E_2: E.p = e_x/sqrt2, p x (E.p) = e_y/sqrt2
    expected[3, 2] = -B / np.sqrt(2.0)         # E_3: E.p = e_y/sqrt2, p x (E.p) = -e_x/sqrt2
    assert np.abs(V - expected).max() < 1e-13
    assert np.abs(T - np.diag(np.diag(T))).max() < 1e-12 * T.max()
    assert T[0, 0] == pytest.approx(T[3, 3], rel=1e-13)
    assert T[1, 1] == pytest.approx(T[2, 2], rel=1e-13)
    assert np.all(np.linalg.eigvalsh(T) > 0)
    sc = tsf.resistance_scalars(r)             # a transverse strain moves nothing
    assert T[0, 0] == pytest.approx(2 * UNIT * (sc["ZM"][0] + sc["ZM"][1]), rel=1e-13)


def test_doublet_scaling():
    base = tsf.doublet_flow(3.0)
    scaled = tsf.doublet_flow(3.0, radius=2.0, viscosity=0.5)
    assert np.allclose(scaled["velocity_per_strain"], base["velocity_per_strain"], atol=1e-14)
    assert np.allclose(scaled["stresslet_per_strain"], 0.5 * 8.0 * base["stresslet_per_strain"], rtol=1e-13, atol=0)


@pytest.mark.parametrize("rho", [10.0, 20.0, 40.0])
def test_doublet_far_apart(rho):
    out = tsf.doublet_flow(rho)
    B = out["bretherton"]
    t = np.diag(out["stresslet_per_strain"]) / UNIT
    assert abs(B - (1 - 16 / 3 / rho**2 + 6 / rho**3)) < 30 / rho**4
    assert abs(t[1] - (2 + 1.2 * B)) < 9 / rho**3
    assert abs(t[0] - (2 - 4 / rho**5)) < 1 / rho**6      # Z^M_12 = -64 t^5 = -2 (a/r)^5
    assert abs(t[4] - (0.3 * rho**2 + 0.45 * rho + 27 / 40 + 2)) < 2.5 / rho


def test_isolated_spheres_limit():
    out = tsf.doublet_flow(1e3)
    t = np.diag(out["stresslet_per_strain"]) / UNIT
    assert t[0] == pytest.approx(2.0, abs=1e-12)
    assert t[1] == pytest.approx(2 + 6 / 5, abs=2e-5)      # (64/3) pi eta a^3
    assert out["bretherton"] == pytest.approx(1.0, abs=6e-6)


@pytest.mark.parametrize("r", sorted(TABLE))
def test_reference_table(r):
    out = tsf.doublet_flow(r)
    t = np.diag(out["stresslet_per_strain"]) / UNIT
    assert [out["bretherton"], t[0], t[1], t[4]] == pytest.approx(TABLE[r], rel=1e-13)
    half = tsf.doublet_flow(r, terms=out["terms"] // 2)
    th = np.diag(half["stresslet_per_strain"]) / UNIT
    assert np.max(np.abs(np.array([half["bretherton"], th[0], th[1], th[4]]) - TABLE[r])) < 2e-9


def test_bretherton_rises_toward_one():
    values = [tsf.doublet_flow(r)["bretherton"] for r in (2.5, 3.0, 4.0, 6.0, 10.0, 30.0)]
    assert np.all(np.diff(values) > 0) and 0.6 < values[0] and values[-1] < 1.0


def test_refusals():
    with pytest.raises(ValueError):
        tsf.doublet_flow(2.0)
    with pytest.raises(ValueError):
        tsf.series_coefficients(tsf.MAX_TERMS + 1)
