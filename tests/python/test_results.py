"""Tests of beadmob_post.results: reading result files and rejecting other files."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from beadmob_post.results import ResultFileError, load_result
from conftest import L_SHAPE_POSITIONS


def test_load_reads_geometry_shape_and_metadata(result_path):
    result = load_result(result_path)

    assert result.path == result_path
    assert result.n_beads == 4
    np.testing.assert_array_equal(result.positions, L_SHAPE_POSITIONS)
    np.testing.assert_allclose(result.centre_of_mass, [2.75, 3.0, 4.25])
    np.testing.assert_array_equal(result.body_axes, np.eye(3))
    np.testing.assert_allclose(result.extent, [3.0, 1.0, 2.0])
    assert result.shape_name == "l_shape"
    assert result.shape_parameters == {"arm_length": 3.0, "height": 2.0}
    assert result.reference_length == 3.0
    assert result.shape_source == "built-in shape"
    assert result.input_source == "test.nml"
    assert result.units["bead_diameter"] == 1.0


def test_strings_are_decoded_and_numbers_are_python_numbers(result_path):
    metadata = load_result(result_path).metadata

    assert metadata["format"] == "beadmob-result"
    assert metadata["format_version"] == 1 and isinstance(metadata["format_version"], int)
    assert metadata["mpi_ranks"] == 2
    assert metadata["program_version"] == "0.1.0"
    assert metadata["git_hash"] == "abc1234"
    assert metadata["created"] == "2025-01-02T03:04:05+00:00"


def test_arrays_are_read_only(result_path):
    result = load_result(result_path)
    with pytest.raises(ValueError):
        result.positions[0, 0] = 99.0


def test_body_coordinates_use_rows_of_body_axes(make_result_file):
    # Body x = input y, body y = -input x, body z = input z (right-handed).
    axes = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    positions = np.array([[0.0, 0.0, 0.0], [0.0, 2.0, 0.0], [1.0, 1.0, 3.0]])
    result = load_result(make_result_file(positions=positions, body_axes=axes))

    body = result.body_coordinates()
    relative = positions - positions.mean(axis=0)
    np.testing.assert_allclose(body[:, 0], relative[:, 1])
    np.testing.assert_allclose(body[:, 1], -relative[:, 0])
    np.testing.assert_allclose(body[:, 2], relative[:, 2])
    np.testing.assert_allclose(body.mean(axis=0), 0.0, atol=1e-15)


def test_later_additions_are_ignored(result_path):
    with h5py.File(result_path, "a") as handle:
        mobility = handle.create_group("mobility")
        mobility["matrix"] = np.eye(6)
        handle.create_group("solver").attrs["tolerance"] = 1e-8
        handle["geometry"]["mirror_planes"] = np.array([1.0, 1.0, 0.0])
        handle["geometry"].attrs["paper_class"] = np.int64(1)
        handle.attrs["new_root_attribute"] = np.bytes_(b"later")

    result = load_result(result_path)
    assert result.n_beads == 4
    assert result.metadata["new_root_attribute"] == "later"


def test_paper_length_is_accepted_as_reference_length(make_result_file):
    path = make_result_file()
    with h5py.File(path, "a") as handle:
        del handle["shape"].attrs["reference_length"]
        handle["shape"].attrs["paper_length"] = 7.5
    result = load_result(path)
    assert result.reference_length == 7.5
    assert "paper_length" not in result.shape_parameters


def test_missing_file_is_reported(tmp_path):
    missing = tmp_path / "nowhere.h5"
    with pytest.raises(ResultFileError, match="no such file") as caught:
        load_result(missing)
    assert str(missing) in str(caught.value)


def test_text_file_is_not_hdf5(tmp_path):
    path = tmp_path / "notes.h5"
    path.write_text("&shape name = 'cone' /\n")
    with pytest.raises(ResultFileError, match="is not an HDF5 file") as caught:
        load_result(path)
    assert str(path) in str(caught.value)


def test_hdf5_file_without_format_attribute(make_result_file):
    path = make_result_file(file_format=None)
    with pytest.raises(ResultFileError) as caught:
        load_result(path)
    assert str(caught.value) == f"{path} is not a beadmob result file (no /format attribute)"


def test_hdf5_file_of_another_format(make_result_file):
    path = make_result_file(file_format="other-program-output")
    with pytest.raises(ResultFileError, match="is not a beadmob result file") as caught:
        load_result(path)
    assert "other-program-output" in str(caught.value)


def test_plain_hdf5_file_is_rejected(tmp_path):
    path = tmp_path / "plain.h5"
    with h5py.File(path, "w") as handle:
        handle["data"] = np.arange(3)
    with pytest.raises(ResultFileError, match=r"no /format attribute"):
        load_result(path)


def test_newer_format_version_is_rejected(make_result_file):
    path = make_result_file(format_version=2)
    with pytest.raises(ResultFileError, match="format_version 2"):
        load_result(path)


@pytest.mark.parametrize(
    "omitted, message",
    [
        ("geometry/positions", "missing dataset /geometry/positions"),
        ("geometry/centre_of_mass", "missing dataset /geometry/centre_of_mass"),
        ("geometry/body_axes", "missing dataset /geometry/body_axes"),
        ("geometry/extent", "missing dataset /geometry/extent"),
        ("geometry", "missing group /geometry"),
        ("shape", "missing group /shape"),
    ],
)
def test_missing_required_data_is_named(make_result_file, omitted, message):
    path = make_result_file(omit=(omitted,))
    with pytest.raises(ResultFileError) as caught:
        load_result(path)
    assert str(caught.value) == f"{path}: {message}"


def test_bead_count_mismatch_is_reported(result_path):
    with h5py.File(result_path, "a") as handle:
        handle["geometry"].attrs["n_beads"] = np.int64(5)
    with pytest.raises(ResultFileError, match="n_beads = 5 but .* holds 4 beads"):
        load_result(result_path)


def test_positions_of_wrong_shape_are_reported(make_result_file):
    path = make_result_file()
    with h5py.File(path, "a") as handle:
        del handle["geometry/positions"]
        handle["geometry/positions"] = np.zeros((3, 4))
        handle["geometry"].attrs["n_beads"] = np.int64(3)
    with pytest.raises(ResultFileError, match=r"shape \(3, 4\), expected \(N, 3\)"):
        load_result(path)


def test_non_orthonormal_axes_are_reported(make_result_file):
    path = make_result_file(body_axes=np.diag([1.0, 2.0, 1.0]))
    with pytest.raises(ResultFileError, match="not an orthonormal frame"):
        load_result(path)
