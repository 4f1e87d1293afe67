"""Numbers from the settlers paper, kept as data with their source.

Source: C. Shekhar, H. N. Mirajkar, P. Zdybel, Y. Melikhov and M. L. Ekiel-Jeżewska, "Sedimenting
rigid particles of certain shapes approach a stationary orientation" (IPPT PAN, Warsaw; data:
RepOD, https://doi.org/10.18150/MIL6UG), the "settlers" paper: cones, arrowheads, crescent
moons, open rings settling in silicone oil. Each constant names the table or section
it is copied from; the values are typed in exactly as printed there (same rounding).
"""

from __future__ import annotations

from dataclasses import dataclass

CITATION = "settlers paper (Shekhar et al., IPPT PAN; data https://doi.org/10.18150/MIL6UG)"

#: The five dimensionless coefficients of eq. `matrices`, in the paper's order.
COEFFICIENT_NAMES = ("mu11", "mu22", "mu33", "mu42", "mu51")


@dataclass(frozen=True)
class PaperBeadModel:
    """One row of Table `tab_mob_num` (bead models, multipole order 2 with lubrication)."""

    shape: str            # beadmob shape name
    label: str            # the paper's "Object (shape)" column
    length_over_d: float  # L/d
    n_beads: int
    mu11: float
    mu22: float
    mu33: float
    mu42: float
    mu51: float
    ratio_51_42: float    # |mu51/mu42| as printed
    sum_over_51: float    # (mu51 + mu42)/|mu51| as printed

    def coefficients(self) -> tuple[float, float, float, float, float]:
        return (self.mu11, self.mu22, self.mu33, self.mu42, self.mu51)


#: Table `tab_mob_num` ("The dimensionless mobility coefficients defined in (matrices), for the
#: bead model of the particles used in our experiments"), section "Theoretical modeling".
TAB_MOB_NUM: tuple[PaperBeadModel, ...] = (
    PaperBeadModel("cone", "Cone", 21, 5088, 0.269, 0.269, 0.303, 0.057, -0.057, 1.00, 0.0),
    PaperBeadModel("crescent_moon", "Crescent moon", 55, 5513,
                   0.751, 0.560, 0.639, 0.381, -0.167, 0.44, 1.281),
    PaperBeadModel("arrowhead", "Arrowhead", 29, 5104,
                   0.422, 0.370, 0.396, 0.050, -0.067, 1.34, -0.254),
    PaperBeadModel("ring_1mm", "Ring (1 mm)", 67, 5182,
                   0.559, 0.442, 0.552, 0.057, -0.058, 1.001, -0.017),
    PaperBeadModel("ring_2mm", "Ring (2 mm)", 73, 5106,
                   0.608, 0.481, 0.592, 0.096, -0.102, 1.06, -0.059),
    PaperBeadModel("ring_3mm", "Ring (3 mm)", 81, 5110,
                   0.671, 0.528, 0.643, 0.140, -0.145, 1.04, -0.034),
    PaperBeadModel("ring_4mm", "Ring (4 mm)", 85, 4870,
                   0.717, 0.565, 0.679, 0.193, -0.195, 1.01, -0.010),
)

#: Multipole order and lubrication of the paper's computation (section "Theoretical modeling":
#: "We truncate the expansion at the multipole order of 2", "corrected for lubrication").
PAPER_MULTIPOLE_ORDER = 2
PAPER_LUBRICATION = True


def paper_row(shape: str) -> PaperBeadModel | None:
    """The Table `tab_mob_num` row of beadmob shape ``shape``, or None."""
    for row in TAB_MOB_NUM:
        if row.shape == shape:
            return row
    return None


def paper_counterpart(shape: str, reference_length: float | None) -> PaperBeadModel | None:
    """The row a result compares with: same shape name and the paper's L/d.

    A paper shape with changed parameters (e.g. a small test cone) has another L/d and is
    not the paper's model, so it gets no counterpart.
    """
    row = paper_row(shape)
    if row is None or reference_length is None or abs(reference_length - row.length_over_d) > 1e-6:
        return None
    return row


@dataclass(frozen=True)
class PaperExperiment:
    """Measured averages of Table `tab:mobility_velocity` with the object's data.

    ``length_mm`` is L of section "Rigid particles", ``force_mN`` the total force F (gravity
    minus buoyancy) of Table `tab:phys_properties`. None where the paper gives no value.
    """

    shape: str
    label: str
    length_mm: float
    force_mN: float
    terminal_velocity_mm_s: float
    minus_inverse_tau51_per_s: float | None
    inverse_tau42_per_s: float | None
    mu33: float
    minus_mu51: float | None
    mu42: float | None


#: Silicone oil of section "Setup": kinematic viscosity 5e-3 m^2/s, density 970 kg/m^3, so the
#: dynamic viscosity is eta = nu rho = 4.85 Pa s.
FLUID_KINEMATIC_VISCOSITY_M2_S = 5e-3
FLUID_DENSITY_KG_M3 = 970.0

#: Table `tab:mobility_velocity` (C, M, A rows; the rings share one force of
#: Table `tab:phys_properties`, their lengths are those of section "Rigid particles").
TAB_MOBILITY_VELOCITY: tuple[PaperExperiment, ...] = (
    PaperExperiment("cone", "C", 4.39, 1.10, 5.23, 0.113, 0.113, 0.320, 0.030, 0.030),
    PaperExperiment("crescent_moon", "M", 10.18, 0.59, 3.26, None, 0.144, 0.864, None, 0.389),
    PaperExperiment("arrowhead", "A", 6.28, 1.98, 8.72, 0.189, 0.129, 0.422, 0.057, 0.039),
    PaperExperiment("ring_1mm", "R1", 5.45, 0.264, 1.91, 0.042, 0.038, 0.598, 0.072, 0.065),
    PaperExperiment("ring_2mm", "R2", 5.92, 0.264, 1.88, 0.055, 0.056, 0.642, 0.110, 0.114),
    PaperExperiment("ring_3mm", "R3", 6.48, 0.264, 1.84, 0.059, 0.066, 0.685, 0.143, 0.159),
    PaperExperiment("ring_4mm", "R4", 6.81, 0.264, 1.74, 0.066, 0.070, 0.682, 0.176, 0.186),
)

#: Table `tab:fitting_param` (Appendix "Parameters of the fit"): A, 1/tau (1/s) and R^2 of
#: the weighted fit of eq. `eq:exp_exp` to one trial per object: (label, A, dA, 1/tau, d(1/tau), R^2).
TAB_FITTING_PARAM: tuple[tuple[str, float, float, float, float, float], ...] = (
    ("Cone", 2.743, 0.002, 0.1244, 0.0001, 1.000),
    ("Crescent moon", 2.462, 0.040, 0.1643, 0.0022, 0.999),
    ("Arrowhead", 5.776, 0.314, 0.2136, 0.0083, 0.989),
    ("Open ring (1 mm)", 2.865, 0.043, 0.0407, 0.0005, 0.992),
    ("Open ring (2 mm)", 2.048, 0.010, 0.0599, 0.0003, 0.999),
    ("Open ring (3 mm)", 1.539, 0.012, 0.0639, 0.0005, 0.998),
    ("Open ring (4 mm)", 2.432, 0.086, 0.0604, 0.0021, 0.971),
)
