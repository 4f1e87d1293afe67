"""Orientation of a rigid body of any shape in simple shear flow, from its response to linear flow
(``/flow/velocity_per_strain``, see :mod:`beadmob_post.brownian`).

Lab frame: u_inf = gamma y e_x, so E = gamma/2 (xy + yx) = gamma/sqrt2 E_1 and Omega_inf =
-gamma/2 e_z; time in units of 1/gamma, i.e. the strain gamma t. The body's orientation is the
rotation Q taking model coordinates to lab coordinates (Q = I: the body as in the input). The
lab strain's amplitudes e seen in the body are eps = D(Q)^T e (D(Q)[k, l] = E_k : (Q E_l Q^T)),
so with V the model-frame velocity_per_strain (rows U then Omega, about the centre of mass R0):

    Omega = Omega_inf + Q V[3:6] D(Q)^T e,   dQ/dt = [Omega]x Q,
    dX/dt = u_inf(X) + w,   w = Q V[0:3] D(Q)^T e   (the drift of R0 relative to the local flow).

Two integrators: ``quaternion`` (scipy solve_ivp DOP853 on the unit quaternion, renormalised,
dense output) and ``rkmk`` (Munthe-Kaas: classical RK4 on the rotation vector u of
Q = exp([u]x) Q_n over each step, du/dt = dexp_u^-1(Omega), then Rodrigues' formula, so Q stays
orthogonal to rounding). Periods are returns of a body axis (or of Q) to its start, found as
sign changes of g(t) = x'(0) . (x(t) - x(0)) with |x(t) - x(0)| small, refined by Brent's method on
the integrator's continuous solution.

For a body of revolution with Bretherton's constant B (Jeffery 1922 for spheroids) the axis p
follows Jeffery's orbits: azimuth phi from the flow direction x obeys
dphi/dt = -(1 - B cos 2 phi)/2 (period 2 pi (r_e + 1/r_e), r_e^2 = (1 + B)/(1 - B)), and
C = tan(theta) sqrt(cos^2 phi + r_e^2 sin^2 phi) / r_e (theta from the vorticity axis z) is
constant: d ln tan(theta)/dt = B sin(phi) cos(phi) = -(1/2) d ln(1 - B cos 2 phi)/dt (Jeffery's
orbit constant).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from beadmob_post.brownian import mode_rotation
from beadmob_post.mobility import skew

#: Lab strain amplitudes and vorticity of u = y e_x (shear rate 1).
SHEAR_STRAIN = np.array([1.0 / np.sqrt(2.0), 0.0, 0.0, 0.0, 0.0])
SHEAR_ROTATION = np.array([0.0, 0.0, -0.5])
METHODS = ("quaternion", "rkmk")


def rates(rotation: np.ndarray, velocity_per_strain: np.ndarray, shear_rate: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """(Omega, w): the lab angular velocity and the drift relative to the local flow for orientation Q."""
    body_strain = mode_rotation(rotation).T @ (shear_rate * SHEAR_STRAIN)
    omega = shear_rate * SHEAR_ROTATION + rotation @ (velocity_per_strain[3:6] @ body_strain)
    drift = rotation @ (velocity_per_strain[0:3] @ body_strain)
    return omega, drift


def rotation_vector_rate(u: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """du/dt = dexp_u^-1(Omega) = Omega - u x Omega / 2 + c(|u|) u x (u x Omega),
    c = (1 - (t/2) cot(t/2))/t^2 (-> 1/12), for Q = exp([u]x) Q_n with dQ/dt = [Omega]x Q."""
    angle = np.linalg.norm(u)
    c = 1.0 / 12.0 + angle**2 / 720.0 if angle < 1e-4 else (1.0 - 0.5 * angle / np.tan(0.5 * angle)) / angle**2
    cross = np.cross(u, omega)
    return omega - 0.5 * cross + c * np.cross(u, cross)


def exp_rotation(u: np.ndarray) -> np.ndarray:
    """exp([u]x) (Rodrigues)."""
    return Rotation.from_rotvec(u).as_matrix()


@dataclass(frozen=True)
class Orbit:
    """Samples of one integration in the strain gamma t."""

    strain: np.ndarray            # (n,)
    rotations: np.ndarray         # (n, 3, 3) model -> lab
    position: np.ndarray          # (n, 3) R0 in the lab (start at the origin, where u_inf = 0)
    drift: np.ndarray             # (n, 3) w = dX/dt - u_inf(X)
    angular_velocity: np.ndarray  # (n, 3)
    method: str
    #: Q at any strain in [0, end] from the integrator's continuous solution
    rotation_at: Callable[[float], np.ndarray] = field(repr=False, compare=False, default=None)

    def axis(self, model_vector: np.ndarray) -> np.ndarray:
        """(n, 3) lab direction of a body-fixed vector given in model coordinates."""
        return self.rotations @ np.asarray(model_vector, float)

    @property
    def orthogonality_error(self) -> float:
        """max over samples of |Q^T Q - I| (max norm)."""
        gram = np.einsum("nki,nkj->nij", self.rotations, self.rotations)
        return float(np.abs(gram - np.eye(3)).max())


def integrate(velocity_per_strain: np.ndarray, initial: np.ndarray, strain: float, samples: int = 2001,
              method: str = "quaternion", rtol: float = 1e-11, atol: float = 1e-13,
              steps_per_strain: int = 100) -> Orbit:
    """Integrate the orientation and the centre's path in shear from Q(0) = ``initial`` to ``strain``."""
    if not (strain > 0 and np.isfinite(strain)):
        raise ValueError(f"the strain must be positive and finite, got {strain}")
    if samples < 2:
        raise ValueError(f"at least 2 samples are needed, got {samples}")
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; use one of {', '.join(METHODS)}")
    velocity = np.asarray(velocity_per_strain, float)
    initial = np.asarray(initial, float)
    if velocity.shape != (6, 5):
        raise ValueError(f"velocity_per_strain must be 6x5, got {velocity.shape}")
    if not np.allclose(initial.T @ initial, np.eye(3), atol=1e-9) or np.linalg.det(initial) < 0:
        raise ValueError("the initial orientation must be a proper rotation")
    times = np.linspace(0.0, strain, samples)
    if method == "quaternion":
        rotation_at, positions = _integrate_quaternion(velocity, initial, strain, times, rtol, atol)
    else:
        rotation_at, positions = _integrate_rkmk(velocity, initial, strain, times, steps_per_strain)
    rotations = np.array([rotation_at(t) for t in times])
    pairs = [rates(q, velocity) for q in rotations]
    return Orbit(times, rotations, positions, np.array([p[1] for p in pairs]), np.array([p[0] for p in pairs]),
                 method, rotation_at)


def _integrate_quaternion(velocity, initial, strain, times, rtol, atol):
    def rhs(_t: float, state: np.ndarray) -> np.ndarray:
        q = state[0:4]
        norm2 = q @ q
        rotation = Rotation.from_quat(q / np.sqrt(norm2)).as_matrix()
        omega, drift = rates(rotation, velocity)
        vector, scalar = q[0:3], q[3]
        # lab-frame angular velocity: dq/dt = (Omega, 0) (x) q / 2, plus a pull back to |q| = 1
        dq = 0.5 * np.concatenate([scalar * omega + np.cross(omega, vector), [-omega @ vector]])
        dq += 0.5 * (1.0 - norm2) * q
        position = state[4:7]
        return np.concatenate([dq, drift + np.array([position[1], 0.0, 0.0])])

    state0 = np.concatenate([Rotation.from_matrix(initial).as_quat(), np.zeros(3)])
    solution = solve_ivp(rhs, (0.0, strain), state0, method="DOP853", rtol=rtol, atol=atol, dense_output=True)
    if not solution.success:
        raise RuntimeError(f"orientation integration failed: {solution.message}")
    dense = solution.sol

    def rotation_at(t: float) -> np.ndarray:
        q = dense(t)[0:4]
        return Rotation.from_quat(q / np.linalg.norm(q)).as_matrix()

    return rotation_at, dense(times)[4:7].T


def _integrate_rkmk(velocity, initial, strain, times, steps_per_strain):
    steps = max(int(np.ceil(strain * steps_per_strain)), 1)
    h = strain / steps
    nodes = np.empty((steps + 1, 3, 3))
    nodes[0] = initial
    positions = np.zeros((steps + 1, 3))

    def step(rotation: np.ndarray, position: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        def f(u: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            omega, drift = rates(exp_rotation(u) @ rotation, velocity)
            return rotation_vector_rate(u, omega), drift + np.array([x[1], 0.0, 0.0])

        u0 = np.zeros(3)
        k1, l1 = f(u0, position)
        k2, l2 = f(u0 + 0.5 * dt * k1, position + 0.5 * dt * l1)
        k3, l3 = f(u0 + 0.5 * dt * k2, position + 0.5 * dt * l2)
        k4, l4 = f(u0 + dt * k3, position + dt * l3)
        u = dt * (k1 + 2 * k2 + 2 * k3 + k4) / 6.0
        return exp_rotation(u) @ rotation, position + dt * (l1 + 2 * l2 + 2 * l3 + l4) / 6.0

    for n in range(steps):
        nodes[n + 1], positions[n + 1] = step(nodes[n], positions[n], h)

    def rotation_at(t: float) -> np.ndarray:
        n = min(int(np.floor(t / h)), steps)
        rest = t - n * h
        return nodes[n] if rest <= 0 else step(nodes[n], positions[n], rest)[0]

    def position_at(t: float) -> np.ndarray:
        n = min(int(np.floor(t / h)), steps)
        rest = t - n * h
        return positions[n] if rest <= 0 else step(nodes[n], positions[n], rest)[1]

    return rotation_at, np.array([position_at(t) for t in times])


# ----------------------------------------------------------------------------- periods
@dataclass(frozen=True)
class Return:
    """Returns of a body axis (or of the whole orientation) to its start."""

    period: float | None          # first return (strain), None when it does not return
    closure: float | None         # |x(period) - x(0)|
    returns: int                  # returns found in the integrated strain
    mean_period: float | None     # last return / returns
    fixed: bool = False           # x does not move at the start (a fixed point)


def find_return(orbit: Orbit, value: Callable[[np.ndarray], np.ndarray],
                rate: Callable[[np.ndarray, np.ndarray], np.ndarray], tolerance: float = 1e-5,
                per_strain: int = 20) -> Return:
    """First and later returns of x(t) = value(Q(t)) to x(0) (module docstring).

    ``rate(Q, Omega)`` is dx/dt; ``per_strain`` grid points per unit strain look for sign changes.
    """
    start_rotation = orbit.rotations[0]
    start = np.ravel(value(start_rotation))
    velocity = np.ravel(rate(start_rotation, orbit.angular_velocity[0]))
    if np.linalg.norm(velocity) < 1e-12:
        return Return(None, None, 0, None, fixed=True)
    end = float(orbit.strain[-1])
    grid = np.linspace(0.0, end, max(int(end * per_strain), len(orbit.strain)))

    def g(t: float) -> float:
        return float(velocity @ (np.ravel(value(orbit.rotation_at(t))) - start))

    values = np.array([g(t) for t in grid])
    found = []
    for k in range(1, len(grid)):
        if values[k - 1] < 0.0 <= values[k]:
            t = brentq(g, grid[k - 1], grid[k], xtol=1e-14, rtol=4 * np.finfo(float).eps)
            closure = float(np.linalg.norm(np.ravel(value(orbit.rotation_at(t))) - start))
            if closure < tolerance:
                found.append((t, closure))
    if not found:
        return Return(None, None, 0, None)
    return Return(found[0][0], found[0][1], len(found), found[-1][0] / len(found))


def axis_return(orbit: Orbit, model_vector: np.ndarray, tolerance: float = 1e-5) -> Return:
    """Returns of the body-fixed unit vector ``model_vector`` (model coordinates)."""
    vector = np.asarray(model_vector, float) / np.linalg.norm(model_vector)
    return find_return(orbit, lambda q: q @ vector, lambda q, omega: np.cross(omega, q @ vector), tolerance)


def orientation_return(orbit: Orbit, tolerance: float = 1e-5) -> Return:
    """Returns of the whole orientation Q (Frobenius distance)."""
    return find_return(orbit, lambda q: q, lambda q, omega: skew(omega) @ q, tolerance)


# ----------------------------------------------------------------------------- angles, invariants
def polar_angles(directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(theta, phi) of unit vectors (n, 3): theta from the vorticity axis z, phi (unwrapped) the
    azimuth from the flow direction x towards the gradient direction y."""
    theta = np.arccos(np.clip(directions[:, 2], -1.0, 1.0))
    phi = np.unwrap(np.arctan2(directions[:, 1], directions[:, 0]))
    return theta, phi


def jeffery_orbit_constant(directions: np.ndarray, bretherton: float) -> np.ndarray:
    """Jeffery's C = tan(theta) sqrt(cos^2 phi + r^2 sin^2 phi)/r along the samples (inf in the
    flow-gradient plane); needs |B| < 1 (module docstring)."""
    if not abs(bretherton) < 1:
        raise ValueError(f"Jeffery's orbit constant needs |B| < 1, got B = {bretherton}")
    r2 = (1 + bretherton) / (1 - bretherton)
    x, y, z = directions.T
    with np.errstate(divide="ignore"):
        return np.sqrt(x * x + r2 * y * y) / np.abs(z) / np.sqrt(r2)


def minimal_rotation(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The rotation by the smallest angle taking the direction ``source`` to ``target``."""
    a = np.asarray(source, float) / np.linalg.norm(source)
    b = np.asarray(target, float) / np.linalg.norm(target)
    axis = np.cross(a, b)
    sine, cosine = np.linalg.norm(axis), float(a @ b)
    if sine < 1e-12:
        if cosine > 0:
            return np.eye(3)
        helper = np.eye(3)[np.argmin(np.abs(a))]
        axis = np.cross(a, helper)
        return Rotation.from_rotvec(np.pi * axis / np.linalg.norm(axis)).as_matrix()
    return Rotation.from_rotvec(axis / sine * np.arctan2(sine, cosine)).as_matrix()


def orbit_figure(orbit: Orbit, axes: dict[str, np.ndarray], title: str = ""):
    """Two panels against the strain: the angle of each followed body axis from the vorticity axis
    z, and its azimuth from the flow direction x (in units of pi)."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(9, 6), layout="constrained")
    top, bottom = figure.subplots(2, 1, sharex=True)
    for name, vector in axes.items():
        theta, phi = polar_angles(orbit.axis(vector))
        top.plot(orbit.strain, np.degrees(theta), label=name)
        bottom.plot(orbit.strain, phi / np.pi, label=name)
    top.set_ylabel("angle from vorticity z (deg)")
    top.set_ylim(0, 180)
    bottom.set_ylabel("azimuth from flow x (pi)")
    bottom.set_xlabel(r"strain $\dot\gamma t$")
    top.legend(fontsize="small", ncols=min(len(axes), 4))
    if title:
        figure.suptitle(title)
    return figure


def summary(orbit: Orbit, axes: dict[str, np.ndarray], bretherton: Any = None, tolerance: float = 1e-5) -> dict[str, Any]:
    """The JSON summary of ``beadmob-post orbit``: per followed axis its start and end in the lab
    and its return; the orientation's return; Jeffery's prediction and orbit constant for a body of
    revolution; the drift; the integration's orthogonality error."""
    data: dict[str, Any] = {"strain": float(orbit.strain[-1]), "samples": len(orbit.strain), "method": orbit.method,
                            "initial_rotation": orbit.rotations[0].tolist(), "axes": {}}
    for name, vector in axes.items():
        found = axis_return(orbit, vector, tolerance)
        lab = orbit.axis(vector)
        data["axes"][name] = {"model_direction": (np.asarray(vector) / np.linalg.norm(vector)).tolist(),
                              "initial_lab": lab[0].tolist(), "final_lab": lab[-1].tolist(),
                              "period": found.period, "closure": found.closure, "returns": found.returns,
                              "mean_period": found.mean_period, "fixed": found.fixed}
    whole = orientation_return(orbit, tolerance)
    data["orientation"] = {"period": whole.period, "closure": whole.closure, "returns": whole.returns,
                           "mean_period": whole.mean_period}
    if bretherton is not None:
        item: dict[str, Any] = {"constant": bretherton.constant, "axis": bretherton.axis.tolist(),
                                "residual": bretherton.residual, "axisymmetric": bretherton.axisymmetric,
                                "jeffery_period": bretherton.jeffery_period}
        if bretherton.axisymmetric and abs(bretherton.constant) < 1:
            constant = jeffery_orbit_constant(orbit.axis(bretherton.axis), bretherton.constant)
            finite = np.isfinite(constant)
            item["orbit_constant"] = float(constant[0]) if finite[0] else None
            # C ~ 0 (the axis within 1e-8 of the vorticity, a fixed point): no relative change, the
            # absolute one
            change = float(np.abs(constant - constant[0]).max()) if finite.all() else None
            item["orbit_constant_change"] = change
            item["orbit_constant_relative_change"] = (
                change / abs(constant[0]) if change is not None and abs(constant[0]) > 1e-8 else None)
        data["bretherton"] = item
    mean_drift = np.trapezoid(orbit.drift, orbit.strain, axis=0) / orbit.strain[-1]
    data["drift"] = {"mean": mean_drift.tolist(), "largest": float(np.linalg.norm(orbit.drift, axis=1).max()),
                     "final_position": orbit.position[-1].tolist()}
    data["orthogonality_error"] = orbit.orthogonality_error
    return data


__all__ = ["METHODS", "Orbit", "Return", "axis_return", "find_return", "integrate", "jeffery_orbit_constant",
           "minimal_rotation", "orbit_figure", "orientation_return", "polar_angles", "rates", "summary"]
