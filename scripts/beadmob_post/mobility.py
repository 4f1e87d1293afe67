"""The paper's mobility coefficients from the 6x6 friction/mobility of a result file.

Conventions (paper, section "Theoretical background"): rows (U, Omega), columns (F, T); U is
the velocity of the centre of mass, about which gravity exerts no torque. In the body frame
(x, y normal to the two mirror planes, x along the larger in-plane size, z oriented so that
theta = 0 is the stable orientation) the dimensionless blocks have the form of eq. `matrices`:

    pi eta L mu_tt   = diag(mu11, mu22, mu33),
    pi eta L^2 mu_rt = [[0, mu42, 0], [mu51, 0, 0], [0, 0, 0]].

That form is exact for two mirror planes (a vector component and a pseudo-vector component
couple only when the reflection flips exactly one of them); what a bead model leaves outside
it is reported as the off-pattern entries. beadmob writes eta = 1 and lengths in d.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from beadmob_post.paper import COEFFICIENT_NAMES
from beadmob_post.results import BeadResult, ResultFileError

#: Above this 2-norm condition number the friction matrix is treated as singular.
SINGULAR_CONDITION = 1e12
#: Largest accepted |mobility @ friction - I| (max norm) when the file holds both.
INVERSE_TOLERANCE = 1e-6
#: Mirror planes the paper's particles have: normal to body x and y, not z.
PAPER_MIRROR_PLANES = (1.0, 1.0, 0.0)

_AXES = "xyz"

#: Which friction of /hydrodynamics the coefficients come from (option ``--friction``):
#: ``default`` = ``friction`` (with the lubrication correction when the run had it on),
#: ``multipole`` = ``multipole_friction`` (the order-L friction alone, no lubrication correction).
FRICTION_CHOICES = ("default", "multipole")


class MobilityError(ResultFileError):
    """The hydrodynamics of a result file cannot be used (message names file and problem)."""


@dataclass(frozen=True)
class OffPatternEntry:
    """A dimensionless entry that eq. `matrices` assumes to be zero."""

    block: str       # "tt", "rt" (the paper's two blocks) or "rr"
    row: str         # body axis of the velocity component
    column: str      # body axis of the force (tt, rt) or torque (rr) component
    value: float     # dimensionless (pi eta L^k times the mobility entry)
    relative: float  # |value| / max |mu_ij| of the five coefficients


@dataclass(frozen=True)
class Coefficients:
    """The paper's coefficients of one result file, with the frame they refer to."""

    path: str
    shape: str
    n_beads: int
    reference_length: float                 # L in d
    mu11: float
    mu22: float
    mu33: float
    mu42: float
    mu51: float
    #: rows = body x, y, z in the input coordinates.
    body_axes: np.ndarray
    #: the 6x6 mobility in the body frame, dimensionless: blocks times pi L, pi L^2, pi L^3.
    dimensionless_body_mobility: np.ndarray
    #: True when z was turned (pi about x) from /geometry/body_axes to make theta = 0 stable.
    z_reversed: bool
    #: True when x and y of /geometry/body_axes were exchanged to put x along the larger size.
    xy_swapped: bool
    #: largest |tt, rt entry outside the pattern| / largest |coefficient| (as beadmob's attribute).
    off_pattern: float
    off_pattern_entries: tuple[OffPatternEntry, ...]
    #: mirror planes of the beads (None when not recorded) and whether they are the paper's.
    mirror_planes: tuple[float, ...] | None
    paper_class: bool | None
    multipole_order: int | None
    #: whether the coefficients include the lubrication correction (False with
    #: ``friction="multipole"`` even when the run had it on)
    lubrication: bool | None
    all_converged: bool | None
    extra: dict = field(default_factory=dict)
    #: the friction used: "default" (/hydrodynamics/friction) or "multipole" (multipole_friction)
    friction: str = "default"
    #: whether the run had the lubrication correction on (/hydrodynamics attribute lubrication)
    run_lubrication: bool | None = None
    #: the run's own error bar (None when the file has no error estimate or another friction is used)
    error_bar: "ErrorBar | None" = None

    def values(self) -> tuple[float, float, float, float, float]:
        return (self.mu11, self.mu22, self.mu33, self.mu42, self.mu51)

    def as_dict(self) -> dict[str, float]:
        return dict(zip(COEFFICIENT_NAMES, self.values()))

    @property
    def ratio_51_42(self) -> float:
        """|mu51/mu42| (Table `tab_mob_num`); inf when mu42 = 0."""
        return abs(self.mu51 / self.mu42) if self.mu42 != 0 else float("inf")

    @property
    def sum_over_51(self) -> float:
        """(mu51 + mu42)/|mu51| (Table `tab_mob_num`, stability of planar rotations)."""
        return (self.mu51 + self.mu42) / abs(self.mu51) if self.mu51 != 0 else float("inf")


def skew(vector: np.ndarray) -> np.ndarray:
    """The matrix [r]x with [r]x v = r x v."""
    x, y, z = vector
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def shift_reference_point(mobility: np.ndarray, displacement: np.ndarray) -> np.ndarray:
    """The 6x6 mobility about the point P + ``displacement`` from the mobility about P.

    With r = displacement: U_new = U - r x Omega and T_P = T_new + r x F, so
    M_new = S M S^T with S = [[I, -[r]x], [0, I]] (rigid-body kinematics).
    """
    shift = np.eye(6)
    shift[0:3, 3:6] = -skew(np.asarray(displacement, dtype=float))
    return shift @ mobility @ shift.T


def in_frame(matrix: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """The 6x6 ``matrix`` in the frame whose rows ``axes`` are given in its coordinates.

    Both vector triples (translation, rotation) turn with the same proper rotation A, so each
    3x3 block B becomes A B A^T.
    """
    rotation = np.zeros((6, 6))
    rotation[0:3, 0:3] = axes
    rotation[3:6, 3:6] = axes
    return rotation @ matrix @ rotation.T


def dimensionless(body_mobility: np.ndarray, reference_length: float) -> np.ndarray:
    """Blocks tt, rt/tr, rr multiplied by pi L, pi L^2, pi L^3 (eta = 1; eq. `matrices`)."""
    scale = np.empty((6, 6))
    scale[0:3, 0:3] = np.pi * reference_length
    scale[3:6, 0:3] = np.pi * reference_length**2
    scale[0:3, 3:6] = np.pi * reference_length**2
    scale[3:6, 3:6] = np.pi * reference_length**3
    return body_mobility * scale


def checked_mobility(
    result: BeadResult, allow_unconverged: bool = False, friction: str = "default"
) -> np.ndarray:
    """The 6x6 mobility about the centre of mass, in input coordinates, after the checks.

    ``friction`` chooses the matrix it is the inverse of: ``"default"`` is
    /hydrodynamics/friction (with the lubrication correction when the run had it on; the stored
    mobility is checked against it), ``"multipole"`` /hydrodynamics/multipole_friction (the
    order-L friction alone). Raises :class:`MobilityError` when the file has no /hydrodynamics
    (or no multipole_friction when asked for), beadmob flagged a solve as not converged (unless
    ``allow_unconverged``), the friction is singular or not positive definite, or the stored
    mobility is not its inverse.
    """
    path = result.path
    hydro = result.hydrodynamics
    if friction not in FRICTION_CHOICES:
        raise MobilityError(
            f"{path}: unknown friction {friction!r}; use one of {', '.join(FRICTION_CHOICES)}"
        )
    if hydro is None:
        raise MobilityError(
            f"{path}: no /hydrodynamics in the file (run beadmob with an &hydrodynamics group)"
        )
    if hydro.all_converged is False and not allow_unconverged:
        reasons = hydro.attributes.get("solve_converged_reason")
        detail = f"; PETSc converged reasons {[int(r) for r in np.ravel(reasons)]}" if reasons is not None else ""
        raise MobilityError(
            f"{path}: beadmob flagged the mobility solves as not converged "
            f"(/hydrodynamics all_converged = 0{detail}); rerun with a tighter or longer "
            "solve, or pass --allow-unconverged to look at it anyway"
        )
    if friction == "multipole":
        if hydro.multipole_friction is None:
            raise MobilityError(
                f"{path}: no /hydrodynamics/multipole_friction (the order-L friction without "
                "the lubrication correction) in the file; it was written by an older beadmob: "
                "use the default friction or rerun"
            )
        matrix, name = hydro.multipole_friction, "/hydrodynamics/multipole_friction"
    else:
        matrix, name = hydro.friction, "the 6x6 friction matrix"
    condition = np.linalg.cond(matrix)
    if not np.isfinite(condition) or condition > SINGULAR_CONDITION:
        raise MobilityError(
            f"{path}: {name} is singular (condition number {condition:.3g}); "
            "no mobility exists for it"
        )
    symmetric = 0.5 * (matrix + matrix.T)
    if np.linalg.eigvalsh(symmetric).min() <= 0.0:
        raise MobilityError(
            f"{path}: {name} is not positive definite, so it is not the "
            "friction of a rigid body"
        )
    # The stored mobility is the inverse of /hydrodynamics/friction only.
    mobility = hydro.mobility if friction == "default" else None
    if mobility is None:
        mobility = np.linalg.inv(matrix)
    else:
        mismatch = np.abs(mobility @ matrix - np.eye(6)).max()
        if mismatch > INVERSE_TOLERANCE:
            raise MobilityError(
                f"{path}: /hydrodynamics/mobility is not the inverse of the friction "
                f"(|M Z - I| = {mismatch:.3g})"
            )
    # Reciprocity makes the mobility symmetric; its antisymmetric part is solver error
    # (beadmob's symmetry_error, ~1e-16 for the variational friction). Symmetrising also keeps
    # files of beadmob versions that stored the Fortran matrices transposed readable.
    mobility = 0.5 * (mobility + mobility.T)
    return _about_centre_of_mass(result, mobility)


def _about_centre_of_mass(result: BeadResult, mobility: np.ndarray) -> np.ndarray:
    """Move the mobility to the centre of mass when the file says it is about another point."""
    point = result.hydrodynamics.attributes.get("reference_point", "centre of mass")
    if isinstance(point, str) and point.strip().lower() in ("centre of mass", "center of mass"):
        return mobility
    position = result.hydrodynamics.attributes.get("reference_point_position")
    if position is None or np.shape(position) != (3,):
        raise MobilityError(
            f"{result.path}: mobility about {point!r}, not the centre of mass, and no "
            "reference_point_position attribute to move it"
        )
    return shift_reference_point(mobility, result.centre_of_mass - np.asarray(position, float))


def paper_frame(result: BeadResult, mobility: np.ndarray) -> tuple[np.ndarray, bool, bool]:
    """Body axes (rows) of the paper's frame for ``mobility`` (input coordinates).

    Starts from /geometry/body_axes (mirror-plane normals found from the beads), puts x along
    the larger of the x and y extents, then turns the frame by pi about x when needed so that
    mu51 < 0 (or, when mu51 = 0, mu42 > 0): theta = 0 is then the stable orientation of the
    planar rotations d theta/dt = mu51 sin theta and -mu42 sin theta (paper, eqs.
    `eq:theta_51_exp`, `eq:theta_42_exp`). Returns (axes, z_reversed, xy_swapped).
    """
    axes = np.array(result.body_axes, dtype=float)
    xy_swapped = bool(result.extent[1] > result.extent[0] + 1e-9)
    if xy_swapped:
        axes = np.array([axes[1], axes[0], -axes[2]])  # still right-handed
    body = in_frame(mobility, axes)
    mu51, mu42 = body[4, 0], body[3, 1]
    z_reversed = bool(mu51 > 0.0 or (mu51 == 0.0 and mu42 < 0.0))
    if z_reversed:
        axes = np.array([axes[0], -axes[1], -axes[2]])  # pi about x: mu42, mu51 change sign
    return axes, z_reversed, xy_swapped


def off_pattern_entries(
    dimensionless_mobility: np.ndarray, coefficients: np.ndarray
) -> tuple[OffPatternEntry, ...]:
    """Entries of the tt, rt (eq. `matrices`) and rr blocks that the paper's form sets to zero.

    rr has no printed form in the paper; its off-diagonal entries vanish for two mirror planes
    by the same argument and are listed too. tr = rt^T for a symmetric mobility and is omitted.
    """
    largest = float(np.abs(coefficients).max()) or 1.0
    entries = []
    blocks = {
        "tt": (dimensionless_mobility[0:3, 0:3], {(0, 0), (1, 1), (2, 2)}),
        "rt": (dimensionless_mobility[3:6, 0:3], {(0, 1), (1, 0)}),
        "rr": (dimensionless_mobility[3:6, 3:6], {(0, 0), (1, 1), (2, 2)}),
    }
    for name, (block, pattern) in blocks.items():
        for row in range(3):
            for column in range(3):
                if (row, column) not in pattern:
                    value = float(block[row, column])
                    entries.append(OffPatternEntry(
                        name, _AXES[row], _AXES[column], value, abs(value) / largest
                    ))
    return tuple(entries)


def compute_coefficients(
    result: BeadResult,
    reference_length: float | None = None,
    allow_unconverged: bool = False,
    friction: str = "default",
) -> Coefficients:
    """The paper's mu11, mu22, mu33, mu42, mu51 of ``result`` (see the module docstring).

    ``reference_length`` (in d) overrides L of the file (/shape reference_length);
    ``friction="multipole"`` uses the order-L friction without the lubrication correction
    (see :func:`checked_mobility`).
    """
    mobility = checked_mobility(result, allow_unconverged=allow_unconverged, friction=friction)
    length = reference_length if reference_length is not None else result.reference_length
    if length is None or not length > 0:
        raise MobilityError(
            f"{result.path}: no reference length L in the file (/shape reference_length); "
            "give one with --reference-length"
        )
    axes, z_reversed, xy_swapped = paper_frame(result, mobility)
    body = dimensionless(in_frame(mobility, axes), length)
    values = np.array([body[0, 0], body[1, 1], body[2, 2], body[3, 1], body[4, 0]])
    entries = off_pattern_entries(body, values)
    off_pattern = max((e.relative for e in entries if e.block in ("tt", "rt")), default=0.0)
    mirror = tuple(float(v) for v in result.mirror_planes) if result.mirror_planes is not None else None
    hydro = result.hydrodynamics
    return Coefficients(
        path=str(result.path),
        shape=result.shape_name,
        n_beads=result.n_beads,
        reference_length=float(length),
        mu11=float(values[0]), mu22=float(values[1]), mu33=float(values[2]),
        mu42=float(values[3]), mu51=float(values[4]),
        body_axes=axes,
        dimensionless_body_mobility=body,
        z_reversed=z_reversed,
        xy_swapped=xy_swapped,
        off_pattern=off_pattern,
        off_pattern_entries=entries,
        mirror_planes=mirror,
        paper_class=None if mirror is None else mirror == PAPER_MIRROR_PLANES,
        multipole_order=hydro.multipole_order,
        lubrication=False if friction == "multipole" else hydro.lubrication,
        all_converged=hydro.all_converged,
        friction=friction,
        run_lubrication=hydro.lubrication,
        error_bar=_error_bar_of(result, axes, float(length), body, friction),
    )


@dataclass(frozen=True)
class ErrorBar:
    """The error bar of a run (beadmob's docs/theory.md T14) in the frame of :class:`Coefficients`.

    From the run's order-L mobility M and its companion's of order L - 1, M': with the step
    s_ij = |M_ij - M'_ij| / sqrt(M_ii M_jj) and b_ij the largest step in the 3x3 block of (i, j),
    the estimated error of entry (i, j) is max(f_entry s_ij, f_block b_ij) on the scale
    sqrt(M_ii M_jj); the extrapolated value M + rho (M - M') has the estimated error
    max(g_entry s_ij, g_block b_ij). The factors (f_entry, f_block, rho, g_entry, g_block) are the
    file's attribute ``error_estimate_factors``, so this equals beadmob's own
    ``coefficient_error`` in its frame (a test checks it).
    """

    companion_order: int
    #: absolute estimated error of mu11 ... mu51 (coefficient units)
    errors: tuple[float, ...]
    extrapolated: tuple[float, ...]
    extrapolated_errors: tuple[float, ...]
    #: the same errors on the scale sqrt(M_ii M_jj) (relative for mu11 ... mu33)
    scaled_errors: tuple[float, ...]
    #: largest estimated error over the 36 entries of the mobility, on that scale
    largest: float
    largest_extrapolated: float


#: (row, column) of the dimensionless body mobility behind mu11, mu22, mu33, mu42, mu51
COEFFICIENT_ENTRIES = ((0, 0), (1, 1), (2, 2), (3, 1), (4, 0))


def error_bar(body: np.ndarray, companion_body: np.ndarray, factors, companion_order: int) -> ErrorBar:
    """The :class:`ErrorBar` of two dimensionless body mobilities of one run (orders L, L - 1)."""
    entry, block_factor, rho, ext_entry, ext_block = (float(f) for f in factors)
    diagonal = np.sqrt(np.abs(np.diag(body)))
    scale = np.outer(diagonal, diagonal)
    step = np.abs(body - companion_body) / scale
    block = np.zeros((6, 6))
    for i in range(6):
        for j in range(6):
            block[i, j] = step[3 * (i // 3):3 * (i // 3) + 3, 3 * (j // 3):3 * (j // 3) + 3].max()
    scaled = np.maximum(entry * step, block_factor * block)
    extrapolated = body + rho * (body - companion_body)
    scaled_ext = np.maximum(ext_entry * step, ext_block * block)
    pick = (lambda m: tuple(float(m[i, j]) for i, j in COEFFICIENT_ENTRIES))
    return ErrorBar(companion_order=companion_order, errors=pick(scaled * scale), extrapolated=pick(extrapolated),
                    extrapolated_errors=pick(scaled_ext * scale), scaled_errors=pick(scaled),
                    largest=float(scaled.max()), largest_extrapolated=float(scaled_ext.max()))


def _error_bar_of(result: BeadResult, axes: np.ndarray, length: float, body: np.ndarray,
                  friction: str) -> ErrorBar | None:
    """The run's error bar in this frame, when the file has one for the friction used."""
    hydro = result.hydrodynamics
    factors = hydro.attributes.get("error_estimate_factors")
    if friction != "default" or hydro.companion_friction is None or factors is None:
        return None
    companion = dimensionless(in_frame(np.linalg.inv(hydro.companion_friction), axes), length)
    return error_bar(body, companion, np.ravel(factors), int(hydro.attributes.get("companion_order", 0)))


def pattern_mobility(mu11: float, mu22: float, mu33: float, mu42: float, mu51: float) -> np.ndarray:
    """The dimensionless tt and rt blocks of eq. `matrices` as a 6x6 (tr = rt^T, rr = 0)."""
    matrix = np.zeros((6, 6))
    matrix[0:3, 0:3] = np.diag([mu11, mu22, mu33])
    matrix[3, 1], matrix[4, 0] = mu42, mu51
    matrix[0:3, 3:6] = matrix[3:6, 0:3].T
    return matrix
