"""beadmob_post: read and picture the HDF5 result files written by beadmob.

Modules:

* :mod:`beadmob_post.results`  -- :func:`load_result` reads one result file into a
  :class:`BeadResult`; problems raise :class:`ResultFileError`.
* :mod:`beadmob_post.beadplot` -- :func:`plot_beads` draws the bead model in three views.
* :mod:`beadmob_post.cli`      -- the ``beadmob-post`` command.
"""

from beadmob_post.results import (
    RESULT_FORMAT,
    SUPPORTED_FORMAT_VERSION,
    BeadResult,
    ResultFileError,
    load_result,
)

__version__ = "0.1.0"

__all__ = [
    "RESULT_FORMAT",
    "SUPPORTED_FORMAT_VERSION",
    "BeadResult",
    "ResultFileError",
    "load_result",
    "__version__",
]
