"""Settler / drifter / flutterer classification, reorientation times, terminal velocity.

Orientation dynamics under gravity (paper, section "Theoretical background"): with g the unit
vector of lab Z in body coordinates and the dimensionless time t of eq. `eq:time`, the body
angular velocity is Omega = -mu_rt g, so dg/dt = -Omega x g gives, in the frame of eq.
`matrices`,

    dg_x/dt = mu51 g_x g_z,   dg_y/dt = -mu42 g_y g_z,   dg_z/dt = mu42 g_y^2 - mu51 g_x^2,

with theta the angle between z and Z (g_z = cos theta). The planar cases are eqs.
`eq:theta_51_exp` and `eq:theta_42_exp`. |g_x|^mu42 |g_y|^mu51 is conserved, so the signs
decide the family (Joshi & Govindarajan, cited as [joshi] in the paper's introduction):

* mu42 mu51 < 0: settler -- every orbit runs from theta = pi to theta = 0, one stable
  vertical orientation (paper: "For the settlers ... mu42 mu51 < 0");
* mu42 mu51 > 0: flutterer -- neither vertical orientation is stable; orbits are closed curves
  around the horizontal orientations with g_y^2/g_x^2 = mu51/mu42, the body rotates forever;
* exactly one of them zero: drifter -- rotation about one body axis only, ending at an
  inclined orientation fixed by the start, falling obliquely (lateral drift);
* both zero: no rotation-translation coupling -- every orientation is kept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from beadmob_post.mobility import Coefficients

#: Standard gravity (m/s^2), the default for forces from masses and densities.
STANDARD_GRAVITY = 9.80665
#: mu42 or mu51 counts as zero when |mu| <= this times max(mu11, mu22, mu33).
DEFAULT_ZERO_TOLERANCE = 1e-6

SETTLER, FLUTTERER, DRIFTER, UNCOUPLED = "settler", "flutterer", "drifter", "no coupling"


@dataclass(frozen=True)
class Classification:
    family: str
    reason: str
    #: theta = 0 stable for the planar rotations about y (eq:theta_51_exp) and x (eq:theta_42_exp)
    stable_about_y: bool
    stable_about_x: bool
    #: dimensionless time coefficients 1/mu51 and 1/mu42 (eq. `eq:mobility` with eq. `eq:time`)
    tau51: float
    tau42: float
    #: (mu51 + mu42)/|mu51| and the out-of-plane stability remarks of section "Discussion"
    sum_over_51: float
    remarks: tuple[str, ...]


def classify(coefficients: Coefficients, zero_tolerance: float = DEFAULT_ZERO_TOLERANCE) -> Classification:
    """Family of the body from the signs of mu42 and mu51 (see the module docstring)."""
    mu42, mu51 = coefficients.mu42, coefficients.mu51
    scale = max(coefficients.mu11, coefficients.mu22, coefficients.mu33)
    zero42 = abs(mu42) <= zero_tolerance * scale
    zero51 = abs(mu51) <= zero_tolerance * scale
    stable_y = not zero51 and mu51 < 0      # d theta/dt = mu51 sin theta
    stable_x = not zero42 and mu42 > 0      # d theta/dt = -mu42 sin theta
    remarks: list[str] = []
    if zero42 and zero51:
        family = UNCOUPLED
        reason = ("mu42 = mu51 = 0 (within tolerance): gravity turns the body neither way, "
                  "every orientation is kept (as for three mirror planes)")
    elif zero42 or zero51:
        family = DRIFTER
        turning = "y (mu51)" if zero42 else "x (mu42)"
        still = "mu42" if zero42 else "mu51"
        reason = (f"{still} = 0 (within tolerance): the body turns only about body {turning}, "
                  "towards an inclined orientation set by the start, and falls obliquely")
    elif mu42 * mu51 < 0:
        family = SETTLER
        reason = (f"mu42 mu51 = {mu42 * mu51:.3g} < 0: every orientation relaxes to the "
                  "stable vertical one, theta = 0 (paper, section 'Theoretical background')")
        total = mu51 + mu42
        if abs(total) <= zero_tolerance * scale:
            remarks.append("mu42 + mu51 = 0: planar rotations are neutral to rotation about z")
        else:
            about_y = "theta > pi/2" if total > 0 else "theta < pi/2"
            about_x = "theta < pi/2" if total > 0 else "theta > pi/2"
            remarks.append(
                f"mu42 + mu51 = {total:.3g}: rotation about y = Y is unstable to rotation "
                f"about z for {about_y}, rotation about x = X for {about_x} "
                "(paper, section 'Discussion and conclusions': (mu42 + mu51) cos theta < 0 "
                "and > 0)"
            )
    else:
        family = FLUTTERER
        reason = (f"mu42 mu51 = {mu42 * mu51:.3g} > 0: neither vertical orientation is stable; "
                  "the orientation circles closed orbits around horizontal ones and the body "
                  "rotates forever")
    return Classification(
        family=family,
        reason=reason,
        stable_about_y=stable_y,
        stable_about_x=stable_x,
        tau51=1.0 / mu51 if not zero51 else math.inf,
        tau42=1.0 / mu42 if not zero42 else math.inf,
        sum_over_51=coefficients.sum_over_51,
        remarks=tuple(remarks),
    )


@dataclass(frozen=True)
class PhysicalScales:
    """SI scales of one particle in one fluid: L (m), F (N), eta (Pa s)."""

    length_m: float
    force_N: float
    viscosity_Pa_s: float
    fluid_density_kg_m3: float | None = None

    @property
    def time_unit_s(self) -> float:
        """pi eta L^2 / F: one unit of the dimensionless time of eq. `eq:time`."""
        return math.pi * self.viscosity_Pa_s * self.length_m**2 / self.force_N

    @property
    def velocity_unit_m_s(self) -> float:
        """F / (pi eta L): the velocity unit of eq. `eq:mju33`."""
        return self.force_N / (math.pi * self.viscosity_Pa_s * self.length_m)


def physical_scales(
    length_m: float,
    viscosity_Pa_s: float | None = None,
    kinematic_viscosity_m2_s: float | None = None,
    fluid_density_kg_m3: float | None = None,
    force_N: float | None = None,
    buoyant_mass_kg: float | None = None,
    density_difference_kg_m3: float | None = None,
    volume_m3: float | None = None,
    gravity_m_s2: float = STANDARD_GRAVITY,
) -> PhysicalScales:
    """Scales from what the user knows; raises ValueError naming what is missing or wrong.

    Viscosity: eta, or nu with the fluid density (eta = nu rho). Force F (gravity minus
    buoyancy): F itself, or the buoyant mass m_b (F = m_b g), or the density difference with
    the particle volume (F = delta rho V g).
    """
    def positive(name: str, value: float | None) -> None:
        if value is not None and not (value > 0 and math.isfinite(value)):
            raise ValueError(f"{name} must be a positive number, got {value}")

    for name, value in (("length", length_m), ("viscosity", viscosity_Pa_s),
                        ("kinematic viscosity", kinematic_viscosity_m2_s),
                        ("fluid density", fluid_density_kg_m3), ("force", force_N),
                        ("buoyant mass", buoyant_mass_kg), ("volume", volume_m3),
                        ("gravity", gravity_m_s2)):
        positive(name, value)
    if density_difference_kg_m3 is not None and density_difference_kg_m3 == 0:
        raise ValueError("density difference is 0: the particle does not settle")
    if viscosity_Pa_s is None:
        if kinematic_viscosity_m2_s is None or fluid_density_kg_m3 is None:
            raise ValueError("give the viscosity, or the kinematic viscosity and the fluid density")
        viscosity_Pa_s = kinematic_viscosity_m2_s * fluid_density_kg_m3
    givens = [force_N is not None, buoyant_mass_kg is not None, density_difference_kg_m3 is not None]
    if sum(givens) != 1:
        raise ValueError("give exactly one of the force, the buoyant mass or the density difference")
    if buoyant_mass_kg is not None:
        force_N = buoyant_mass_kg * gravity_m_s2
    elif density_difference_kg_m3 is not None:
        if volume_m3 is None:
            raise ValueError("a density difference needs the particle volume")
        # A lighter-than-fluid particle rises: same magnitudes, gravity reversed.
        force_N = abs(density_difference_kg_m3) * volume_m3 * gravity_m_s2
    return PhysicalScales(length_m, float(force_N), float(viscosity_Pa_s), fluid_density_kg_m3)


def bead_model_volume_m3(n_beads: int, reference_length_d: float, length_m: float) -> float:
    """Volume of N spheres of diameter d = L_m / (L/d): N pi d^3 / 6."""
    diameter = length_m / reference_length_d
    return n_beads * math.pi * diameter**3 / 6.0


@dataclass(frozen=True)
class Times:
    """Dimensional results of eq. `eq:mobility` and eq. `eq:mju33`."""

    tau51_s: float
    tau42_s: float
    terminal_velocity_m_s: float
    reynolds: float | None


def physical_times(coefficients: Coefficients, scales: PhysicalScales) -> Times:
    """tau~51 = (pi eta L^2/F)/mu51, tau~42 = (pi eta L^2/F)/mu42, U_f = mu33 F/(pi eta L)."""
    unit = scales.time_unit_s
    velocity = coefficients.mu33 * scales.velocity_unit_m_s
    reynolds = None
    if scales.fluid_density_kg_m3 is not None:
        reynolds = scales.fluid_density_kg_m3 * velocity * scales.length_m / scales.viscosity_Pa_s
    return Times(
        tau51_s=unit / coefficients.mu51 if coefficients.mu51 != 0 else math.inf,
        tau42_s=unit / coefficients.mu42 if coefficients.mu42 != 0 else math.inf,
        terminal_velocity_m_s=velocity,
        reynolds=reynolds,
    )
