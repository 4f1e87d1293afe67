"""Tests of beadmob_post.ellipsoid, the exact friction of an ellipsoid, against independent sources:

- the sphere: Stokes' 6 pi eta a and 8 pi eta a^3;
- the prolate spheroid's closed forms in the eccentricity e (Kim & Karrila, Microhydrodynamics,
  1991, section 3.3, Table 3.4: X^A, Y^A, X^C, Y^C), which the triaxial formula must reduce to;
- the thin circular disk (the oblate limit; Kim & Karrila section 3.3): broadside 16 eta a,
  edgewise 32/3 eta a, rotation about a diameter 32/3 eta a^3;
- the defining integrals by adaptive quadrature (scipy.integrate.quad), a different method from
  the Carlson integrals the module uses, for a triaxial 3:2:1 body.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from beadmob_post.ellipsoid import ellipsoid_friction, shape_integrals


def test_sphere_is_stokes():
    a = 2.5
    friction = ellipsoid_friction([a, a, a], viscosity=1.3)
    assert np.allclose(np.diag(friction)[:3], 6 * np.pi * 1.3 * a, rtol=1e-13)
    assert np.allclose(np.diag(friction)[3:], 8 * np.pi * 1.3 * a**3, rtol=1e-13)
    assert np.count_nonzero(friction - np.diag(np.diag(friction))) == 0


@pytest.mark.parametrize("e", [0.3, 0.7, 0.95])
def test_prolate_spheroid_closed_forms(e):
    a = 2.0                      # semi-axis along the symmetry axis (body x here)
    b = a * np.sqrt(1 - e**2)
    log = np.log((1 + e) / (1 - e))
    x_a = 8 / 3 * e**3 / (-2 * e + (1 + e**2) * log)
    y_a = 16 / 3 * e**3 / (2 * e + (3 * e**2 - 1) * log)
    x_c = 4 / 3 * e**3 * (1 - e**2) / (2 * e - (1 - e**2) * log)
    y_c = 4 / 3 * e**3 * (2 - e**2) / (-2 * e + (1 + e**2) * log)
    diagonal = np.diag(ellipsoid_friction([a, b, b]))
    expected = [6 * np.pi * a * x_a, 6 * np.pi * a * y_a, 6 * np.pi * a * y_a,
                8 * np.pi * a**3 * x_c, 8 * np.pi * a**3 * y_c, 8 * np.pi * a**3 * y_c]
    assert np.allclose(diagonal, expected, rtol=1e-10)


def test_thin_disk_limit():
    a = 1.0
    diagonal = np.diag(ellipsoid_friction([a, a, 1e-7 * a]))
    assert diagonal[2] == pytest.approx(16 * a, rel=1e-5)          # broadside
    assert diagonal[0] == pytest.approx(32 / 3 * a, rel=1e-5)      # edgewise
    assert diagonal[3] == pytest.approx(32 / 3 * a**3, rel=1e-5)   # about a diameter


def test_integrals_by_quadrature():
    semi_axes = np.array([3.0, 2.0, 1.0])

    def delta(t):
        return np.sqrt(np.prod(semi_axes**2 + t))

    chi = quad(lambda t: 1 / delta(t), 0, np.inf, epsabs=0, epsrel=1e-13)[0]
    alpha = [quad(lambda t, s=s: 1 / ((s**2 + t) * delta(t)), 0, np.inf, epsabs=0, epsrel=1e-13)[0] for s in semi_axes]
    got_chi, got_alpha = shape_integrals(semi_axes)
    assert got_chi == pytest.approx(chi, rel=1e-10)
    assert np.allclose(got_alpha, alpha, rtol=1e-10)
    # Exact: sum_i 1 / (a_i^2 + t) = 2 Delta' / Delta, so sum_i alpha_i = 2 / Delta(0).
    assert got_alpha.sum() == pytest.approx(2 / np.prod(semi_axes), rel=1e-12)


def test_bad_semi_axes_refused():
    with pytest.raises(ValueError, match="three positive semi-axes"):
        ellipsoid_friction([1.0, 0.0, 1.0])
