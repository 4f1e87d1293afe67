"""Tests of beadmob_post.two_spheres (the rigid doublet along / about its line of centres) against
independent limits:

- far apart, translation: two isolated spheres with the Oseen / Rotne-Prager interaction, whose
  per-sphere drag 1 / (1 + 3/2 e - e^3) (e = a / r) agrees with the exact far-field expansion
  lambda = 1 - 3/2 e + 9/4 e^2 - 19/8 e^3 + 93/16 e^4 + O(e^5) (Happel & Brenner 1965, sec. 6.3)
  to O(e^4); the series must match that expansion to O(e^5);
- far apart, rotation: a sphere turning in the rotlet of the other (the Rotne-Prager level,
  1 / (1 + e^3)), to O(e^8);
- touching: Stimson & Jeffery's contact value lambda = 0.645 (and 0.6451414, docs/theory.md T8,
  beadmob's multipole method at L = 20 ... 40); the co-rotating doublet's torque 3 zeta(3) / 4 =
  0.9015427, which beadmob's multipole method gives independently (T8: 0.9015426774 at L = 30);
- a direct evaluation of Stimson & Jeffery's published form (sinh and cosh, no rescaling) where it
  does not overflow.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import zeta

from beadmob_post.two_spheres import corotation_torque, doublet_mobility, stimson_jeffery


def published_stimson_jeffery(r, a=1.0, terms=60):
    alpha = np.arccosh(r / (2 * a))
    total = 0.0
    for n in range(1, terms + 1):
        x = (2 * n + 1) * alpha
        fraction = ((4 * np.sinh(x / 2) ** 2 - (2 * n + 1) ** 2 * np.sinh(alpha) ** 2)
                    / (2 * np.sinh(x) + (2 * n + 1) * np.sinh(2 * alpha)))
        total += n * (n + 1) / ((2 * n - 1) * (2 * n + 3)) * (1 - fraction)
    return 4 / 3 * np.sinh(alpha) * total


@pytest.mark.parametrize("r", [2.2, 2.5, 3.0, 4.0])
def test_stimson_jeffery_equals_its_published_form(r):
    assert stimson_jeffery(r) == pytest.approx(published_stimson_jeffery(r, terms=200), rel=1e-13)


@pytest.mark.parametrize("r", [20.0, 40.0, 80.0])
def test_translation_far_field(r):
    e = 1 / r
    rotne_prager = 1 / (1 + 1.5 * e - e**3)
    expansion = 1 - 1.5 * e + 9 / 4 * e**2 - 19 / 8 * e**3 + 93 / 16 * e**4
    lam = stimson_jeffery(r)
    assert abs(lam - rotne_prager) < 4 * e**4          # the O(e^4) term is 93/16 - 33/16 = 3.75
    assert abs(lam - expansion) < 13 * e**5            # the next term is -387/32 e^5


@pytest.mark.parametrize("r", [6.0, 10.0, 20.0])
def test_rotation_far_field(r):
    e = 1 / r
    assert abs(corotation_torque(r) - 1 / (1 + e**3)) < 4 * e**8


def test_isolated_spheres():
    translation, rotation = doublet_mobility(1e4, radius=0.7, viscosity=1.3)
    assert translation == pytest.approx(1 / (2 * 6 * np.pi * 1.3 * 0.7), rel=2e-4)
    assert rotation == pytest.approx(1 / (2 * 8 * np.pi * 1.3 * 0.7**3), rel=1e-11)


def test_contact_values():
    for alpha in (1e-3, 1e-4):
        r = 2 * np.cosh(alpha)
        assert stimson_jeffery(r) == pytest.approx(0.645, abs=5e-4)
        assert stimson_jeffery(r) == pytest.approx(0.6451414, abs=2e-6 + 2e-3 * alpha)
        assert corotation_torque(r) == pytest.approx(0.75 * zeta(3), abs=2e-3 * alpha)
    assert 0.75 * zeta(3) == pytest.approx(0.9015426774, abs=1e-9)


def test_scale_and_monotone():
    # lengths in any unit: lambda and f_C depend on r / a only
    assert stimson_jeffery(5.0, 2.0) == pytest.approx(stimson_jeffery(2.5, 1.0), rel=1e-14)
    assert corotation_torque(5.0, 2.0) == pytest.approx(corotation_torque(2.5, 1.0), rel=1e-14)
    r = np.linspace(2.01, 12.0, 40)
    assert np.all(np.diff([stimson_jeffery(x) for x in r]) > 0)
    assert np.all(np.diff([corotation_torque(x) for x in r]) > 0)


def test_refuses_overlap():
    with pytest.raises(ValueError):
        stimson_jeffery(2.0)
