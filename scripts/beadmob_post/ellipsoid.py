"""Exact Stokes friction of a rigid ellipsoid (the continuum reference of docs/theory.md T18).

For semi-axes a_1, a_2, a_3 along the body axes and viscosity eta, with
Delta(l) = sqrt((a_1^2 + l)(a_2^2 + l)(a_3^2 + l)) and the integrals

    chi = int_0^inf dl / Delta(l),     alpha_i = int_0^inf dl / ((a_i^2 + l) Delta(l)),

the force on a translating ellipsoid (Oberbeck 1876) and the torque on a rotating one (Jeffery
1922) are diagonal in the principal frame:

    F_i = 16 pi eta U_i / (chi + a_i^2 alpha_i),
    T_i = 16 pi eta (a_j^2 + a_k^2) Omega_i / (3 (a_j^2 alpha_j + a_k^2 alpha_k)),  (i, j, k) cyclic,

and translation and rotation do not couple (three mirror planes). The integrals are Carlson's
symmetric elliptic integrals: chi = 2 R_F(a_1^2, a_2^2, a_3^2) and
alpha_i = (2/3) R_D(a_j^2, a_k^2, a_i^2) (DLMF 19.16.1-2 with t = l).
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
