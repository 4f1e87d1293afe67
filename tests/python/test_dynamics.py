"""Tests of beadmob_post.dynamics against the paper's closed forms and invariants."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from beadmob_post import dynamics
from beadmob_post.mobility import compute_coefficients, pattern_mobility
from beadmob_post.results import load_result

SETTLER = dict(mu11=0.42, mu22=0.37, mu33=0.40, mu42=0.050, mu51=-0.067)  # arrowhead, tab_mob_num


def settler_mobility(**changes) -> np.ndarray:
    matrix = pattern_mobility(**{**SETTLER, **changes})
    matrix[3:6, 3:6] = np.diag([0.2, 0.25, 0.3])  # rr does not enter, any values
    return matrix


@pytest.mark.parametrize("axis, theta0", [("y", 179.0), ("y", 100.0), ("x", 175.0), ("x", 30.0)])
def test_planar_rotation_follows_the_closed_form(axis, theta0):
    # Paper, eqs. so51 and so42: tan(theta/2) = A exp(mu51 t) about y = Y, A exp(-mu42 t) about x.
    mobility = settler_mobility()
    rate = SETTLER["mu51"] if axis == "y" else -SETTLER["mu42"]
    trajectory = dynamics.integrate(mobility, dynamics.planar_orientation(theta0, axis), 150.0)
    closed = dynamics.planar_closed_form(np.radians(theta0), rate, trajectory.t)
    np.testing.assert_allclose(trajectory.theta, closed, atol=1e-8)
    np.testing.assert_allclose(np.tan(trajectory.theta / 2),
                               np.tan(np.radians(theta0) / 2) * np.exp(rate * trajectory.t), rtol=1e-7)
    # The rotation stays in its plane: the rotation axis keeps its direction.
    matrices = Rotation.from_quat(trajectory.quaternions).as_matrix()
    kept = 1 if axis == "y" else 0          # body y = lab Y, or body x = lab X, throughout
    np.testing.assert_allclose(matrices[:, :, kept], np.tile(np.eye(3)[kept], (len(matrices), 1)),
                               atol=1e-9)


def test_conserved_quantity_in_three_dimensions():
    # |g_x|^mu42 |g_y|^mu51 is constant along any orbit (classify module docstring).
    mu42, mu51 = SETTLER["mu42"], SETTLER["mu51"]
    trajectory = dynamics.integrate(settler_mobility(), dynamics.orientation(130.0, 40.0, 25.0), 60.0)
    g = trajectory.gravity_in_body
    invariant = np.abs(g[:, 0]) ** mu42 * np.abs(g[:, 1]) ** mu51
    np.testing.assert_allclose(invariant, invariant[0], rtol=1e-8)
    np.testing.assert_allclose(np.linalg.norm(trajectory.quaternions, axis=1), 1.0, atol=1e-15)


def test_settler_reaches_theta_zero_and_the_terminal_velocity():
    mobility = settler_mobility()
    trajectory = dynamics.integrate(mobility, dynamics.orientation(150.0, 70.0, -40.0), 400.0,
                                    n_samples=2001)
    assert trajectory.theta[-1] < 1e-6
    # At theta = 0 the centre of mass falls vertically with U = mu33 (eq. eq:mju33).
    velocity = np.diff(trajectory.position[-2:], axis=0)[0] / np.diff(trajectory.t[-2:])[0]
    np.testing.assert_allclose(velocity, [0.0, 0.0, -SETTLER["mu33"]], atol=1e-6)


def test_flutterer_keeps_rotating():
    # mu42 mu51 > 0: theta = 0 is not an attractor; the orbit is closed (periodic theta).
    mobility = settler_mobility(mu51=0.067)
    trajectory = dynamics.integrate(mobility, dynamics.orientation(60.0, 30.0, 40.0), 400.0,
                                    n_samples=4001)
    late = trajectory.theta[len(trajectory.theta) // 2:]
    assert late.min() > np.radians(5.0)
    assert late.max() - late.min() > np.radians(20.0)
    # Periodic: theta returns within a small distance of its start.
    returns = np.abs(trajectory.theta[100:] - trajectory.theta[0])
    assert returns.min() < np.radians(0.5)


def test_euler_angles_round_trip():
    for angles in [(30.0, 120.0, -45.0), (170.0, -60.0, 10.0), (90.0, 0.0, 0.0)]:
        matrix = dynamics.orientation(*angles).as_matrix()
        theta, phi, psi = dynamics.euler_angles(matrix[None])
        np.testing.assert_allclose(np.degrees([theta[0], phi[0], psi[0]]),
                                   [angles[0], angles[1], angles[2]], atol=1e-10)


def test_planar_start_about_x_keeps_body_x_along_lab_x():
    matrix = dynamics.planar_orientation(40.0, "x").as_matrix()
    np.testing.assert_allclose(matrix[:, 0], [1.0, 0.0, 0.0], atol=1e-15)
    assert np.degrees(np.arccos(matrix[2, 2])) == pytest.approx(40.0)


def test_bad_end_time():
    with pytest.raises(ValueError, match="end time must be positive"):
        dynamics.integrate(settler_mobility(), dynamics.orientation(10.0), -1.0)


def test_real_file_planar_rotation(real_hydro_file):
    c = compute_coefficients(load_result(real_hydro_file))
    trajectory = dynamics.integrate(c.dimensionless_body_mobility,
                                    dynamics.planar_orientation(170.0, "y"), 5.0 / abs(c.mu51))
    closed = dynamics.planar_closed_form(np.radians(170.0), c.mu51, trajectory.t)
    # The full body mobility holds solver noise outside the pattern (~1e-11): same curve.
    np.testing.assert_allclose(trajectory.theta, closed, atol=1e-7)
    assert trajectory.theta[-1] < trajectory.theta[0]
