"""Exact Stokes friction of a rigid ellipsoid (the continuum reference of docs/theory.md T18),
and its motion and stresslet in an ambient linear flow.

Functions: shape_integrals, ellipsoid_friction (friction); strain_modes, strain_amplitudes,
strain_tensor, strain_rotation (strain conventions); pair_integrals, ellipsoid_flow,
intrinsic_viscosity (linear flow).

Friction. For semi-axes a_1, a_2, a_3 along the body axes and viscosity eta, with
Delta(l) = sqrt((a_1^2 + l)(a_2^2 + l)(a_3^2 + l)) and the integrals

    chi = int_0^inf dl / Delta(l),     alpha_i = int_0^inf dl / ((a_i^2 + l) Delta(l)),

the force on a translating ellipsoid (Oberbeck 1876) and the torque on a rotating one (Jeffery
1922) are diagonal in the principal frame:

    F_i = 16 pi eta U_i / (chi + a_i^2 alpha_i),
    T_i = 16 pi eta (a_j^2 + a_k^2) Omega_i / (3 (a_j^2 alpha_j + a_k^2 alpha_k)),  (i, j, k) cyclic,

and translation and rotation do not couple (three mirror planes). The integrals are Carlson's
symmetric elliptic integrals: chi = 2 R_F(a_1^2, a_2^2, a_3^2) and
alpha_i = (2/3) R_D(a_j^2, a_k^2, a_i^2) (DLMF 19.16.1-2 with t = l).

Strain conventions (those of the Fortran side). Five modes, orthonormal under
A:B = sum_ij A_ij B_ij,

    E_1 = (xy + yx)/sqrt2,  E_2 = (xz + zx)/sqrt2,  E_3 = (yz + zy)/sqrt2,
    E_4 = (xx - yy)/sqrt2,  E_5 = (2 zz - xx - yy)/sqrt6,

carry a symmetric traceless E = sum_k e_k E_k; a rotation Q maps the amplitudes of E to those of
Q E Q^T by D_kl = E_k : (Q E_l Q^T).

Linear flow. In u_inf(r) = U_inf + Omega_inf x r + E.r about the centre, the force- and
torque-free ellipsoid has U = U_inf + V[0:3] e, Omega = Omega_inf + V[3:6] e and the stresslet
(Batchelor 1970, J. Fluid Mech. 41, 545: S = int sym(x (sigma.n)) dS) s = T e. In its axes:

- no translation (V[0:3] = 0: the problem is odd under r -> -r), and Jeffery's (1922, Proc. R.
  Soc. A 102, 161) rotation Omega_i - Omega_inf_i = (a_j^2 - a_k^2)/(a_j^2 + a_k^2) E_jk,
  (i, j, k) cyclic;
- with beta_ij = int_0^inf dl / ((a_i^2 + l)(a_j^2 + l) Delta(l)) (for i != j Jeffery's primed
  integrals) and V_p = 4 pi a_1 a_2 a_3 / 3,

      S_ij = 16 pi eta E_ij / (3 (a_i^2 + a_j^2) beta_ij)                     (i != j),
      diag(S) = 2 eta V_p (M on traceless diagonals)^-1 diag(E),
      M_ii = (3/2) a_1 a_2 a_3 a_i^2 beta_ii,   M_ij = (1/2) a_1 a_2 a_3 a_j^2 beta_ij.

  This is Eshelby's equivalent inclusion (Eshelby 1957, Proc. R. Soc. A 241, 376; the tensor as
  in Mura 1987, Micromechanics of Defects in Solids, section 11) at Poisson ratio 1/2: Stokes flow
  is incompressible elasticity with eta for the shear modulus, the free rigid body an inclusion
  of zero strain rate whose eigenstrain eps* solves S^Esh : eps* = -E, and S = -2 eta V_p eps*.
  M_ij is S^Esh_iijj; it maps traceless diagonals to traceless diagonals (its columns sum to 1).
  A sphere gives S = (20/3) pi eta a^3 E (Einstein) and no rotation.

beta_ij (i != j) equals (alpha_j - alpha_i)/(a_i^2 - a_j^2); it is computed from Carlson's
duplication theorem without that cancellation (exact also for a_i = a_j), and beta_ii from
3 a_i^2 beta_ii + a_j^2 beta_ij + a_k^2 beta_ik = 3 alpha_i (Mura 1987 section 11).

Intrinsic viscosity. Over isotropic orientations <D T D^T> = tr(T)/5 I_5 (the five-dimensional
representation is irreducible), so n = phi / V_p free particles per volume add tr(T)/5 n E to the
stress: eta_eff = eta (1 + [eta] phi) with [eta] = tr(T) / (10 eta V_p), 5/2 for spheres. This is
the purely hydrodynamic value (no rotary-Brownian stress); for spheroids it equals the terms of
Simha's (1940, J. Phys. Chem. 44, 25) formula other than the rotary-diffusion one.
"""

from __future__ import annotations

import numpy as np
from scipy.special import elliprd, elliprf


def shape_integrals(semi_axes) -> tuple[float, np.ndarray]:
    """chi and (alpha_1, alpha_2, alpha_3) of the ellipsoid with these semi-axes."""
    squares = np.asarray(semi_axes, dtype=float) ** 2
    if squares.shape != (3,) or not np.all(squares > 0):
        raise ValueError(f"an ellipsoid needs three positive semi-axes, got {semi_axes!r}")
    chi = 2.0 * elliprf(*squares)
    alpha = np.array([2.0 / 3.0 * elliprd(squares[(i + 1) % 3], squares[(i + 2) % 3], squares[i]) for i in range(3)])
    return float(chi), alpha


def ellipsoid_friction(semi_axes, viscosity: float = 1.0) -> np.ndarray:
    """The 6x6 friction (rows force, torque; columns velocity, angular velocity) about the
    centre, in the frame of the semi-axes."""
    squares = np.asarray(semi_axes, dtype=float) ** 2
    chi, alpha = shape_integrals(semi_axes)
    friction = np.zeros((6, 6))
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        friction[i, i] = 16.0 * np.pi * viscosity / (chi + squares[i] * alpha[i])
        friction[3 + i, 3 + i] = (16.0 * np.pi * viscosity * (squares[j] + squares[k])
                                  / (3.0 * (squares[j] * alpha[j] + squares[k] * alpha[k])))
    return friction


# --- strain modes -------------------------------------------------------------------------------

_SQRT2, _SQRT6 = np.sqrt(2.0), np.sqrt(6.0)


def strain_modes() -> np.ndarray:
    """The five orthonormal symmetric traceless modes E_1..E_5, shape (5, 3, 3) (module docstring)."""
    x, y, z = np.eye(3)
    o = np.outer
    return np.array([
        (o(x, y) + o(y, x)) / _SQRT2,
        (o(x, z) + o(z, x)) / _SQRT2,
        (o(y, z) + o(z, y)) / _SQRT2,
        (o(x, x) - o(y, y)) / _SQRT2,
        (2.0 * o(z, z) - o(x, x) - o(y, y)) / _SQRT6,
    ])


def strain_amplitudes(tensor) -> np.ndarray:
    """The amplitudes e_k = E_k : A of a symmetric traceless 3x3 tensor A (A = sum_k e_k E_k)."""
    tensor = np.asarray(tensor, dtype=float)
    if tensor.shape != (3, 3):
        raise ValueError(f"a strain is a 3x3 tensor, got shape {tensor.shape}")
    scale = max(np.abs(tensor).max(), np.finfo(float).tiny)
    if np.abs(tensor - tensor.T).max() > 1e-10 * scale or abs(np.trace(tensor)) > 1e-10 * scale:
        raise ValueError("a strain must be symmetric and traceless")
    return np.einsum("kij,ij->k", strain_modes(), tensor)


def strain_tensor(amplitudes) -> np.ndarray:
    """The symmetric traceless tensor sum_k e_k E_k of five amplitudes."""
    amplitudes = np.asarray(amplitudes, dtype=float)
    if amplitudes.shape != (5,):
        raise ValueError(f"a strain has five amplitudes, got shape {amplitudes.shape}")
    return np.einsum("k,kij->ij", amplitudes, strain_modes())


def _check_rotation(rotation) -> np.ndarray:
    rotation = np.asarray(rotation, dtype=float)
    if rotation.shape != (3, 3) or np.abs(rotation.T @ rotation - np.eye(3)).max() > 1e-10:
        raise ValueError("a rotation must be an orthogonal 3x3 matrix")
    return rotation


def strain_rotation(rotation) -> np.ndarray:
    """D (5x5) with D[k, l] = E_k : (Q E_l Q^T): amplitudes of Q E Q^T are D times those of E.
    D is orthogonal (Q preserves A:B) and D(Q1 Q2) = D(Q1) D(Q2)."""
    q = _check_rotation(rotation)
    modes = strain_modes()
    turned = np.einsum("ia,lab,jb->lij", q, modes, q)
    return np.einsum("kij,lij->kl", modes, turned)


# --- the ellipsoid in a linear flow -------------------------------------------------------------

def _rd_divided_difference(a: float, b: float, c: float) -> float:
    """[R_D(a, c, b) - R_D(b, c, a)] / (a - b), its limit when a == b, for a, b, c > 0.

    Carlson's duplication R_D(x, y, z) = R_D(x', y', z') / 4 + 3 / (sqrt z (z + lam)), with
    lam = sqrt(xy) + sqrt(yz) + sqrt(zx) and x' = (x + lam)/4 (Carlson 1979, Numer. Math. 33, 1;
    DLMF section 19.26), has the same lam for both orderings, so the difference quotient q obeys
    q = q' / 16 + 3 g, with g = [h(b) - h(a)] / (a - b), h(u) = 1 / (sqrt u (u + lam)), written
    without the cancellation. Iterated until the arguments agree, then q -> (3/5) mu^(-5/2)
    (dR_D/dx - dR_D/dz at x = y = z = mu)."""
    weight, total = 1.0, 0.0
    for _ in range(200):
        mu = (a + b + c) / 3.0
        if max(abs(a - mu), abs(b - mu), abs(c - mu)) <= 1e-12 * mu:
            break
        sa, sb, sc = np.sqrt(a), np.sqrt(b), np.sqrt(c)
        lam = sa * sb + sb * sc + sc * sa
        total += 3.0 * weight * (a + sa * sb + b + lam) / ((sa + sb) * sa * sb * (a + lam) * (b + lam))
        weight /= 16.0
        a, b, c = (a + lam) / 4.0, (b + lam) / 4.0, (c + lam) / 4.0
    mu = (a + b + c) / 3.0
    return total + weight * 0.6 * mu ** -2.5


def pair_integrals(semi_axes) -> np.ndarray:
    """beta (3x3, symmetric): beta_ij = int_0^inf dl / ((a_i^2 + l)(a_j^2 + l) Delta(l))."""
    squares = np.asarray(semi_axes, dtype=float) ** 2
    _, alpha = shape_integrals(semi_axes)  # also checks the semi-axes
    beta = np.zeros((3, 3))
    for i, j in ((0, 1), (0, 2), (1, 2)):
        # beta_ij = (alpha_j - alpha_i) / (a_i^2 - a_j^2), alpha_i = (2/3) R_D(a_j^2, a_k^2, a_i^2)
        beta[i, j] = beta[j, i] = 2.0 / 3.0 * _rd_divided_difference(squares[i], squares[j], squares[3 - i - j])
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        # 3 a_i^2 beta_ii + a_j^2 beta_ij + a_k^2 beta_ik = 3 alpha_i (integrate d/dl[l / ((a_i^2 + l) Delta)])
        beta[i, i] = (3.0 * alpha[i] - squares[j] * beta[i, j] - squares[k] * beta[i, k]) / (3.0 * squares[i])
    return beta


# (i, j) of the off-diagonal modes E_1, E_2, E_3, and (unit diagonal) of E_4, E_5
_PAIRS = ((0, 1), (0, 2), (1, 2))
_DIAGONALS = np.array([[1.0, -1.0, 0.0], [-1.0, -1.0, 2.0]]) / np.array([[_SQRT2], [_SQRT6]])


def ellipsoid_flow(semi_axes, viscosity: float = 1.0, rotation=None) -> tuple[np.ndarray, np.ndarray]:
    """(V, T) of the free ellipsoid in an ambient linear flow (module docstring).

    V (6x5): U - U_inf = V[0:3] e and Omega - Omega_inf = V[3:6] e for strain amplitudes e;
    T (5x5, symmetric positive definite): stresslet amplitudes s = T e. The semi-axes lie along x,
    y, z, or along the columns of the proper rotation `rotation` (Q); V and T are then in the
    lab frame: V_lab = diag(Q, Q) V D^T, T_lab = D T D^T with D = strain_rotation(Q)."""
    squares = np.asarray(semi_axes, dtype=float) ** 2
    beta = pair_integrals(semi_axes)
    product = float(np.prod(np.sqrt(squares)))
    volume = 4.0 * np.pi * product / 3.0
    velocity = np.zeros((6, 5))
    stresslet = np.zeros((5, 5))
    for mode, (i, j) in enumerate(_PAIRS):
        k = 3 - i - j
        # Jeffery: Omega_k - Omega_inf_k = (a_i^2 - a_j^2)/(a_i^2 + a_j^2) E_ij for (k, i, j) cyclic,
        # with E_ij = e / sqrt2; (0, 2) is anticyclic for k = 1.
        sign = -1.0 if (i, j) == (0, 2) else 1.0
        velocity[3 + k, mode] = sign * (squares[i] - squares[j]) / ((squares[i] + squares[j]) * _SQRT2)
        # S_ij = 16 pi eta E_ij / (3 (a_i^2 + a_j^2) beta_ij); amplitudes s = sqrt2 S_ij, e = sqrt2 E_ij
        stresslet[mode, mode] = 16.0 * np.pi * viscosity / (3.0 * (squares[i] + squares[j]) * beta[i, j])
    # Eshelby's S_iijj at Poisson ratio 1/2 (over a_1 a_2 a_3); it maps traceless diagonals to
    # traceless diagonals (columns sum to 1), and its restriction is symmetric (reciprocity; not
    # imposed here, the tests check it).
    eshelby = 0.5 * beta * squares[np.newaxis, :]
    eshelby[np.diag_indices(3)] = 1.5 * squares * np.diag(beta)
    restricted = product * _DIAGONALS @ eshelby @ _DIAGONALS.T
    stresslet[3:, 3:] = 2.0 * viscosity * volume * np.linalg.inv(restricted)
    if rotation is not None:
        q = _check_rotation(rotation)
        if np.linalg.det(q) < 0.0:
            raise ValueError("the rotation must be proper (determinant +1)")
        turn = strain_rotation(q)
        velocity = np.vstack([q @ velocity[:3], q @ velocity[3:]]) @ turn.T
        stresslet = turn @ stresslet @ turn.T
    return velocity, stresslet


def intrinsic_viscosity(semi_axes) -> float:
    """[eta] = tr(T) / (10 eta V_p): eta_eff = eta (1 + [eta] phi) for freely rotating ellipsoids
    at isotropic orientations (dilute; no Brownian stress). 5/2 for a sphere (Einstein).

    With S = T e per particle and n = phi / V_p particles per volume, the particle stress is
    n <D T D^T> e = n tr(T)/5 e over isotropic rotations D (Schur's lemma), to be set equal to
    2 eta [eta] phi E."""
    _, stresslet = ellipsoid_flow(semi_axes)
    return float(np.trace(stresslet) / (10.0 * 4.0 * np.pi * np.prod(np.asarray(semi_axes, dtype=float)) / 3.0))
