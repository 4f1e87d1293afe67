"""Exact Stokes resistance of two equal spheres moving as one rigid body, along and about their
line of centres (the two-sphere bodies of bench/continuum/coverage.py).

Two spheres of radius a, centre distance r > 2a, in bispherical coordinates (xi, eta) with the
spheres at xi = +-alpha, cosh(alpha) = r / (2a), focal distance c = a sinh(alpha); viscosity eta.

* Translation along the line of centres with the same velocity U (Stimson & Jeffery, Proc. R. Soc.
  Lond. A 111, 110 (1926), eq. for the force; Happel & Brenner, Low Reynolds Number
  Hydrodynamics (1965), sec. 6.3): the drag on each sphere is F = 6 pi eta a U lambda with

      lambda = (4/3) sinh(alpha) sum_{n>=1} n(n+1) / ((2n-1)(2n+3)) [1 - (4 sinh^2((n+1/2) alpha)
               - (2n+1)^2 sinh^2(alpha)) / (2 sinh((2n+1) alpha) + (2n+1) sinh(2 alpha))].

  Evaluated here in the form 1 - fraction = e^-x (2 - 2 e^-x + k sinh 2alpha + k^2 sinh^2 alpha)
  / (1 - e^-2x + k sinh(2 alpha) e^-x), k = 2n + 1, x = k alpha (the same terms, divided by
  e^x: no overflow and no cancellation). At contact lambda = 0.645 (Stimson & Jeffery's value;
  0.6451414 by the series' limit, docs/theory.md T8).

* Rotation about the line of centres with the same angular velocity Omega (the doublet turning as
  one rigid body; Jeffery, Proc. Lond. Math. Soc. (2) 14, 327 (1915), the rotation of solids of
  revolution, whose method for two spheres this is). The swirl u_phi = v(xi, eta) makes v cos(phi)
  harmonic, so v = sqrt(cosh xi - cos eta) sum_n f_n(xi) P_n^1(cos eta); with the expansion
  sin(eta) (cosh(xi) - cos(eta))^(-3/2) = 2 sqrt(2) sum_n e^(-(n+1/2)|xi|) P_n^1(cos eta) of the
  boundary values v = Omega rho on xi = +-alpha and f_n even in xi (co-rotation),
  f_n(xi) = 2 sqrt(2) Omega c e^(-(n+1/2) alpha) cosh((n+1/2) xi) / cosh((n+1/2) alpha). The
  rotlet far field v ~ T_total rho / (8 pi eta R^3) gives the torque on each sphere

      T = 8 pi eta a^3 Omega f_C,   f_C = 4 sinh^3(alpha) sum_{n>=1} n(n+1) / (e^((2n+1) alpha) + 1).

  Checks (tests/python/test_two_spheres.py): f_C -> 1 far apart (one sphere, Stokes' 8 pi eta a^3),
  f_C = 1 - (a/r)^3 + O((a/r)^6) (a sphere in the rotlet of the other, the Rotne-Prager level), and
  at contact f_C -> 3 zeta(3) / 4 = 0.9015427 (the sum becomes an integral), which is the touching
  doublet's axial rotation beadmob's multipole method gives at L = 20 ... 40 (docs/theory.md T8,
  0.9015426774).

Mobility of the rigid doublet about its centre (the mid-point), along / about the line of centres
(both decouple from every other motion by the doublet's symmetry): 1 / (2 * 6 pi eta a lambda) and
1 / (2 * 8 pi eta a^3 f_C).
"""

from __future__ import annotations

import numpy as np


def _alpha(distance: float, radius: float) -> float:
    ratio = float(distance) / (2.0 * float(radius))
    if not ratio > 1.0:
        raise ValueError(f"two spheres of radius {radius} need a centre distance > {2 * radius}, got {distance}")
    return float(np.arccosh(ratio))


def _terms(alpha: float) -> np.ndarray:
    """n = 1 ... N, with N such that e^(-(2N+1) alpha) < 1e-18 (the terms fall as n e^(-(2n+1) alpha))."""
    count = int(np.ceil(45.0 / alpha)) + 10
    return np.arange(1, count + 1, dtype=float)


def stimson_jeffery(distance: float, radius: float = 1.0) -> float:
    """lambda: drag per sphere / (6 pi eta a U), two equal spheres translating together along their
    line of centres (Stimson & Jeffery 1926)."""
    alpha = _alpha(distance, radius)
    n = _terms(alpha)
    k = 2.0 * n + 1.0
    decay = np.exp(-k * alpha)
    s1, s2 = np.sinh(alpha), np.sinh(2.0 * alpha)
    one_minus_fraction = decay * (2.0 - 2.0 * decay + k * s2 + k**2 * s1**2) / (1.0 - decay**2 + k * s2 * decay)
    series = n * (n + 1.0) / ((2.0 * n - 1.0) * (2.0 * n + 3.0)) * one_minus_fraction
    return float(4.0 / 3.0 * s1 * np.sum(series[::-1]))


def corotation_torque(distance: float, radius: float = 1.0) -> float:
    """f_C: torque per sphere / (8 pi eta a^3 Omega), two equal spheres turning together about their
    line of centres (Jeffery 1915's bispherical swirl; module docstring)."""
    alpha = _alpha(distance, radius)
    n = _terms(alpha)
    series = n * (n + 1.0) / (np.exp((2.0 * n + 1.0) * alpha) + 1.0)
    return float(4.0 * np.sinh(alpha) ** 3 * np.sum(series[::-1]))


def doublet_mobility(distance: float, radius: float = 1.0, viscosity: float = 1.0) -> tuple[float, float]:
    """(translation along the line of centres, rotation about it): the rigid doublet's mobility
    about its mid-point."""
    translation = 1.0 / (2.0 * 6.0 * np.pi * viscosity * radius * stimson_jeffery(distance, radius))
    rotation = 1.0 / (2.0 * 8.0 * np.pi * viscosity * radius**3 * corotation_torque(distance, radius))
    return translation, rotation


__all__ = ["stimson_jeffery", "corotation_torque", "doublet_mobility"]
