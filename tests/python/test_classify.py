"""Tests of beadmob_post.classify: families, time coefficients, physical units."""

from __future__ import annotations

import math

import numpy as np
import pytest

from beadmob_post.classify import (
    DRIFTER,
    FLUTTERER,
    SETTLER,
    UNCOUPLED,
    bead_model_volume_m3,
    classify,
    physical_scales,
    physical_times,
)
from beadmob_post.mobility import Coefficients
from beadmob_post.paper import (
    FLUID_DENSITY_KG_M3,
    FLUID_KINEMATIC_VISCOSITY_M2_S,
    TAB_MOBILITY_VELOCITY,
)


def coefficients(mu11=0.3, mu22=0.3, mu33=0.3, mu42=0.05, mu51=-0.05, n_beads=100, length=10.0):
    return Coefficients(
        path="x.h5", shape="test", n_beads=n_beads, reference_length=length,
        mu11=mu11, mu22=mu22, mu33=mu33, mu42=mu42, mu51=mu51,
        body_axes=np.eye(3), dimensionless_body_mobility=np.zeros((6, 6)), z_reversed=False,
        xy_swapped=False, off_pattern=0.0, off_pattern_entries=(), mirror_planes=None,
        paper_class=None, multipole_order=1, lubrication=False, all_converged=True,
    )


@pytest.mark.parametrize(
    "mu42, mu51, family, stable_y, stable_x",
    [
        (0.05, -0.03, SETTLER, True, True),     # the paper's sign pattern
        (0.05, 0.03, FLUTTERER, False, True),   # theta = 0 unstable about y
        (-0.05, -0.03, FLUTTERER, True, False),
        (0.05, 0.0, DRIFTER, False, True),
        (0.0, -0.03, DRIFTER, True, False),
        (0.0, 0.0, UNCOUPLED, False, False),
    ],
)
def test_family_from_the_signs(mu42, mu51, family, stable_y, stable_x):
    result = classify(coefficients(mu42=mu42, mu51=mu51))
    assert result.family == family
    assert result.stable_about_y is stable_y
    assert result.stable_about_x is stable_x


def test_noise_level_coefficients_count_as_zero():
    assert classify(coefficients(mu42=1e-12, mu51=-1e-13)).family == UNCOUPLED
    assert classify(coefficients(mu42=1e-12, mu51=-1e-13), zero_tolerance=0.0).family == SETTLER


def test_times_are_the_inverse_coefficients():
    result = classify(coefficients(mu42=0.04, mu51=-0.025))
    assert result.tau51 == pytest.approx(-40.0)  # eq. eq:mobility in the time of eq. eq:time
    assert result.tau42 == pytest.approx(25.0)
    assert classify(coefficients(mu42=0.0, mu51=-0.025)).tau42 == math.inf


def test_out_of_plane_stability_remarks_follow_the_paper():
    # Crescent moon of Table tab_mob_num: mu42 + mu51 > 0, so the rotation about y = Y is
    # unstable to rotation about z for theta > pi/2 (section "Discussion and conclusions").
    moon = classify(coefficients(mu11=0.751, mu22=0.560, mu33=0.639, mu42=0.381, mu51=-0.167))
    assert moon.family == SETTLER
    assert moon.sum_over_51 == pytest.approx(1.281, abs=1e-3)
    assert "about y = Y is unstable to rotation about z for theta > pi/2" in moon.remarks[0]
    # Arrowhead: mu42 + mu51 < 0, rotation about y unstable for theta < pi/2.
    arrow = classify(coefficients(mu11=0.422, mu22=0.370, mu33=0.396, mu42=0.050, mu51=-0.067))
    assert "about y = Y is unstable to rotation about z for theta < pi/2" in arrow.remarks[0]


@pytest.mark.parametrize("row", TAB_MOBILITY_VELOCITY, ids=lambda row: row.label)
def test_physical_units_reproduce_the_papers_measured_table(row):
    # Table tab:mobility_velocity relates U_f, 1/tau~ and the dimensionless mu by eqs.
    # eq:mju33 and eq:mobility, with L (section "Rigid particles"), F (tab:phys_properties)
    # and eta = nu rho of the silicone oil (section "Setup"); rounding to 2-3 digits.
    scales = physical_scales(
        row.length_mm * 1e-3, kinematic_viscosity_m2_s=FLUID_KINEMATIC_VISCOSITY_M2_S,
        fluid_density_kg_m3=FLUID_DENSITY_KG_M3, force_N=row.force_mN * 1e-3)
    assert scales.viscosity_Pa_s == pytest.approx(4.85)
    mu42 = row.mu42 if row.mu42 is not None else 0.1
    mu51 = -row.minus_mu51 if row.minus_mu51 is not None else -0.1
    times = physical_times(coefficients(mu33=row.mu33, mu42=mu42, mu51=mu51), scales)
    assert times.terminal_velocity_m_s * 1e3 == pytest.approx(row.terminal_velocity_mm_s, rel=0.02)
    if row.mu42 is not None:
        assert 1 / times.tau42_s == pytest.approx(row.inverse_tau42_per_s, rel=0.02)
    if row.minus_mu51 is not None:
        assert -1 / times.tau51_s == pytest.approx(row.minus_inverse_tau51_per_s, rel=0.02)
    # Section "Introduction": Re = 2.1e-3 ... 1.1e-2 in the experiments.
    assert 2e-3 < times.reynolds < 1.2e-2


def test_force_from_buoyant_mass_or_density_difference():
    g = 9.80665
    by_mass = physical_scales(1e-3, viscosity_Pa_s=1.0, buoyant_mass_kg=2e-6)
    assert by_mass.force_N == pytest.approx(2e-6 * g)
    by_density = physical_scales(1e-3, viscosity_Pa_s=1.0, density_difference_kg_m3=-500.0,
                                 volume_m3=4e-9, gravity_m_s2=9.81)
    assert by_density.force_N == pytest.approx(500.0 * 4e-9 * 9.81)


def test_bead_model_volume():
    # 8 beads, L = 2 d, L = 2 mm: d = 1 mm, volume 8 pi/6 mm^3.
    assert bead_model_volume_m3(8, 2.0, 2e-3) == pytest.approx(8 * math.pi / 6 * 1e-9)


@pytest.mark.parametrize(
    "options, message",
    [
        (dict(viscosity_Pa_s=1.0), "exactly one of the force"),
        (dict(viscosity_Pa_s=1.0, force_N=1.0, buoyant_mass_kg=1.0), "exactly one"),
        (dict(force_N=1.0), "give the viscosity"),
        (dict(viscosity_Pa_s=-1.0, force_N=1.0), "viscosity must be a positive number"),
        (dict(viscosity_Pa_s=1.0, density_difference_kg_m3=100.0), "needs the particle volume"),
        (dict(viscosity_Pa_s=1.0, density_difference_kg_m3=0.0, volume_m3=1.0), "does not settle"),
    ],
)
def test_physical_scales_errors(options, message):
    with pytest.raises(ValueError, match=message):
        physical_scales(1e-3, **options)
