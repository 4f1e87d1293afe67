"""beadmob_post.orbit and `beadmob-post orbit`: a rigid body's orientation in the shear flow
u = gamma y e_x, against exact references:

- a spheroid of aspect ratio r built by hand from Bretherton's form Omega - Omega_inf =
  B p x (E.p), B = (r^2 - 1)/(r^2 + 1): Jeffery's (1922) period 2 pi (r + 1/r)/gamma and his orbit
  constant C = tan(theta) sqrt(cos^2 phi + r^2 sin^2 phi)/r;
- a sphere turns rigidly with -gamma/2 about z;
- a triaxial ellipsoid with Jeffery's Omega_i - Omega_inf_i = (a_j^2 - a_k^2)/(a_j^2 + a_k^2) E_jk:
  Q stays orthogonal, the two integrators (scipy DOP853 on the quaternion, Munthe-Kaas RK4 on SO(3))
  agree and the second converges at fourth order, and started with its shortest axis along the
  vorticity the body stays in that plane and tumbles with Jeffery's period of r = a_1/a_2;
- the drift of the centre against an independent integration of its formula.
"""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from beadmob_post import orbit
from beadmob_post.brownian import STRAIN_MODES, bretherton_form, mode_amplitudes
from beadmob_post.cli import main
from conftest import png_size


def jeffery_velocity(axis, bretherton: float) -> np.ndarray:
    velocity = np.zeros((6, 5))
    velocity[3:6] = bretherton * bretherton_form(axis)
    return velocity


def triaxial_velocity(semi_axes) -> np.ndarray:
    a2 = np.asarray(semi_axes, float) ** 2
    velocity = np.zeros((6, 5))
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        velocity[3 + i] = (a2[j] - a2[k]) / (a2[j] + a2[k]) * STRAIN_MODES[:, j, k]
    return velocity


def flow_file(make_result_file, velocity, name="flow.h5", with_flow=True):
    path = make_result_file(name=name, hydrodynamics={"friction": np.diag([3.0, 3.0, 4.0, 2.0, 2.0, 1.0])})
    if with_flow:
        with h5py.File(path, "a") as handle:
            group = handle.create_group("flow")
            group["strain_modes"] = STRAIN_MODES
            group["velocity_per_strain"] = velocity
            group["stresslet_per_strain"] = np.eye(5)
    return path


AXIS = np.array([0.3, -0.5, 0.81])
AXIS = AXIS / np.linalg.norm(AXIS)


@pytest.mark.parametrize("r", [3.0, 0.25])
def test_spheroid_follows_jeffery(r):
    b = (r * r - 1) / (r * r + 1)
    start = orbit.minimal_rotation(AXIS, [0.6, 0.0, 0.8])
    period = 2 * np.pi * (r + 1 / r)
    path = orbit.integrate(jeffery_velocity(AXIS, b), start, 2.3 * period)
    found = orbit.axis_return(path, AXIS)
    assert found.period == pytest.approx(period, rel=1e-6)
    assert found.returns == 2 and found.mean_period == pytest.approx(period, rel=1e-6)
    constant = orbit.jeffery_orbit_constant(path.axis(AXIS), b)
    assert constant[0] == pytest.approx(0.75 / r)               # tan(theta) = 0.6/0.8 at phi = 0
    assert np.abs(constant / constant[0] - 1).max() < 1e-8
    assert path.orthogonality_error < 1e-12


def test_sphere_turns_rigidly_with_half_the_vorticity():
    start = Rotation.from_euler("xyz", [10, 20, 30], degrees=True).as_matrix()
    path = orbit.integrate(np.zeros((6, 5)), start, 30.0, samples=301)
    expected = Rotation.from_rotvec(np.outer(-path.strain / 2, [0, 0, 1])).as_matrix() @ start
    assert np.abs(path.rotations - expected).max() < 1e-9
    assert path.angular_velocity == pytest.approx(np.tile([0, 0, -0.5], (301, 1)), abs=1e-15)
    assert orbit.orientation_return(path).period == pytest.approx(4 * np.pi, rel=1e-9)
    assert orbit.axis_return(path, start.T @ [1.0, 0, 0]).period == pytest.approx(4 * np.pi, rel=1e-9)
    assert orbit.axis_return(path, start.T @ [0, 0, 1.0]).fixed      # the axis along the vorticity


def test_triaxial_body_integrators_agree_and_stay_orthogonal():
    velocity = triaxial_velocity((3.0, 2.0, 1.0))
    start = Rotation.from_euler("zyz", [25, 60, -40], degrees=True).as_matrix()
    reference = orbit.integrate(velocity, start, 40.0, samples=81)
    lie = orbit.integrate(velocity, start, 40.0, samples=81, method="rkmk", steps_per_strain=40)
    assert reference.orthogonality_error < 1e-12 and lie.orthogonality_error < 1e-12
    assert np.all(np.abs(np.linalg.det(lie.rotations) - 1) < 1e-12)
    assert np.abs(lie.rotations - reference.rotations).max() < 1e-7
    # fourth order: halving the step divides the error by about 16
    errors = []
    for steps in (4, 8):
        coarse = orbit.integrate(velocity, start, 10.0, samples=11, method="rkmk", steps_per_strain=steps)
        errors.append(np.abs(coarse.rotations[-1] - reference.rotation_at(10.0)).max())
    assert 11 < errors[0] / errors[1] < 22


def test_triaxial_body_with_an_axis_along_the_vorticity_tumbles_in_the_plane():
    semi = (3.0, 2.0, 1.0)
    path = orbit.integrate(triaxial_velocity(semi), np.eye(3), 60.0)
    assert np.abs(path.axis([0, 0, 1.0]) - [0, 0, 1]).max() < 1e-10
    r = semi[0] / semi[1]
    assert orbit.axis_return(path, [1.0, 0, 0]).period == pytest.approx(2 * np.pi * (r + 1 / r), rel=1e-6)
    tilted = orbit.integrate(triaxial_velocity(semi), orbit.minimal_rotation([0, 0, 1.0], [0.1, 0.2, 1.0]), 60.0)
    assert tilted.orthogonality_error < 1e-12


def test_drift_of_the_centre():
    """A sphere (Q = Rz(-t/2) Q0) with a translation-strain coupling K: the drift is
    w = Q K eps, eps the amplitudes of Q^T E Q, and dX/dt = (Y, 0, 0) + w."""
    coupling = np.arange(15.0).reshape(3, 5) / 10
    velocity = np.zeros((6, 5))
    velocity[0:3] = coupling
    start = Rotation.from_euler("xyz", [40, -10, 70], degrees=True).as_matrix()
    strain = np.zeros((3, 3))
    strain[0, 1] = strain[1, 0] = 0.5

    def drift(t: float) -> np.ndarray:
        q = Rotation.from_rotvec([0, 0, -t / 2]).as_matrix() @ start
        return q @ coupling @ mode_amplitudes(q.T @ strain @ q)

    path = orbit.integrate(velocity, start, 20.0, samples=41)
    assert path.drift == pytest.approx(np.array([drift(t) for t in path.strain]), abs=1e-9)
    independent = solve_ivp(lambda t, x: np.array([x[1], 0, 0]) + drift(t), (0, 20.0), np.zeros(3),
                            rtol=1e-12, atol=1e-12).y[:, -1]
    assert path.position[-1] == pytest.approx(independent, abs=1e-8)


def test_minimal_rotation():
    for target in ([0, 0, 1.0], [-1.0, 0, 0], [0.2, -0.7, 0.1]):
        q = orbit.minimal_rotation([1.0, 0, 0], target)
        assert q @ [1.0, 0, 0] == pytest.approx(np.array(target) / np.linalg.norm(target), abs=1e-14)
        assert q.T @ q == pytest.approx(np.eye(3), abs=1e-14) and np.linalg.det(q) == pytest.approx(1.0)


def test_orbit_command(make_result_file, capsys, tmp_path):
    r = 2.5
    b = (r * r - 1) / (r * r + 1)
    path = flow_file(make_result_file, jeffery_velocity([1.0, 0, 0], b))
    picture = tmp_path / "orbit.png"
    status = main(["orbit", str(path), "--strain", "40", "--initial-axis", "1,1,1", "--plot", str(picture),
                   "--json"])
    assert status == 0
    data = json.loads(capsys.readouterr().out)
    period = 2 * np.pi * (r + 1 / r)
    assert data["axes"]["body x (symmetry)"]["period"] == pytest.approx(period, rel=1e-6)
    assert data["bretherton"]["jeffery_period"] == pytest.approx(period, rel=1e-12)
    assert data["bretherton"]["orbit_constant_relative_change"] < 1e-8
    assert data["initial_axis"] == "symmetry"
    assert data["initial_direction"] == pytest.approx(np.ones(3) / np.sqrt(3), abs=1e-12)
    assert png_size(picture) == (1080, 720)
    assert main(["orbit", str(path), "--strain", "40"]) == 0
    out = capsys.readouterr().out
    assert "revolution:       Bretherton B = 0.724138" in out and "body x (symmetry):" in out
    # The axis on the vorticity (z in u = y e_x) stays there (Jeffery 1922: log-rolling), C = 0:
    # no relative change to report, the absolute one instead.
    assert main(["orbit", str(path), "--strain", "20", "--initial-axis", "0,0,1", "--json"]) == 0
    log_rolling = json.loads(capsys.readouterr().out)["bretherton"]
    assert log_rolling["orbit_constant"] == pytest.approx(0.0, abs=1e-12)
    assert log_rolling["orbit_constant_relative_change"] is None and log_rolling["orbit_constant_change"] < 1e-10
    assert main(["orbit", str(path), "--strain", "20", "--initial-axis", "0,0,1"]) == 0
    assert "the axis on the vorticity" in capsys.readouterr().out


def test_orbit_command_errors(make_result_file, capsys):
    plain = flow_file(make_result_file, None, name="plain.h5", with_flow=False)
    assert main(["orbit", str(plain)]) == 2
    assert f"{plain} has no /flow group: run with &hydrodynamics flow = .true." in capsys.readouterr().err
    triaxial = flow_file(make_result_file, triaxial_velocity((3.0, 2.0, 1.0)), name="t.h5")
    assert main(["orbit", str(triaxial), "--axis", "symmetry"]) == 2
    assert "not a body of revolution" in capsys.readouterr().err
    assert main(["orbit", str(triaxial), "--initial-axis", "1,2"]) == 2
    assert "--initial-axis needs three numbers" in capsys.readouterr().err
    assert main(["orbit", str(triaxial), "--strain", "-3"]) == 2
    assert "--strain must be positive" in capsys.readouterr().err
    with h5py.File(triaxial, "a") as handle:
        handle["flow"].attrs["all_converged"] = 0
    assert main(["orbit", str(triaxial)]) == 2
    assert "strain solve of /flow as not converged" in capsys.readouterr().err
    assert main(["orbit", str(triaxial), "--strain", "10", "--method", "rkmk", "--allow-unconverged"]) == 0
    assert "revolution:       no" in capsys.readouterr().out
