"""Rigid-body orientation (and centre-of-mass path) of a settling body, in full 3-D.

Lab frame XYZ with the force F = -F Z (paper, section "Theoretical background"); the body
frame xyz of eq. `matrices`; R (body -> lab) kept as a unit quaternion q (scalar last, as in
scipy.spatial.transform.Rotation). In the dimensionless time t of eq. `eq:time`, with lengths
in L and M the dimensionless body mobility (tt block times pi eta L, rt block times
pi eta L^2):

    f = R^T (-Z)               force direction in the body frame
    Omega = M_rt f             body angular velocity,   dq/dt = q (x) (Omega, 0) / 2
    dX/dt = R M_tt f           centre-of-mass velocity in the lab frame

Angles: theta = angle between z and Z (cos theta = R_zz), phi = azimuth of z in the XY plane,
psi = spin about z; R = Rz(phi) Ry(theta) Rz(psi) (intrinsic Z-Y-Z Euler angles).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

#: Initial orientations of section "Specification of the initial orientations", as
#: (theta, phi, psi) in degrees: rotation about y = Y (phi = psi = 0) and about x = X.
ROTATION_PLANES = {"y": (0.0, 0.0), "x": (90.0, -90.0)}


def orientation(theta_deg: float, phi_deg: float = 0.0, psi_deg: float = 0.0) -> Rotation:
    """R = Rz(phi) Ry(theta) Rz(psi) (angles in degrees)."""
    return Rotation.from_euler("ZYZ", [phi_deg, theta_deg, psi_deg], degrees=True)


def planar_orientation(theta_deg: float, axis: str) -> Rotation:
    """Orientation tilted by theta about body y = lab Y (``axis="y"``) or x = X (``"x"``)."""
    phi, psi = ROTATION_PLANES[axis]
    return orientation(theta_deg, phi, psi)


def euler_angles(matrices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(theta, phi, psi) in radians of rotation matrices (..., 3, 3), phi and psi unwrapped.

    Read directly from the matrix (R_zz = cos theta, third column = body z in the lab,
    third row = lab Z in the body) so that theta = 0 raises no gimbal-lock warning.
    """
    theta = np.arccos(np.clip(matrices[..., 2, 2], -1.0, 1.0))
    phi = np.unwrap(np.arctan2(matrices[..., 1, 2], matrices[..., 0, 2]))
    psi = np.unwrap(np.arctan2(matrices[..., 2, 1], -matrices[..., 2, 0]))
    return theta, phi, psi


@dataclass(frozen=True)
class Trajectory:
    """Samples of one integration, dimensionless time t (eq. `eq:time`), lengths in L."""

    t: np.ndarray            # (n,)
    quaternions: np.ndarray  # (n, 4), scalar last
    position: np.ndarray     # (n, 3) centre of mass in the lab frame
    theta: np.ndarray
    phi: np.ndarray
    psi: np.ndarray

    @property
    def gravity_in_body(self) -> np.ndarray:
        """(n, 3): lab Z in body coordinates (g of classify's orientation equation)."""
        return Rotation.from_quat(self.quaternions).as_matrix()[:, 2, :]


def _right_hand_side(mobility: np.ndarray):
    tt, rt = mobility[0:3, 0:3], mobility[3:6, 0:3]

    def rhs(_t: float, state: np.ndarray) -> np.ndarray:
        q = state[0:4] / np.linalg.norm(state[0:4])
        matrix = Rotation.from_quat(q).as_matrix()
        force = -matrix[2, :]                  # R^T (-Z): third row of R, negated
        omega = rt @ force
        vector, scalar = q[0:3], q[3]
        dq = 0.5 * np.concatenate([scalar * omega + np.cross(vector, omega),
                                   [-vector @ omega]])
        dx = matrix @ (tt @ force)
        return np.concatenate([dq, dx])

    return rhs


def integrate(
    mobility: np.ndarray,
    start: Rotation,
    t_end: float,
    n_samples: int = 400,
    rtol: float = 1e-10,
    atol: float = 1e-12,
) -> Trajectory:
    """Integrate the orientation and position from ``start`` to dimensionless time ``t_end``.

    ``mobility`` is the dimensionless 6x6 body mobility (only its tt and rt blocks enter).
    scipy's ``solve_ivp`` (DOP853) integrates the quaternion; it is renormalised on output.
    """
    if not (t_end > 0 and np.isfinite(t_end)):
        raise ValueError(f"the end time must be positive and finite, got {t_end}")
    state0 = np.concatenate([start.as_quat(), np.zeros(3)])
    times = np.linspace(0.0, t_end, n_samples)
    solution = solve_ivp(
        _right_hand_side(np.asarray(mobility, dtype=float)), (0.0, t_end), state0,
        method="DOP853", t_eval=times, rtol=rtol, atol=atol,
    )
    if not solution.success:
        raise RuntimeError(f"orientation integration failed: {solution.message}")
    quaternions = solution.y[0:4].T
    quaternions /= np.linalg.norm(quaternions, axis=1, keepdims=True)
    theta, phi, psi = euler_angles(Rotation.from_quat(quaternions).as_matrix())
    return Trajectory(solution.t, quaternions, solution.y[4:7].T, theta, phi, psi)


def planar_closed_form(theta0: float, rate: float, t: np.ndarray) -> np.ndarray:
    """theta(t) from tan(theta/2) = tan(theta0/2) exp(rate t) (paper, eqs. `so51`, `so42`).

    rate = mu51 for rotation about y = Y, -mu42 for rotation about x = X; radians.
    """
    return 2.0 * np.arctan(np.tan(theta0 / 2.0) * np.exp(rate * np.asarray(t)))


def default_end_time(mu42: float, mu51: float, mu_scale: float) -> float:
    """A time long enough to see the motion: about 12 e-folds of the slower planar rotation."""
    rates = [abs(m) for m in (mu42, mu51) if abs(m) > 1e-9 * mu_scale]
    if not rates:
        return 10.0
    return 12.0 / min(rates)


def write_csv(trajectory: Trajectory, path, time_unit_s: float | None = None) -> None:
    """CSV: t, [t_s], theta_deg, phi_deg, psi_deg, tan_half_theta, qx, qy, qz, qw, X, Y, Z."""
    columns = [trajectory.t]
    names = ["t"]
    if time_unit_s is not None:
        columns.append(trajectory.t * time_unit_s)
        names.append("t_s")
    columns += [np.degrees(trajectory.theta), np.degrees(trajectory.phi),
                np.degrees(trajectory.psi), np.tan(trajectory.theta / 2.0)]
    names += ["theta_deg", "phi_deg", "psi_deg", "tan_half_theta"]
    columns += list(trajectory.quaternions.T) + list(trajectory.position.T)
    names += ["qx", "qy", "qz", "qw", "X_over_L", "Y_over_L", "Z_over_L"]
    np.savetxt(path, np.column_stack(columns), delimiter=",", header=",".join(names),
               comments="", fmt="%.10g")
