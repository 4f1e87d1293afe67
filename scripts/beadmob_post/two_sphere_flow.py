"""Two equal spheres rigidly joined into one body (a doublet) in an ambient linear flow: its
rotation and stresslet per unit strain, from the exact two-sphere resistance functions. A
reference for beadmob's flow computation that does not use beadmob's multipole method.

Geometry and conventions (those of the Fortran side and of ellipsoid.py): spheres of radius a at
-+(r/2) e_z, viscosity eta, strain modes E_1 = (xy+yx)/sqrt2, E_2 = (xz+zx)/sqrt2,
E_3 = (yz+zy)/sqrt2, E_4 = (xx-yy)/sqrt2, E_5 = (2zz-xx-yy)/sqrt6 (orthonormal under A:B), ambient
flow u_inf = U_inf + Omega_inf x x + E.x about the doublet's centre, E = sum_k e_k E_k. The
force- and torque-free doublet moves with U = U_inf + V[0:3] e, Omega = Omega_inf + V[3:6] e and
carries the stresslet (Batchelor 1970, J. Fluid Mech. 41, 545: the symmetric first moment of the
traction the fluid exerts on the body) s = T e.

1. Two-sphere resistance functions (equal spheres, lambda = 1, s = r/a). In the notation of
   Jeffrey & Onishi (1984, J. Fluid Mech. 139, 261; "JO") and Jeffrey (1992, Phys. Fluids A 4, 16;
   "J92") the forces, torques and stresslets on the spheres are

       (F, L, S)_alpha = eta sum_beta R^(alpha beta) . (U_inf(x_beta) - U_beta, Omega_inf - Omega_beta, E)

   with d the unit vector from sphere alpha to the other sphere and (the tensor forms defined in
   JO and J92)
       A = X^A dd + Y^A (I - dd)                      (force from translation),       scale 6 pi a
       B_ij = Y^B eps_ijk d_k                          (torque from translation),      scale 4 pi a^2
       C = X^C dd + Y^C (I - dd)                      (torque from rotation),         scale 8 pi a^3
       G_ijk = X^G (d_i d_j - delta_ij/3) d_k + Y^G (d_i delta_jk + d_j delta_ik - 2 d_i d_j d_k)
                                                       (stresslet from translation),   scale 4 pi a^2
       H_ijk = Y^H (eps_ikl d_l d_j + eps_jkl d_l d_i) (stresslet from rotation),      scale 8 pi a^3
       M = X^M d0 + Y^M d1 + Z^M d2                   (stresslet from strain),        scale 20/3 pi a^3
   (JO's scales 3 pi (a_1 + a_2), pi (a_1 + a_2)^2, ... at a_1 = a_2; d0, d1, d2 as in J92, with
   d0 + d1 + d2 the identity on symmetric traceless tensors), and the rest by reciprocity (force
   from rotation = B^T, force from strain = G^T, torque from strain = H^T): the 22x22 matrix is
   symmetric and positive definite. The signs were checked against single reflections and Wilson's
   independent values (tests).

   Far-field series (JO's form f_k / ((1 + lambda) s)^k at lambda = 1), t = a/(2r) = 1/(2s):
       X^A_11 = sum_{k even} f_k t^k,  X^A_12 = -sum_{k odd} f_k t^k       (Y^A alike)
       Y^B_11 = sum_odd,  Y^B_12 = -sum_even;   Y^C_11 = sum_even,  Y^C_12 = +sum_odd
       X^G_11 = sum_odd,  X^G_12 = -sum_even    (Y^G alike);   Y^H_11 = sum_even, Y^H_12 = +sum_odd
       X^M_11 = sum_even, X^M_12 = +sum_odd     (Y^M alike);   Z^M_11 = sum_even, Z^M_12 = -sum_odd
   (for unequal spheres the 12 sums also carry powers of 2/(1 + lambda)). The coefficients
   f_k(lambda) = 2^k sum_q X_{n (k-q) q} lambda^q come from the twin-multipole recurrences for
   P_npq, V_npq, Q_npq, started at (n, 0, 0): X^A = P at n = 1 of JO's X^A recurrence (JO sec. 3;
   Townsend 2018, arXiv:1802.08226, eq. 5-9, which corrects JO's misprints), X^G = (3/4) P at n = 2
   of the same (Ichiki et al. 2013, arXiv:1302.0461, eq. 94); Y^A = P, Y^B = 2 Q at n = 1 of JO
   eq. 4.6-4.11 (Townsend eq. 18, 21), Y^G = (3/4) P at n = 2 (Ichiki eq. 115); Y^C = Q at n = 1 of
   the same recurrence started from Q (JO eq. 7.3-7.5, Townsend eq. 29), Y^H = -(3/8) P at n = 2
   (Ichiki eq. 120); X^M, Y^M = P at n = 2 of the X^A / Y^A recurrences started at n = 2 (J92
   eq. 58; Ichiki eq. 104-105, 125); Z^M from J92 eq. 73-76 (Ichiki eq. 131). (Equation numbers as
   cross-referenced by Townsend 2018 and its script; the recurrences are written out in
   _recurrence.)
   For lambda = 1 the recurrences need only the sums P~_n(k) = sum_{p+q=k} P_npq: their
   coefficients depend on n and the summed index only, so summing the three-index recurrence over
   p + q = k closes it on P~ (this is exact; it turns O(K^4) work into O(K^3)). The series
   converge like (2a/r)^k (contact is their singularity): the default number of terms K gives
   (2a/r)^K < 1e-16, 170 terms at r = 2.5a.

   X^C (rotation about the line of centres) comes from Jeffery's (1915) bispherical swirl
   (two_spheres.py): co-rotation X^C_11 + X^C_12 = f_C = 4 sinh^3(alpha) sum n(n+1)/(e^((2n+1)alpha)+1),
   counter-rotation X^C_11 - X^C_12 = 4 sinh^3(alpha) sum n(n+1)/(e^((2n+1)alpha)-1) (the same
   method with f_n odd in xi). It does not enter V or T (nothing in a strain turns the doublet
   about its axis); it completes the matrix. Contact limits (7/8) zeta(3) and -zeta(3)/8 (JO
   sec. 6; Townsend 2018 eq. 26-27).

2. The rigid doublet (derivation here). With Delta = (U - U_inf, Omega - Omega_inf), sphere
   alpha's velocity relative to the ambient flow at its centre is
   U_inf(x_alpha) - U_alpha = E.x_alpha - Delta_U - Delta_Omega x x_alpha, its rotation relative to
   the ambient -Delta_Omega. Writing y = W e - Sigma Delta for these 12 numbers (W e: the strain's
   E.x_alpha; Sigma: the rigid-body map), the free-body conditions
   Sigma^T (R_FF y + R_FE e) = 0 (total force, and torque about the centre, zero) give

       V = (Sigma^T R_FF Sigma)^-1 Sigma^T (R_FF W + R_FE),

   and the doublet's stresslet is the spheres' stresslets plus the symmetric traceless first
   moment of their forces about the centre, s_l = sum_alpha [S_alpha,l + x_alpha . E_l . F_alpha]:

       T = R_SE + R_SF (W - Sigma V) + W^T (R_FF (W - Sigma V) + R_FE),

   a Schur complement of the positive definite two-sphere matrix: symmetric, positive definite.
   By the doublet's symmetry (axisymmetric, fore-aft symmetric) V has only
   Omega - Omega_inf = B p x (E.p), p = e_z (Bretherton 1962's constant B), and T is diagonal with
   T_11 = T_44 (transverse strains), T_22 = T_33 (the xz, yz shears) and T_55 (axial extension).

   Limits (derived here; checked in tests/python/test_two_sphere_flow.py). Far apart, torque
   balance of the two Stokes drags 6 pi eta a on the arm r/2 (with their Oseen interaction,
   resistance 1 + 3a/(4r) for opposite transverse motion) against the spheres' rotary drag
   8 pi eta a^3 (reduced by the rotlet of each sphere dragging the other, a force 6 pi eta a^4
   Delta_Omega / r^2 on the arm r/2) gives 1 - B = (16/3)(a/r)^2 B (1 - 3a/(4r)) (1 - 3a/(8r)):
       B = 1 - (16/3)(a/r)^2 + 6 (a/r)^3 + O((a/r)^4);
   T_11 = T_44 = (40/3) pi eta a^3 (Z^M_11 + Z^M_12) exactly (a transverse strain moves nothing);
   T_22 = T_33 = (20/3) pi eta a^3 (2 + (6/5) B) + O(a^3 (a/r)^3) (two Einstein stresslets plus the
   force dipole 16 pi eta a^3 B sym(p (E.p)) that balances the spheres' rotary torque), so
   T_22 -> (64/3) pi eta a^3; T_55 = 2 pi eta a r^2 (1 + 3a/(2r) + 9a^2/(4r^2)) + (40/3) pi eta a^3
   + O(a^4/r) (the axial force dipole of a rod that cannot stretch, with X^A_11 - X^A_12).
   Toward contact (400 terms) B = 0.6102818 at r = 2.1a, 0.602281 at 2.05a, about 0.5957 at
   2.01a (there the series are no longer converged: +-1e-4); a 2:1 spheroid has B = 0.6.

Reference table (eta = a = 1; T in units of (20/3) pi eta a^3; K = default_terms(r/a) series
terms; the numbers change by at most the "K/2" column when K/2 terms are used and not at all
(to the digits shown) with 2K; reference_table() recomputes it):

    r/a    K   B                  T_11 = T_44        T_22 = T_33        T_55               K/2
    2.5  170   0.667345875423615  1.963718518994716  2.496252320335530  4.837210358392880  4e-10
    3     96   0.724360616378102  1.984582976731173  2.655213198299416  5.984676761710165  6e-10
    4     58   0.805366275376166  1.996194387138847  2.859177266651000  8.684434458393314  6e-10
    6     38   0.892339611089492  1.999489412988909  3.035756573843650  15.766673705601521 5e-10
    10    27   0.954783993766200  1.999960063090517  3.137871306401701  36.929918341024489 1e-9
"""

from __future__ import annotations

import numpy as np
from scipy.special import comb

from beadmob_post.ellipsoid import strain_modes
from beadmob_post.two_spheres import corotation_torque

_SQRT2 = np.sqrt(2.0)

#: Names of the 22 scalar resistance functions (11 and 12 of each), JO / J92 normalisation.
SCALAR_NAMES = ("XA", "YA", "YB", "XC", "YC", "XG", "YG", "YH", "XM", "YM", "ZM")

# Parity of the 11 series and sign of the 12 series (lambda = 1; module docstring, item 1).
_SERIES_FORM = {
    "XA": (0, -1.0), "YA": (0, -1.0), "YB": (1, -1.0), "YC": (0, 1.0), "XG": (1, -1.0),
    "YG": (1, -1.0), "YH": (0, 1.0), "XM": (0, 1.0), "YM": (0, 1.0), "ZM": (0, -1.0),
}




#: Largest number of series terms (beyond it the coefficients overflow double precision).
MAX_TERMS = 400


def default_terms(distance_over_radius: float) -> int:
    """K with (2a/r)^K < 1e-16 (at least 24, at most MAX_TERMS): the terms fall like (2a/r)^k.
    MAX_TERMS still leaves (2a/r)^K = 3e-9 at r = 2.1a; the series fail at contact."""
    ratio = float(distance_over_radius) / 2.0
    if not ratio > 1.0:
        raise ValueError(f"the series need r/a > 2, got {distance_over_radius}")
    return min(MAX_TERMS, max(24, int(np.ceil(37.0 / np.log(ratio))) + 4))


def _recurrence(kind: str, order: int, start: dict[str, int]) -> tuple[np.ndarray, np.ndarray]:
    """P~_n(k), Q~_n(k) (k = 0..order) of one twin-multipole recurrence summed over p + q = k.

    kind "x": JO's X^A recurrence (Townsend eq. 5-8); "y": JO eq. 4.6-4.11 (Townsend eq. 18); "z":
    J92 eq. 73-76 (sums from s = 2). In the three-index form the children of P_npq are
    P_{s, q-s, p-n+-1}, V_{s, q-s-2, p-n+1}, Q_{s, q-s-1, p-n+1} (and Q_npq's are Q_{s, q-s-1, p-n},
    P_{s, q-s, p-n}); summed over p + q = k they are P~_s(k-n-s+-1), V~_s(k-n-s-1), Q~_s(k-n-s)
    (Q~_s(k-n-s-1), P~_s(k-n-s)). start: which of P, V, Q are 1 at (n, 0, 0)."""
    size = order + 3                                    # n = 0 .. order + 2 (n + k <= order + 2)
    n = np.arange(size, dtype=float)[:, None]
    s = np.arange(size, dtype=float)[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        if kind == "x":                                 # JO sec. 3 / Townsend (5)-(8)
            c = comb(n + s, n)
            coef = {
                "P+": c * n * (2 * n + 1) * (2 * n * s - n - s + 2) / (2 * (n + 1) * (2 * s - 1) * (n + s)),
                "P-": -c * n * (2 * n - 1) / (2 * (n + 1)),
                "V-": -c * n * (4 * n * n - 1) / (2 * (n + 1) * (2 * s + 1)),
                "v": -c * 2 * n / ((n + 1) * (2 * n + 3)),
            }
        elif kind == "y":                               # JO (4.6)-(4.11)
            c = comb(n + s, n + 1)
            coef = {
                "P+": c * (2 * n + 1) / (2 * (n + 1)) * (3 * (n + s) - (n * s + 1) * (2 * n * s - s - n + 2))
                / (s * (n + s) * (2 * s - 1)),
                "P-": c * n * (2 * n - 1) / (2 * (n + 1)),
                "V-": c * n * (4 * n * n - 1) / (2 * (n + 1) * (2 * s + 1)),
                "Q0": -c * 2 * (4 * n * n - 1) / (3 * (n + 1)),
                "qQ": c * s / (n + 1),
                "qP": -c * 3 / (2 * n * s * (n + 1)),
                "v": c * 2 * n / ((n + 1) * (2 * n + 3)),
            }
        else:                                           # J92 (73)-(76)
            c = comb(n + s, n + 2)
            coef = {
                "P+": c * (2 * n + 1) / (n + 1)
                * (n * s * (n + s - 2 * n * s - 2) - 4 * (2 * n * s - 4 * s - 4 * n + 2))
                / (2 * s * (n + s) * (2 * s - 1)),
                "P-": c * n * (2 * n - 1) / (2 * (n + 1)),
                "V-": c * n * (2 * n + 1) * (2 * n - 1) / (2 * (n + 1) * (2 * s + 1)),
                "Q0": -c * 2 * (2 * n + 1) * (2 * n - 1) / (n + 1),
                "qQ": c * s / (n + 1),
                "qP": -c * 2 / (n * s * (n + 1)),
                "v": c * 2 * n / ((n + 1) * (2 * n + 3)),
            }
    first_s = 2 if kind == "z" else 1
    for value in coef.values():
        value[~np.isfinite(value)] = 0.0
        value[0, :] = 0.0
        value[:, :first_s] = 0.0
    # columns k = 0 .. order; column order + 1 stays zero and stands for every negative index
    P, V, Q = (np.zeros((size, order + 2)) for _ in range(3))
    for name, n0 in start.items():
        {"P": P, "V": V, "Q": Q}[name][n0, 0] = 1.0
    zero = order + 1
    for k in range(1, order + 1):
        nn = np.arange(1, order + 3 - k)[:, None]      # n + k <= order + 2 is all that is needed
        ss = np.arange(1, k + 2)[None, :]               # children have k - n - s + 1 >= 0
        base = k - nn - ss
        rows = np.broadcast_to(ss, base.shape)
        block = (slice(1, order + 3 - k), slice(1, k + 2))

        def child(array, shift, rows=rows, base=base):
            j = base + shift
            return array[rows, np.where(j >= 0, j, zero)]

        p_minus = child(P, -1)
        total = coef["P+"][block] * child(P, 1) + coef["P-"][block] * p_minus + coef["V-"][block] * child(V, -1)
        if kind != "x":
            total += coef["Q0"][block] * child(Q, 0)
            Q[1:order + 3 - k, k] = (coef["qQ"][block] * child(Q, -1) + coef["qP"][block] * child(P, 0)).sum(axis=1)
        P[1:order + 3 - k, k] = total.sum(axis=1)
        V[1:order + 3 - k, k] = P[1:order + 3 - k, k] + (coef["v"][block] * p_minus).sum(axis=1)
    return P[:, :order + 1], Q[:, :order + 1]


_COEFFICIENTS: dict[str, np.ndarray] = {}


def _compute_coefficients(order: int) -> dict[str, np.ndarray]:
    power = 2.0 ** np.arange(order + 1)
    pa, _ = _recurrence("x", order, {"P": 1, "V": 1})       # X^A, X^G
    pb, qb = _recurrence("y", order, {"P": 1, "V": 1})      # Y^A, Y^B, Y^G
    pc, qc = _recurrence("y", order, {"Q": 1})              # Y^C, Y^H
    pm, _ = _recurrence("x", order, {"P": 2, "V": 2})       # X^M
    pn, _ = _recurrence("y", order, {"P": 2, "V": 2})       # Y^M
    pz, _ = _recurrence("z", order, {"P": 2, "V": 2})       # Z^M
    return {
        "XA": power * pa[1], "XG": 0.75 * power * pa[2],
        "YA": power * pb[1], "YB": 2.0 * power * qb[1], "YG": 0.75 * power * pb[2],
        "YC": power * qc[1], "YH": -0.375 * power * pc[2],
        "XM": power * pm[2], "YM": power * pn[2], "ZM": power * pz[2],
    }


def series_coefficients(order: int) -> dict[str, np.ndarray]:
    """f_k (k = 0..order) of the ten series functions for equal spheres (module docstring, item 1).
    Computed once for at least 180 terms (enough for r >= 2.5a) and kept: f_k does not depend on
    how many terms are computed."""
    order = int(order)
    if not 1 <= order <= MAX_TERMS:
        raise ValueError(f"the series take 1 ... {MAX_TERMS} terms, got {order}")
    if not _COEFFICIENTS or len(_COEFFICIENTS["XA"]) <= order:
        _COEFFICIENTS.update(_compute_coefficients(max(order, 180)))
    return {name: values[:order + 1].copy() for name, values in _COEFFICIENTS.items()}


def counterrotation_torque(distance: float, radius: float = 1.0) -> float:
    """Torque per sphere / (8 pi eta a^3 Omega) of two equal spheres turning with opposite angular
    velocities about their line of centres (Jeffery 1915's swirl with f_n odd in xi:
    4 sinh^3(alpha) sum n(n+1) / (e^((2n+1) alpha) - 1))."""
    ratio = float(distance) / (2.0 * float(radius))
    if not ratio > 1.0:
        raise ValueError(f"two spheres of radius {radius} need a centre distance > {2 * radius}, got {distance}")
    alpha = float(np.arccosh(ratio))
    n = np.arange(1, int(np.ceil(45.0 / alpha)) + 11, dtype=float)     # e^(-(2n+1) alpha) < 1e-18
    series = n * (n + 1.0) / np.expm1((2.0 * n + 1.0) * alpha)
    return float(4.0 * np.sinh(alpha) ** 3 * np.sum(series[::-1]))


def resistance_scalars(distance_over_radius: float, terms: int | None = None) -> dict[str, tuple[float, float]]:
    """The 22 resistance functions of two equal spheres, {name: (11, 12)}, in JO / J92's
    normalisation (divide the dimensional values by eta times 6 pi a, 4 pi a^2, 8 pi a^3, 4 pi a^2,
    8 pi a^3, 20/3 pi a^3 for A, B, C, G, H, M)."""
    s = float(distance_over_radius)
    order = default_terms(s) if terms is None else int(terms)
    coefficients = series_coefficients(order)
    k = np.arange(order + 1)
    powers = (0.5 / s) ** k
    out = {}
    for name, (parity, sign) in _SERIES_FORM.items():
        term = coefficients[name] * powers
        same = (k % 2) == parity
        out[name] = (float(np.sum(term[same][::-1])), sign * float(np.sum(term[~same][::-1])))
    co, counter = corotation_torque(s, 1.0), counterrotation_torque(s, 1.0)
    out["XC"] = (0.5 * (co + counter), 0.5 * (co - counter))
    return {name: out[name] for name in SCALAR_NAMES}


def _eps() -> np.ndarray:
    e = np.zeros((3, 3, 3))
    e[0, 1, 2] = e[1, 2, 0] = e[2, 0, 1] = 1.0
    e[0, 2, 1] = e[2, 1, 0] = e[1, 0, 2] = -1.0
    return e


def _blocks(x_a, y_a, y_b, x_c, y_c, x_g, y_g, y_h, x_m, y_m, z_m, d):
    """One pair's tensors (the forms of JO and J92) with d from the sphere whose force, torque
    and stresslet they give towards the other sphere; G, H, M in the five strain modes."""
    i3 = np.eye(3)
    dd = np.outer(d, d)
    eps = _eps()
    modes = strain_modes()
    a = x_a * dd + y_a * (i3 - dd)
    b = y_b * np.einsum("ijk,k->ij", eps, d)
    c = x_c * dd + y_c * (i3 - dd)
    g = (x_g * np.einsum("ij,k->ijk", dd - i3 / 3.0, d)
         + y_g * (np.einsum("i,jk->ijk", d, i3) + np.einsum("j,ik->ijk", d, i3) - 2.0 * np.einsum("ij,k->ijk", dd, d)))
    h = y_h * (np.einsum("ikl,l,j->ijk", eps, d, d) + np.einsum("jkl,l,i->ijk", eps, d, d))
    dev = dd - i3 / 3.0
    d0 = 1.5 * np.einsum("ij,kl->ijkl", dev, dev)
    d1 = 0.5 * (np.einsum("i,jl,k->ijkl", d, i3, d) + np.einsum("j,il,k->ijkl", d, i3, d)
                + np.einsum("i,jk,l->ijkl", d, i3, d) + np.einsum("j,ik,l->ijkl", d, i3, d)) \
        - 2.0 * np.einsum("ij,kl->ijkl", dd, dd)
    d2 = 0.5 * (np.einsum("ik,jl->ijkl", i3, i3) + np.einsum("jk,il->ijkl", i3, i3) - np.einsum("ij,kl->ijkl", i3, i3)
                + np.einsum("ij,kl->ijkl", dd, i3) + np.einsum("ij,kl->ijkl", i3, dd)
                - np.einsum("i,jl,k->ijkl", d, i3, d) - np.einsum("j,il,k->ijkl", d, i3, d)
                - np.einsum("i,jk,l->ijkl", d, i3, d) - np.einsum("j,ik,l->ijkl", d, i3, d)
                + np.einsum("ij,kl->ijkl", dd, dd))
    m = x_m * d0 + y_m * d1 + z_m * d2
    g5 = np.einsum("lij,ijk->lk", modes, g)
    h5 = np.einsum("lij,ijk->lk", modes, h)
    m5 = np.einsum("lij,ijkm,nkm->ln", modes, m, modes)
    return a, b, c, g5, h5, m5


def grand_resistance(distance_over_radius: float, radius: float = 1.0, viscosity: float = 1.0,
                     terms: int | None = None) -> np.ndarray:
    """The 22x22 resistance of two equal spheres at -+(r/2) e_z: rows (F_1, F_2, L_1, L_2, S_1, S_2)
    exerted by the fluid on the spheres, columns (U_inf(x_1) - U_1, U_inf(x_2) - U_2,
    Omega_inf - Omega_1, Omega_inf - Omega_2, e_1, e_2) with the strain e_beta seen by sphere beta
    (a common ambient strain has e_1 = e_2); S and e in the five strain modes."""
    scalars = resistance_scalars(distance_over_radius, terms)
    a_, eta = float(radius), float(viscosity)
    scale = {"A": 6 * np.pi * a_, "B": 4 * np.pi * a_**2, "C": 8 * np.pi * a_**3,
             "G": 4 * np.pi * a_**2, "H": 8 * np.pi * a_**3, "M": 20.0 / 3.0 * np.pi * a_**3}
    units = [scale[name[1]] for name in SCALAR_NAMES]
    self_pair = [eta * u * scalars[name][0] for u, name in zip(units, SCALAR_NAMES)]
    other_pair = [eta * u * scalars[name][1] for u, name in zip(units, SCALAR_NAMES)]
    ez = np.array([0.0, 0.0, 1.0])
    towards_other = (ez, -ez)                    # sphere 1 at -r/2 e_z sees sphere 2 along +e_z
    R = np.zeros((22, 22))
    force = (slice(0, 3), slice(3, 6))
    torque = (slice(6, 9), slice(9, 12))
    strain = (slice(12, 17), slice(17, 22))
    for i in range(2):
        for j in range(2):
            a, b, c, g5, h5, m5 = _blocks(*(self_pair if i == j else other_pair), towards_other[i])
            R[force[i], force[j]] = a
            R[torque[i], force[j]] = b
            R[torque[i], torque[j]] = c
            R[strain[i], force[j]] = g5
            R[strain[i], torque[j]] = h5
            R[strain[i], strain[j]] = m5
    for i in range(2):                           # reciprocity: force from rotation, force and torque from strain
        for j in range(2):
            R[force[i], torque[j]] = R[torque[j], force[i]].T
            R[force[i], strain[j]] = R[strain[j], force[i]].T
            R[torque[i], strain[j]] = R[strain[j], torque[i]].T
    return R


def _skew(v) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def doublet_flow(distance_over_radius: float, radius: float = 1.0, viscosity: float = 1.0,
                 terms: int | None = None) -> dict:
    """The force- and torque-free rigid doublet (spheres of radius a at -+(r/2) e_z) in
    u_inf = U_inf + Omega_inf x x + E.x: bretherton B, velocity_per_strain V (6, 5) with
    (U - U_inf, Omega - Omega_inf) = V e, stresslet_per_strain T (5, 5) with s = T e, friction (6, 6)
    (force and torque about the centre against U and Omega of the doublet at rest in still fluid,
    a positive matrix) and terms, the number of series terms used (module docstring, item 2).
    distance_over_radius is r/a (> 2)."""
    rho = float(distance_over_radius)
    order = default_terms(rho) if terms is None else int(terms)
    a_ = float(radius)
    R = grand_resistance(rho, a_, viscosity, order)
    centres = (np.array([0.0, 0.0, -0.5 * rho * a_]), np.array([0.0, 0.0, 0.5 * rho * a_]))
    modes = strain_modes()
    sigma = np.zeros((12, 6))
    w = np.zeros((12, 5))
    for i, x in enumerate(centres):
        sigma[3 * i:3 * i + 3, 0:3] = np.eye(3)
        sigma[3 * i:3 * i + 3, 3:6] = -_skew(x)          # Delta_Omega x x = -x x Delta_Omega
        sigma[6 + 3 * i:9 + 3 * i, 3:6] = np.eye(3)
        w[3 * i:3 * i + 3, :] = np.einsum("lij,j->il", modes, x)
    r_ff = R[:12, :12]
    r_fe = R[:12, 12:17] + R[:12, 17:22]
    r_sf = R[12:17, :12] + R[17:22, :12]
    r_se = R[12:17, 12:17] + R[12:17, 17:22] + R[17:22, 12:17] + R[17:22, 17:22]
    velocity = np.linalg.solve(sigma.T @ r_ff @ sigma, sigma.T @ (r_ff @ w + r_fe))
    relative = w - sigma @ velocity
    stresslet = r_se + r_sf @ relative + w.T @ (r_ff @ relative + r_fe)
    stresslet = 0.5 * (stresslet + stresslet.T)
    return {
        "bretherton": float(0.5 * _SQRT2 * (velocity[4, 1] - velocity[3, 2])),
        "velocity_per_strain": velocity,
        "stresslet_per_strain": stresslet,
        "friction": sigma.T @ r_ff @ sigma,
        "terms": order,
    }


def reference_table(separations=(2.5, 3.0, 4.0, 6.0, 10.0)) -> list[dict]:
    """B and T's diagonal values (units (20/3) pi eta a^3) at each r/a with K = default_terms(r/a)
    series terms, and the largest change of these four numbers with K/2 and with 2K terms."""
    unit = 20.0 / 3.0 * np.pi
    rows = []
    for rho in separations:
        order = default_terms(rho)
        values = {}
        for k in (order // 2, order, min(2 * order, MAX_TERMS)):
            out = doublet_flow(rho, terms=k)
            t = np.diag(out["stresslet_per_strain"]) / unit
            values[k] = np.array([out["bretherton"], t[0], t[1], t[4]])
        best = values[order]
        rows.append({"r_over_a": rho, "terms": order, "bretherton": best[0], "T11": best[1],
                     "T22": best[2], "T55": best[3],
                     "change_half_terms": float(np.max(np.abs(values[order // 2] - best))),
                     "change_double_terms": float(np.max(np.abs(values[min(2 * order, MAX_TERMS)] - best)))})
    return rows


__all__ = [
    "SCALAR_NAMES", "strain_modes", "default_terms", "series_coefficients", "counterrotation_torque",
    "resistance_scalars", "grand_resistance", "doublet_flow", "reference_table",
]
