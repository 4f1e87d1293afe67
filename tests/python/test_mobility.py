"""Tests of beadmob_post.mobility: frame, coefficients, off-pattern entries, checks."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from beadmob_post.mobility import (
    MobilityError,
    compute_coefficients,
    dimensionless,
    in_frame,
    pattern_mobility,
    shift_reference_point,
    skew,
)
from beadmob_post.results import load_result
from conftest import friction_of_mobility

#: Coefficients of a made-up settler, and rr diagonal (dimensionless, times pi L^3).
MU = dict(mu11=0.5, mu22=0.4, mu33=0.45, mu42=0.05, mu51=-0.03)
RR = (0.30, 0.35, 0.40)
LENGTH = 3.0


def dimensionless_pattern(mu=MU, rr=RR) -> np.ndarray:
    matrix = pattern_mobility(**mu)
    matrix[3:6, 3:6] = np.diag(rr)
    return matrix


def model_mobility(body_dimensionless: np.ndarray, axes: np.ndarray, length=LENGTH) -> np.ndarray:
    """Input-coordinate mobility (eta = 1, d = 1) whose body-frame form is given."""
    body = body_dimensionless / dimensionless(np.ones((6, 6)), length)
    block = np.zeros((6, 6))
    block[0:3, 0:3] = block[3:6, 3:6] = axes
    return block.T @ body @ block


def hydro_file(make_result_file, body_dimensionless, axes_paper, geometry_axes, **options):
    mobility = model_mobility(body_dimensionless, axes_paper,
                              options.get("reference_length", LENGTH))
    options.setdefault("reference_length", LENGTH)
    return make_result_file(
        body_axes=geometry_axes, mirror_planes=(1.0, 1.0, 0.0),
        hydrodynamics={"friction": friction_of_mobility(mobility), **options.pop("hydro", {})},
        **options,
    )


def rotation_about_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def test_coefficients_in_a_rotated_frame_are_recovered(make_result_file):
    axes = rotation_about_z(0.3)  # rows: body axes in input coordinates; extent x (3) > y
    result = load_result(hydro_file(make_result_file, dimensionless_pattern(), axes, axes))
    assert result.extent[0] > result.extent[1]
    c = compute_coefficients(result)
    np.testing.assert_allclose(c.values(), list(MU.values()), rtol=1e-12)
    np.testing.assert_allclose(c.body_axes, axes, atol=1e-14)
    assert not c.z_reversed and not c.xy_swapped
    assert c.off_pattern < 1e-12
    assert c.paper_class is True
    assert c.reference_length == LENGTH and c.n_beads == 4


def test_x_goes_along_the_larger_in_plane_size(make_result_file):
    # Geometry axes with body x = input y: the L shape is 1 d along it and 3 d along body y.
    geometry = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    paper = np.array([geometry[1], geometry[0], -geometry[2]])
    result = load_result(hydro_file(make_result_file, dimensionless_pattern(), paper, geometry))
    assert result.extent[1] > result.extent[0]
    c = compute_coefficients(result)
    assert c.xy_swapped and not c.z_reversed
    np.testing.assert_allclose(c.body_axes, paper, atol=1e-14)
    np.testing.assert_allclose(c.values(), list(MU.values()), rtol=1e-12)
    assert np.linalg.det(c.body_axes) == pytest.approx(1.0)


def test_z_is_turned_so_that_theta_zero_is_stable(make_result_file):
    # The same body described with z the other way round: mu42 and mu51 change sign.
    flipped = dict(MU, mu42=-MU["mu42"], mu51=-MU["mu51"])
    axes = np.eye(3)
    result = load_result(hydro_file(make_result_file, dimensionless_pattern(flipped), axes, axes))
    c = compute_coefficients(result)
    assert c.z_reversed
    assert c.mu51 < 0 < c.mu42
    np.testing.assert_allclose(c.values(), list(MU.values()), rtol=1e-12)
    np.testing.assert_allclose(c.body_axes, np.diag([1.0, -1.0, -1.0]), atol=1e-14)


def test_off_pattern_entries_are_reported(make_result_file):
    body = dimensionless_pattern()
    body[0, 2] = body[2, 0] = 0.01      # tt x-z coupling, not in eq. matrices
    body[5, 0] = body[0, 5] = -0.002    # rt: Omega_z from F_x
    axes = np.eye(3)
    c = compute_coefficients(load_result(hydro_file(make_result_file, body, axes, axes)))
    entries = {(e.block, e.row, e.column): e for e in c.off_pattern_entries}
    assert entries["tt", "x", "z"].value == pytest.approx(0.01, rel=1e-10)
    assert entries["rt", "z", "x"].value == pytest.approx(-0.002, rel=1e-10)
    assert entries["rt", "x", "x"].value == pytest.approx(0.0, abs=1e-14)
    assert len(entries) == 6 + 7 + 6
    assert c.off_pattern == pytest.approx(0.01 / 0.5, rel=1e-10)  # largest coefficient: mu11


def test_single_sphere_closed_form(make_result_file):
    # Stokes: friction 6 pi eta a and 8 pi eta a^3 with a = d/2 = 1/2, L = d = 1, so
    # mu11 = pi eta L / (6 pi eta a) = 1/3 and no rotation-translation coupling.
    friction = np.diag([3 * np.pi] * 3 + [np.pi] * 3)
    path = make_result_file(positions=[[0.0, 0.0, 0.0]], reference_length=1.0,
                            hydrodynamics={"friction": friction})
    c = compute_coefficients(load_result(path))
    np.testing.assert_allclose(c.values(), [1 / 3, 1 / 3, 1 / 3, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(c.dimensionless_body_mobility[3:6, 3:6], np.eye(3), rtol=1e-14)


def test_reference_length_option(make_result_file):
    axes = np.eye(3)
    result = load_result(hydro_file(make_result_file, dimensionless_pattern(), axes, axes))
    c = compute_coefficients(result, reference_length=2 * LENGTH)
    # mu_tt scales with L, mu_rt with L^2 (eq. matrices).
    np.testing.assert_allclose(c.values()[:3], 2 * np.array(list(MU.values())[:3]), rtol=1e-12)
    np.testing.assert_allclose(c.values()[3:], 4 * np.array(list(MU.values())[3:]), rtol=1e-12)


def test_shift_reference_point_against_a_sphere():
    # A sphere (radius a) at c: force F at c, no torque about c, moves with F/(6 pi a), no spin.
    # Seen from O with r = c - O the torque is r x F; the velocity of O (rigidly attached) is
    # the same, as Omega = 0.
    a = 0.5
    about_centre = np.diag([1 / (6 * np.pi * a)] * 3 + [1 / (8 * np.pi * a**3)] * 3)
    r = np.array([0.3, -1.2, 2.0])
    about_origin = shift_reference_point(about_centre, -r)  # from c to O = c - r
    force = np.array([0.2, 1.0, -0.7])
    velocities = about_origin @ np.concatenate([force, np.cross(r, force)])
    np.testing.assert_allclose(velocities[0:3], force / (6 * np.pi * a), rtol=1e-13)
    np.testing.assert_allclose(velocities[3:6], 0.0, atol=1e-15)
    np.testing.assert_allclose(shift_reference_point(about_origin, r), about_centre, atol=1e-15)
    np.testing.assert_allclose(skew(r) @ force, np.cross(r, force))


def test_in_frame_is_a_rotation_of_each_block():
    rng = np.random.default_rng(1)
    matrix = rng.normal(size=(6, 6))
    axes = rotation_about_z(0.7)
    rotated = in_frame(matrix, axes)
    np.testing.assert_allclose(rotated[0:3, 3:6], axes @ matrix[0:3, 3:6] @ axes.T)
    np.testing.assert_allclose(in_frame(rotated, axes.T), matrix, atol=1e-14)


# ---------------------------------------------------------------- bad input
def test_file_without_hydrodynamics(result_path):
    with pytest.raises(MobilityError, match="no /hydrodynamics in the file"):
        compute_coefficients(load_result(result_path))


def test_unconverged_run_is_refused(make_result_file):
    axes = np.eye(3)
    path = hydro_file(make_result_file, dimensionless_pattern(), axes, axes,
                      hydro={"all_converged": 0, "solve_converged_reason": np.array([2, -3, 2, 2, 2, 2])})
    with pytest.raises(MobilityError, match=r"not converged .*all_converged = 0.*-3"):
        compute_coefficients(load_result(path))
    c = compute_coefficients(load_result(path), allow_unconverged=True)
    assert c.all_converged is False


def test_singular_friction_is_refused(make_result_file):
    friction = np.diag([3 * np.pi] * 3 + [np.pi] * 3)
    friction[5, 5] = 0.0
    path = make_result_file(hydrodynamics={"friction": friction, "mobility": None})
    with pytest.raises(MobilityError, match="friction matrix is singular"):
        compute_coefficients(load_result(path))


def test_indefinite_friction_is_refused(make_result_file):
    friction = np.diag([3 * np.pi] * 3 + [np.pi, np.pi, -np.pi])
    with pytest.raises(MobilityError, match="not positive definite"):
        compute_coefficients(load_result(make_result_file(hydrodynamics={"friction": friction})))


def test_mobility_that_is_not_the_inverse_is_refused(make_result_file):
    friction = np.diag([3 * np.pi] * 3 + [np.pi] * 3)
    path = make_result_file(hydrodynamics={"friction": friction, "mobility": np.eye(6)})
    with pytest.raises(MobilityError, match="not the inverse of the friction"):
        compute_coefficients(load_result(path))


def test_friction_of_wrong_shape_is_a_result_file_error(make_result_file):
    path = make_result_file()
    with h5py.File(path, "a") as handle:
        handle.create_group("hydrodynamics")["friction"] = np.eye(5)
    with pytest.raises(Exception, match=r"friction has shape \(5, 5\), expected \(6, 6\)"):
        load_result(path)


# ---------------------------------------------------------------- real beadmob output
def test_real_file_matches_beadmob_and_symmetry(real_hydro_file):
    result = load_result(real_hydro_file)
    hydro = result.hydrodynamics
    c = compute_coefficients(result)
    # Two implementations of the same chain agree (Fortran wrote coefficients and off_pattern).
    # (to the solve tolerance: the file's mobility and coefficients agree to ~1e-10)
    np.testing.assert_allclose(c.values(), hydro.coefficients, rtol=1e-8, atol=1e-14)
    # Both see only solver noise outside the pattern (this reader symmetrises the mobility).
    assert c.off_pattern < 1e-8 and hydro.attributes["off_pattern"] < 1e-8
    np.testing.assert_allclose(c.body_axes, hydro.body_axes, atol=1e-12)
    # The pyramid is symmetric under a quarter turn about z: mu11 = mu22 and mu42 = -mu51.
    assert c.mu11 == pytest.approx(c.mu22, rel=1e-8)
    assert c.mu42 == pytest.approx(-c.mu51, rel=1e-8)
    assert c.mu51 < 0 < c.mu42
    assert c.off_pattern < 1e-8
    assert c.paper_class is True
    assert c.multipole_order >= 1 and c.all_converged is True
    # Mobility is symmetric positive definite (Stokes reciprocity, dissipation).
    body = c.dimensionless_body_mobility
    assert np.abs(body - body.T).max() < 1e-8 * np.abs(body).max()
    assert np.linalg.eigvalsh(0.5 * (body + body.T)).min() > 0


def test_real_unconverged_file_is_refused(beadmob_output_dir):
    path = beadmob_output_dir / "max_it" / "rpy_pyramid.h5"
    if not path.exists():
        pytest.skip(f"{path} not written (CTest test flagged_nonconvergence_np2 writes it)")
    result = load_result(path)
    assert result.hydrodynamics.all_converged is False
    with pytest.raises(MobilityError, match="not converged"):
        compute_coefficients(result)
