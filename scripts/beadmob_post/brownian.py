"""Brownian motion and dilute-suspension properties of a rigid body from its mobility (and, when the
file has ``/flow``, from its response to a linear flow).

Units: those of the file (beadmob: eta = 1, lengths in the bead diameter d) with kT = 1, so that
the diffusion tensor D = kT M is the mobility M itself; :func:`physical_units` turns the numbers
into SI for a temperature, a viscosity and a length unit.

Diffusion (M: rows U, Omega; columns F, T):

* centre of diffusion (Harvey & Garcia de la Torre 1980, Macromolecules 13, 960): the point about
  which the rotation-translation coupling D_rt is symmetric. Moving the reference point by r
  turns D_rt into D_rt + D_rr [r]x, so r = (tr(D_rr) I - D_rr)^-1 w with w = -2 axial(D_rt),
  w = (D_rt,yz - D_rt,zy, D_rt,zx - D_rt,xz, D_rt,xy - D_rt,yx). It is the same point as beadmob's
  centre of mobility (/hydrodynamics/centre_of_mobility: the same condition on the same matrix
  up to the factor kT), and the point where tr(D_tt) is smallest (the condition is the stationarity
  of tr D_tt(r), a convex quadratic in r). D_t = tr(D_tt)/3 there is the long-time translational
  diffusion coefficient (Brenner 1967, J. Colloid Interface Sci. 23, 407; Cichocki,
  Ekiel-Jezewska & Wajnryb 2015, J. Chem. Phys. 142, 214902), and R_s = kT/(6 pi eta D_t) the
  Stokes radius.
* rotational diffusion: the eigenvalues D_1 <= D_2 <= D_3 of D_rr (independent of the point) and
  the five relaxation times of the l = 2 orientation functions (Favro 1960, Phys. Rev. 119, 53;
  Small & Isenberg 1977, Biopolymers 16, 1907): with D = (D_1 + D_2 + D_3)/3 and
  Delta = sqrt(D_1^2 + D_2^2 + D_3^2 - D_1 D_2 - D_1 D_3 - D_2 D_3),
  1/tau = 6 D - 2 Delta, 3 (D + D_1), 3 (D + D_2), 3 (D + D_3), 6 D + 2 Delta, and their harmonic
  mean tau_h = 5 / sum(1/tau) = 1/(6 D) (Garcia de la Torre et al.). The same rates are the
  eigenvalues of -K, K = sum_ij D_ij G_j G_i, the rotational diffusion operator on the five l = 2
  functions (G_i below); a test checks that both agree.

Linear flow (``/flow``; modes E_1..E_5 of :data:`STRAIN_MODES`): the free body rotates with
Omega = Omega_inf + C e (C = the rotation rows of velocity_per_strain) and has the stresslet s = T e.

* Intrinsic viscosity, eta_eff = eta (1 + [eta] phi), phi the volume fraction, V_p the body's
  volume. Non-Brownian, orientations isotropic: <D T D^T> = tr(T)/5 I (the l = 2 representation is
  irreducible), so [eta]_inf = tr(T)/(10 eta V_p) (5/2 for a sphere: T = 20/3 pi eta a^3 I). It is
  also the high-frequency limit of the Brownian suspension.
* Zero-shear, rotary Brownian motion (Brenner 1974, Int. J. Multiphase Flow 1, 195, and Hinch &
  Leal 1972, J. Fluid Mech. 52, 683, for axisymmetric bodies; Rallison 1978, J. Fluid Mech. 84,
  237, and Haber & Brenner 1984, J. Colloid Interface Sci. 97, 496, for any rigid body). Derived
  here for any body (docs/postprocessing.md, "Diffusion and intrinsic viscosity"): in weak flow the
  orientation density is psi = (1 + g)/(8 pi^2) with g = a . eps (eps the strain amplitudes in the
  body frame) solving the Smoluchowski equation sum D_ij J_i J_j g = J . (C eps), J_i the
  body-frame rotation generators, which act on eps as the 5x5 matrices G_i:
  (G_i)_ml = E_m : (E_l [e_i]x - [e_i]x E_l). So a = K^-1 b with b = sum_i G_i^T C_i (C_i row i
  of C). The Brownian couple -kT J ln psi on the free body adds the stresslet -C^T (couple) (the
  reciprocal theorem, Kim & Karrila 1991 ch. 5: the grand resistance matrix is symmetric), whose
  isotropic average is kT b.(-K)^-1 b / 5 e. Hence

      [eta]_0 = [eta]_inf + b.(-K)^-1 b / (10 eta V_p)      (K with D_rr/kT: kT cancels).

  For a body of revolution (|b|^2 = 6 B^2, -K = 6 D_perp on b) the Brownian part is
  B^2 / (10 eta V_p M_rr,perp), Hinch & Leal's 3 n kT B <pp> stress; for spheroids [eta]_0 is
  Simha's (1940, J. Phys. Chem. 44, 25) value as tabulated by Scheraga (1955, J. Chem. Phys. 23,
  1526), e.g. 2.91 (prolate 2:1), 5.81 (5:1), 13.6 (10:1), 2.85 (oblate 1:2), 8.04 (1:10).
* Bretherton's constant (Bretherton 1962, J. Fluid Mech. 14, 284): for a body of revolution about
  p, Omega - Omega_inf = B p x (E.p) (Jeffery 1922 for spheroids, B = (r^2 - 1)/(r^2 + 1)). B is
  fitted by least squares about the principal axes of D_rr (the symmetry axis is one of them) and
  the relative residual tells how far the body is from that form; r_e = sqrt((1 + B)/(1 - B)) is
  the equivalent aspect ratio and 2 pi (r_e + 1/r_e) the Jeffery period in units of 1/shear rate.
  For any body the constants lambda_i of Jeffery's triaxial form Omega_i - Omega_inf_i =
  lambda_i E_jk ((i, j, k) cyclic) in the principal frame of D_rr are reported with the part of
  C outside that form (exact for three mirror planes).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import h5py
import numpy as np

from beadmob_post.mobility import MobilityError, checked_mobility, in_frame, shift_reference_point, skew
from beadmob_post.results import BeadResult, Flow, ResultFileError
from beadmob_post.ellipsoid import strain_modes

_S2 = np.sqrt(2.0)

#: Boltzmann constant (J/K), exact in the SI since 2019.
BOLTZMANN = 1.380649e-23
#: Relative residual below which the rotation response counts as Bretherton's form.
AXISYMMETRY_TOLERANCE = 1e-3
#: How the default volume of a bead model is named.
BEAD_VOLUME_SOURCE = "N d^3, a lattice cell per bead"
#: Entries of C (rotation per unit strain amplitude, dimensionless) below this are rounding noise.
NEGLIGIBLE_ROTATION = 1e-12

#: The five orthonormal symmetric traceless strain modes E_1..E_5 of /flow (shape (5, 3, 3)).
STRAIN_MODES = strain_modes()   # one definition, beadmob_post/ellipsoid.py
STRAIN_MODES.setflags(write=False)


def mode_amplitudes(tensor: np.ndarray) -> np.ndarray:
    """The amplitudes e_k = E_k : E of a symmetric traceless tensor (..., 3, 3)."""
    return np.einsum("kij,...ij->...k", STRAIN_MODES, tensor)


def mode_rotation(rotation: np.ndarray) -> np.ndarray:
    """D(Q)[k, l] = E_k : (Q E_l Q^T) for rotations (..., 3, 3): the amplitudes of Q E Q^T are D e."""
    turned = np.einsum("...ia,lab,...jb->...lij", rotation, STRAIN_MODES, rotation)
    return np.einsum("kij,...lij->...kl", STRAIN_MODES, turned)


def mode_generators() -> np.ndarray:
    """G_i (3, 5, 5): the body-frame rotation generator J_i on strain amplitudes, J_i eps = G_i eps.

    A body turning with body-frame angular velocity w sees E_b = Q^T E Q change by
    dE_b/dt = E_b [w]x - [w]x E_b, so (G_i)_ml = E_m : (E_l [e_i]x - [e_i]x E_l).
    """
    generators = np.empty((3, 5, 5))
    for i, axis in enumerate(np.eye(3)):
        w = skew(axis)
        change = np.einsum("lab,bc->lac", STRAIN_MODES, w) - np.einsum("ab,lbc->lac", w, STRAIN_MODES)
        generators[i] = np.einsum("mab,lab->ml", STRAIN_MODES, change)
    return generators


def canonical_flow(flow: Flow) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]:
    """(V, T, V error, T error) of ``flow`` on :data:`STRAIN_MODES` (the file's modes may differ).

    With P[k, l] = E_k : F_l (F the file's modes), e_file = P^T e: V P^T, P T P^T; the error bars are
    carried the same way in absolute value (a bound; exact when P is a signed permutation).
    """
    change = np.einsum("kij,lij->kl", STRAIN_MODES, flow.strain_modes)
    velocity = flow.velocity_per_strain @ change.T
    stresslet = change @ flow.stresslet_per_strain @ change.T
    velocity_error = stresslet_error = None
    if flow.velocity_per_strain_error is not None:
        velocity_error = flow.velocity_per_strain_error @ np.abs(change).T
    if flow.stresslet_per_strain_error is not None:
        stresslet_error = np.abs(change) @ flow.stresslet_per_strain_error @ np.abs(change).T
    return velocity, stresslet, velocity_error, stresslet_error


# ----------------------------------------------------------------------------- diffusion
def _axial(matrix: np.ndarray) -> np.ndarray:
    """Axial vector a of the antisymmetric part of a 3x3 matrix: (m - m^T)/2 = [a]x."""
    return 0.5 * np.array([matrix[2, 1] - matrix[1, 2], matrix[0, 2] - matrix[2, 0], matrix[1, 0] - matrix[0, 1]])


def centre_of_diffusion(mobility: np.ndarray, reference_point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The centre of diffusion (model coordinates) and the mobility about it (module docstring).

    Harvey & Garcia de la Torre (1980): r = (tr(D_rr) I - D_rr)^-1 w, w = -2 axial(D_rt).
    """
    rr = mobility[3:6, 3:6]
    system = np.trace(rr) * np.eye(3) - rr
    if np.linalg.cond(system) > 1e12:
        raise MobilityError("the centre of diffusion is undefined (rotational mobility singular)")
    offset = np.linalg.solve(system, -2.0 * _axial(mobility[3:6, 0:3]))
    return np.asarray(reference_point, float) + offset, shift_reference_point(mobility, offset)


def favro_relaxation_times(rotational: np.ndarray) -> np.ndarray:
    """The five l = 2 relaxation times from the principal rotational diffusion coefficients
    (Favro 1960; Small & Isenberg 1977), shortest first."""
    d1, d2, d3 = np.asarray(rotational, float)
    mean = (d1 + d2 + d3) / 3.0
    # Delta^2 = D1^2 + D2^2 + D3^2 - D1 D2 - D1 D3 - D2 D3, written without cancellation
    delta = np.sqrt(0.5 * ((d1 - d2) ** 2 + (d1 - d3) ** 2 + (d2 - d3) ** 2))
    rates = np.array([6 * mean - 2 * delta, 3 * (mean + d1), 3 * (mean + d2), 3 * (mean + d3), 6 * mean + 2 * delta])
    return np.sort(1.0 / rates)


def rotational_operator(rotational_diffusion: np.ndarray) -> np.ndarray:
    """K = sum_ij D_ij G_j G_i, the rotational diffusion operator on l = 2 amplitudes (5x5,
    negative definite); its eigenvalues are minus the five relaxation rates."""
    generators = mode_generators()
    return np.einsum("ij,jab,ibc->ac", rotational_diffusion, generators, generators)


@dataclass(frozen=True)
class IntrinsicViscosity:
    """[eta] of eta_eff = eta (1 + [eta] phi), dimensionless (module docstring)."""

    high_frequency: float   # non-Brownian isotropic average tr(T)/(10 eta V_p)
    brownian: float         # the rotary-Brownian part at zero shear
    zero_shear: float       # their sum


def intrinsic_viscosity(rotation_per_strain: np.ndarray, stresslet_per_strain: np.ndarray,
                        rotational_mobility: np.ndarray, volume: float, viscosity: float = 1.0) -> IntrinsicViscosity:
    """[eta]_inf and [eta]_0 from C (3x5, Omega - Omega_inf = C e), T (5x5), M_rr (3x3) and V_p,
    in the model frame (module docstring)."""
    if not volume > 0:
        raise ValueError(f"the body's volume must be positive, got {volume}")
    high = float(np.trace(stresslet_per_strain)) / (10.0 * viscosity * volume)
    generators = mode_generators()
    b = np.einsum("im,iml->l", rotation_per_strain, generators)         # b = sum_i G_i^T C_i
    operator = -rotational_operator(0.5 * (rotational_mobility + rotational_mobility.T))
    brownian = float(b @ np.linalg.solve(operator, b)) / (10.0 * viscosity * volume)
    return IntrinsicViscosity(high, brownian, high + brownian)


def bretherton_form(axis: np.ndarray) -> np.ndarray:
    """The 3x5 matrix A(p) of e -> p x (E(e).p)."""
    p = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.stack([np.cross(p, mode @ p) for mode in STRAIN_MODES], axis=1)


@dataclass(frozen=True)
class Bretherton:
    axis: np.ndarray            # p, model coordinates (unit vector)
    constant: float             # B
    residual: float             # |C - B A(p)| / |C| (0 for an exact body of revolution)
    axisymmetric: bool          # residual below AXISYMMETRY_TOLERANCE (or C = 0)

    @property
    def aspect_ratio(self) -> float | None:
        """r_e = sqrt((1 + B)/(1 - B)), the equivalent spheroid's aspect ratio (None for |B| >= 1)."""
        return float(np.sqrt((1 + self.constant) / (1 - self.constant))) if abs(self.constant) < 1 else None

    @property
    def jeffery_period(self) -> float | None:
        """2 pi (r_e + 1/r_e), the tumbling period times the shear rate (None for |B| >= 1)."""
        r = self.aspect_ratio
        return None if r is None else float(2 * np.pi * (r + 1 / r))


def bretherton_fit(rotation_per_strain: np.ndarray, candidate_axes: np.ndarray) -> Bretherton:
    """The least-squares B about the candidate axis (rows) that fits C best."""
    norm = float(np.linalg.norm(rotation_per_strain))
    best = None
    for axis in np.asarray(candidate_axes, float):
        form = bretherton_form(axis)
        constant = float(np.sum(form * rotation_per_strain) / np.sum(form * form))
        residual = (float(np.linalg.norm(rotation_per_strain - constant * form)) / norm
                    if np.abs(rotation_per_strain).max() >= NEGLIGIBLE_ROTATION else 0.0)
        if best is None or residual < best[2]:
            best = (axis / np.linalg.norm(axis), constant, residual)
    axis, constant, residual = best
    return Bretherton(axis, constant, residual, residual < AXISYMMETRY_TOLERANCE)


#: (axis i, mode of E_jk) of Jeffery's triaxial form Omega_i - Omega_inf_i = lambda_i E_jk.
_JEFFERY_ENTRIES = ((0, 2), (1, 1), (2, 0))   # x: E_yz (E_3), y: E_zx (E_2), z: E_xy (E_1)


def jeffery_constants(rotation_per_strain: np.ndarray, axes: np.ndarray) -> tuple[np.ndarray, float]:
    """(lambda_x, lambda_y, lambda_z) of Jeffery's triaxial form in the right-handed frame ``axes``
    (rows, model coordinates), and the largest other entry relative to the largest lambda.

    In the frame, C_f = R C D(R)^T; E_jk = e_mode / sqrt(2), so lambda_i = sqrt(2) C_f[i, mode].
    """
    frame = in_frame_rotation(rotation_per_strain, axes)
    constants = np.array([_S2 * frame[i, m] for i, m in _JEFFERY_ENTRIES])
    rest = frame.copy()
    for i, m in _JEFFERY_ENTRIES:
        rest[i, m] = 0.0
    scale = np.abs(constants).max()
    # a body that does not turn in a strain (a sphere, a cube): C is rounding noise, no pattern
    if np.abs(frame).max() < NEGLIGIBLE_ROTATION:
        return constants, 0.0
    return constants, float(_S2 * np.abs(rest).max() / scale) if scale > 0 else float("inf")


def in_frame_rotation(rotation_per_strain: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """C in the frame whose rows ``axes`` are given in model coordinates: R C D(R)^T."""
    axes = np.asarray(axes, float)
    return axes @ rotation_per_strain @ mode_rotation(axes).T


# ----------------------------------------------------------------------------- from a file
@dataclass(frozen=True)
class PhysicalScales:
    """SI scales: kT (J), eta (Pa s), the length unit (m)."""

    temperature_K: float
    viscosity_Pa_s: float
    length_m: float

    @property
    def kT(self) -> float:
        return BOLTZMANN * self.temperature_K

    @property
    def translational(self) -> float:   # m^2/s per dimensionless D_t
        return self.kT / (self.viscosity_Pa_s * self.length_m)

    @property
    def rotational(self) -> float:      # 1/s per dimensionless D_r
        return self.kT / (self.viscosity_Pa_s * self.length_m ** 3)


def physical_scales(temperature: float | None, viscosity: float | None, length: float | None) -> PhysicalScales | None:
    """The scales, None when none is given; ValueError when only some are, or one is not positive."""
    given = [v is not None for v in (temperature, viscosity, length)]
    if not any(given):
        return None
    if not all(given):
        raise ValueError("physical units need --temperature (K), --viscosity (Pa s) and --length-unit "
                         "(metres per length unit of the file) together")
    for name, value in (("temperature", temperature), ("viscosity", viscosity), ("length unit", length)):
        if not (value > 0 and np.isfinite(value)):
            raise ValueError(f"the {name} must be positive, got {value}")
    return PhysicalScales(float(temperature), float(viscosity), float(length))


@dataclass(frozen=True)
class FlowProperties:
    intrinsic_viscosity: IntrinsicViscosity
    bretherton: Bretherton
    #: Jeffery's triaxial lambda_x,y,z in the principal frame of D_rr, and the part outside that form
    jeffery_constants: np.ndarray
    jeffery_off_pattern: float
    #: first-order worst-case error bars from /flow/*_error and the mobility's error bar
    #: (keys high_frequency, brownian, zero_shear, bretherton), None without error bars
    errors: dict[str, float] | None = None


@dataclass(frozen=True)
class Diffusion:
    """What ``beadmob-post diffusion`` reports (kT = eta = 1, lengths in the file's unit)."""

    path: str
    source: str                       # "hydrodynamics" or "continuum"
    length_unit: str                  # "d" or "shape unit"
    reference_point: np.ndarray       # point of the mobility read (centre of mass / centroid)
    centre_of_diffusion: np.ndarray
    file_centre_of_mobility: np.ndarray | None
    diffusion: np.ndarray             # 6x6 kT M about the centre of diffusion, model axes
    translational: float              # D_t = tr(D_tt)/3 there
    translational_principal: np.ndarray
    stokes_radius: float
    rotational: np.ndarray            # D_1 <= D_2 <= D_3
    rotational_axes: np.ndarray       # rows: their axes (model coordinates), right-handed
    relaxation_times: np.ndarray      # five, shortest first
    harmonic_mean_time: float
    volume: float
    volume_source: str
    flow: FlowProperties | None = None
    #: first-order worst-case error bars from /hydrodynamics/body_mobility_error, None without it
    errors: dict[str, Any] | None = None
    physical: PhysicalScales | None = None

    @property
    def mean_rotational(self) -> float:
        return float(np.mean(self.rotational))

    def as_dict(self) -> dict[str, Any]:
        data: dict[str, Any] = {
            "file": self.path, "source": self.source,
            "units": f"kT = eta = 1, lengths in {self.length_unit}",
            "reference_point": self.reference_point.tolist(),
            "centre_of_diffusion": self.centre_of_diffusion.tolist(),
            "file_centre_of_mobility": None if self.file_centre_of_mobility is None else self.file_centre_of_mobility.tolist(),
            "diffusion_tensor_at_centre_of_diffusion": self.diffusion.tolist(),
            "translational_diffusion": self.translational,
            "translational_principal": self.translational_principal.tolist(),
            "stokes_radius": self.stokes_radius,
            "rotational_diffusion": self.rotational.tolist(),
            "rotational_axes": self.rotational_axes.tolist(),
            "mean_rotational_diffusion": self.mean_rotational,
            "relaxation_times": self.relaxation_times.tolist(),
            "harmonic_mean_relaxation_time": self.harmonic_mean_time,
            "volume": self.volume, "volume_source": self.volume_source,
            "errors": self.errors, "flow": None,
        }
        if self.flow is not None:
            f = self.flow
            b = f.bretherton
            data["flow"] = {
                "intrinsic_viscosity_high_frequency": f.intrinsic_viscosity.high_frequency,
                "intrinsic_viscosity_brownian_part": f.intrinsic_viscosity.brownian,
                "intrinsic_viscosity_zero_shear": f.intrinsic_viscosity.zero_shear,
                "bretherton_constant": b.constant, "bretherton_axis": b.axis.tolist(),
                "bretherton_residual": b.residual, "axisymmetric": b.axisymmetric,
                "equivalent_aspect_ratio": b.aspect_ratio, "jeffery_period_strain": b.jeffery_period,
                "jeffery_constants": f.jeffery_constants.tolist(), "jeffery_off_pattern": f.jeffery_off_pattern,
                "errors": f.errors,
            }
        if self.physical is not None:
            s = self.physical
            data["physical"] = {
                "temperature_K": s.temperature_K, "viscosity_Pa_s": s.viscosity_Pa_s, "length_unit_m": s.length_m,
                "translational_diffusion_m2_s": self.translational * s.translational,
                "stokes_radius_m": self.stokes_radius * s.length_m,
                "rotational_diffusion_1_s": (self.rotational * s.rotational).tolist(),
                "relaxation_times_s": (self.relaxation_times / s.rotational).tolist(),
                "harmonic_mean_relaxation_time_s": self.harmonic_mean_time / s.rotational,
                "centre_of_diffusion_m": (self.centre_of_diffusion * s.length_m).tolist(),
                "volume_m3": self.volume * s.length_m ** 3,
            }
        return data


def _principal_frame(rotational: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    values, vectors = np.linalg.eigh(0.5 * (rotational + rotational.T))
    axes = vectors.T.copy()
    if np.linalg.det(axes) < 0:
        axes[2] = -axes[2]
    return values, axes


def _diffusion_numbers(mobility: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(D_t, R_s, D_1, D_2, D_3, five taus, tau_h, centre of diffusion x, y, z) as one vector."""
    centre, moved = centre_of_diffusion(mobility, reference)
    translational = float(np.trace(moved[0:3, 0:3])) / 3.0
    rotational = np.linalg.eigvalsh(0.5 * (mobility[3:6, 3:6] + mobility[3:6, 3:6].T))
    times = favro_relaxation_times(rotational)
    return np.concatenate([[translational, 1.0 / (6 * np.pi * translational)], rotational, times,
                           [1.0 / (2.0 * rotational.sum())], centre])


def _linear_bound(function: Callable[[np.ndarray], np.ndarray], values: np.ndarray, errors: np.ndarray,
                  symmetric: bool = False) -> np.ndarray:
    """sum over entries of |d function / d entry| * error (central differences): a first-order,
    worst-case bound. ``symmetric``: entries (i, j) and (j, i) move together (by the larger bar)."""
    values = np.asarray(values, float)
    errors = np.asarray(errors, float)
    step = 1e-6 * max(float(np.abs(values).max()), 1e-300)
    total = np.zeros_like(np.asarray(function(values), float))
    for index in np.ndindex(values.shape):
        if symmetric and index[0] > index[1]:
            continue
        bar = max(errors[index], errors[index[::-1]]) if symmetric else errors[index]
        if bar == 0:
            continue
        delta = np.zeros_like(values)
        delta[index] = step
        if symmetric:
            delta[index[::-1]] = step
        total += np.abs(np.asarray(function(values + delta)) - np.asarray(function(values - delta))) / (2 * step) * bar
    return total


#: What a continuum job's /continuum group may hold that is used here (docs/output.md), and shapes.
_CONTINUUM_ITEMS = {"mobility": (6, 6), "mobility_error": (6, 6), "centroid": (3,), "velocity_per_strain": (6, 5),
                    "velocity_per_strain_error": (6, 5), "stresslet_per_strain": (5, 5),
                    "stresslet_per_strain_error": (5, 5)}


def _read_continuum(path: Path) -> dict[str, Any] | None:
    """/continuum's mobility (and its bar), centroid, volume and flow response, when the file has
    that group (a continuum job: lengths in the shape's unit, about the centroid, input axes)."""
    with h5py.File(path, "r") as handle:
        if "continuum" not in handle:
            return None
        group = handle["continuum"]
        found: dict[str, Any] = {"volume": float(group.attrs["volume"]) if "volume" in group.attrs else None}
        for name, shape in _CONTINUUM_ITEMS.items():
            value = np.asarray(group[name][()], float) if name in group else None
            if value is not None and (value.shape != shape or not np.all(np.isfinite(value))):
                raise ResultFileError(f"{path}: /continuum/{name} has shape {value.shape} or non-finite values, "
                                      f"expected finite {shape}")
            found[name] = value
        return found


def continuum_flow(result: BeadResult) -> Flow | None:
    """A continuum job's extrapolated flow response (/continuum velocity_per_strain, ...) as a
    :class:`Flow` on :data:`STRAIN_MODES`, None when the file has none."""
    continuum = _read_continuum(result.path)
    if continuum is None or continuum["velocity_per_strain"] is None or continuum["stresslet_per_strain"] is None:
        return None
    return Flow(strain_modes=STRAIN_MODES.copy(), velocity_per_strain=continuum["velocity_per_strain"],
                stresslet_per_strain=continuum["stresslet_per_strain"],
                velocity_per_strain_error=continuum["velocity_per_strain_error"],
                stresslet_per_strain_error=continuum["stresslet_per_strain_error"],
                attributes={"source": "/continuum"})


def diffusion_analysis(result: BeadResult, volume: float | None = None, allow_unconverged: bool = False,
                       friction: str = "default", scales: PhysicalScales | None = None) -> Diffusion:
    """The diffusion (and, with /flow, intrinsic viscosity and Bretherton) numbers of a result file.

    The mobility is /hydrodynamics' (checked as for ``coefficients``, about the centre of mass), else
    a continuum job's /continuum mobility (about /continuum/centroid, in the shape's unit; its flow
    response /continuum velocity_per_strain, ... when the file has no /flow). The volume is
    ``volume`` when given, else /continuum's, else N d^3 (a cubic lattice cell per bead, d = 1). Error bars come from
    /hydrodynamics/body_mobility_error (or /continuum/mobility_error) and the flow's bars.
    """
    path = result.path
    continuum = _read_continuum(path)
    if result.hydrodynamics is not None:
        mobility = checked_mobility(result, allow_unconverged=allow_unconverged, friction=friction)
        reference, source, unit = np.array(result.centre_of_mass, float), "hydrodynamics", "d"
    elif continuum is not None and continuum["mobility"] is not None and continuum["centroid"] is not None:
        mobility = 0.5 * (continuum["mobility"] + continuum["mobility"].T)
        reference, source, unit = continuum["centroid"], "continuum", "shape unit"
    else:
        raise MobilityError(f"{path}: no /hydrodynamics (and no /continuum mobility) in the file: run beadmob "
                            "with an &hydrodynamics group")
    if volume is not None:
        if not volume > 0:
            raise ValueError(f"the volume must be positive, got {volume}")
        volume_source = "given"
    elif continuum is not None and continuum["volume"] is not None:
        volume, volume_source = continuum["volume"], "/continuum volume"
    else:
        volume, volume_source = float(result.n_beads), BEAD_VOLUME_SOURCE

    numbers = _diffusion_numbers(mobility, reference)
    centre, moved = centre_of_diffusion(mobility, reference)
    rotational, axes = _principal_frame(mobility[3:6, 3:6])
    hydro = result.hydrodynamics

    to_model, errors, body, bar_matrix = None, None, None, None
    if hydro is not None and hydro.body_mobility_error is not None and hydro.body_axes is not None and friction == "default":
        body_axes = np.asarray(hydro.body_axes, float)
        body, bar_matrix = in_frame(mobility, body_axes), hydro.body_mobility_error

        def to_model(matrix: np.ndarray) -> np.ndarray:
            return in_frame(matrix, body_axes.T)
    elif source == "continuum" and continuum["mobility_error"] is not None:
        body, bar_matrix = mobility, continuum["mobility_error"]

        def to_model(matrix: np.ndarray) -> np.ndarray:
            return matrix

    if to_model is not None:
        bars = _linear_bound(lambda m: _diffusion_numbers(to_model(m), reference), body, bar_matrix, symmetric=True)
        errors = {"translational_diffusion": bars[0], "stokes_radius": bars[1],
                  "rotational_diffusion": bars[2:5].tolist(), "relaxation_times": bars[5:10].tolist(),
                  "harmonic_mean_relaxation_time": bars[10], "centre_of_diffusion": bars[11:14].tolist()}
        errors = {k: (float(v) if np.isscalar(v) else v) for k, v in errors.items()}

    flow = None
    response = usable_flow(result, allow_unconverged)
    if response is None and source == "continuum":
        response = continuum_flow(result)
    if response is not None:
        velocity, stresslet, velocity_error, stresslet_error = canonical_flow(response)
        rotation = velocity[3:6]
        viscosity_numbers = intrinsic_viscosity(rotation, stresslet, mobility[3:6, 3:6], volume)
        candidates = np.vstack([axes, result.body_axes])
        fit = bretherton_fit(rotation, candidates)
        constants, off = jeffery_constants(rotation, axes)
        flow_errors = _flow_errors(rotation, stresslet, mobility, volume, fit.axis, velocity_error, stresslet_error,
                                   (body, bar_matrix, to_model) if to_model is not None else None)
        flow = FlowProperties(viscosity_numbers, fit, constants, off, flow_errors)

    return Diffusion(
        path=str(path), source=source, length_unit=unit, reference_point=np.asarray(reference, float),
        centre_of_diffusion=centre,
        file_centre_of_mobility=None if hydro is None or hydro.centre_of_mobility is None else np.array(hydro.centre_of_mobility),
        diffusion=moved, translational=float(numbers[0]), translational_principal=np.linalg.eigvalsh(
            0.5 * (moved[0:3, 0:3] + moved[0:3, 0:3].T)),
        stokes_radius=float(numbers[1]), rotational=rotational, rotational_axes=axes,
        relaxation_times=numbers[5:10], harmonic_mean_time=float(numbers[10]), volume=float(volume),
        volume_source=volume_source, flow=flow, errors=errors, physical=scales,
    )


def _flow_errors(rotation, stresslet, mobility, volume, axis, velocity_error, stresslet_error, mobility_bars):
    """First-order worst-case bars of [eta] and B from the /flow bars and the mobility's bar."""
    if velocity_error is None and stresslet_error is None and mobility_bars is None:
        return None
    form = bretherton_form(axis)

    def numbers(c: np.ndarray, t: np.ndarray, m_rr: np.ndarray) -> np.ndarray:
        value = intrinsic_viscosity(c, t, m_rr, volume)
        return np.array([value.high_frequency, value.brownian, value.zero_shear,
                         np.sum(form * c) / np.sum(form * form)])

    total = np.zeros(4)
    if velocity_error is not None:
        total += _linear_bound(lambda c: numbers(c, stresslet, mobility[3:6, 3:6]), rotation, velocity_error[3:6])
    if stresslet_error is not None:
        total += _linear_bound(lambda t: numbers(rotation, t, mobility[3:6, 3:6]), stresslet, stresslet_error)
    if mobility_bars is not None:
        body, bars, to_model = mobility_bars
        total += _linear_bound(lambda m: numbers(rotation, stresslet, to_model(m)[3:6, 3:6]), body, bars,
                               symmetric=True)
    return dict(zip(("high_frequency", "brownian", "zero_shear", "bretherton"), map(float, total)))


def usable_flow(result: BeadResult, allow_unconverged: bool = False) -> Flow | None:
    """``result.flow`` (None without /flow) after the checks of its attributes (docs/output.md):
    ResultFileError when beadmob recorded no response (``response_available`` = 0: the friction block
    was not positive definite), MobilityError when it flagged a strain solve as not converged
    (``all_converged`` = 0) unless ``allow_unconverged``."""
    flow = result.flow
    if flow is None:
        return None
    if flow.attributes.get("response_available", 1) == 0:
        raise ResultFileError(f"{result.path}: /flow holds no response (response_available = 0: the friction "
                              "block was not positive definite)")
    if flow.attributes.get("all_converged", 1) == 0 and not allow_unconverged:
        raise MobilityError(f"{result.path}: beadmob flagged a strain solve of /flow as not converged "
                            "(/flow all_converged = 0); rerun, or pass --allow-unconverged to look at it anyway")
    return flow


def require_flow(result: BeadResult, allow_unconverged: bool = False) -> Flow:
    """:func:`usable_flow`, else a continuum job's :func:`continuum_flow`, else a ResultFileError
    naming how to get /flow."""
    if result.flow is None:
        response = continuum_flow(result) if result.hydrodynamics is None else None
        if response is None:
            raise ResultFileError(f"{result.path} has no /flow group: run with &hydrodynamics flow = .true.")
        return response
    return usable_flow(result, allow_unconverged)


__all__ = [
    "BOLTZMANN", "STRAIN_MODES", "Bretherton", "Diffusion", "FlowProperties", "IntrinsicViscosity",
    "PhysicalScales", "bretherton_fit", "bretherton_form", "canonical_flow", "centre_of_diffusion",
    "diffusion_analysis", "favro_relaxation_times", "intrinsic_viscosity", "jeffery_constants",
    "mode_amplitudes", "mode_generators", "mode_rotation", "physical_scales", "require_flow",
    "rotational_operator", "usable_flow", "continuum_flow",
]
