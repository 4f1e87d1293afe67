"""Checks on result files written by the Fortran program (BEADMOB_TEST_OUTPUT_DIR).

Skipped unless CTest (or the user) points BEADMOB_TEST_OUTPUT_DIR at a directory of results.
"""

from __future__ import annotations

import numpy as np

from beadmob_post.results import load_result


def test_every_result_file_is_readable_and_consistent(beadmob_output_dir):
    paths = sorted(beadmob_output_dir.glob("*.h5"))
    assert paths, f"no *.h5 result files in {beadmob_output_dir}"
    for path in paths:
        result = load_result(path)
        assert result.metadata["format"] == "beadmob-result"
        assert result.n_beads == len(result.positions) >= 1
        assert result.shape_name
        np.testing.assert_allclose(result.centre_of_mass, result.positions.mean(axis=0), atol=1e-9)
        body = result.body_coordinates()
        np.testing.assert_allclose(np.ptp(body, axis=0) + 1.0, result.extent, atol=1e-9)
        np.testing.assert_allclose(np.linalg.det(result.body_axes), 1.0, atol=1e-9)
