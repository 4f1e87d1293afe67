"""beadmob_post: read, analyse and picture the HDF5 result files written by beadmob.

Modules:

* :mod:`beadmob_post.results`  -- :func:`load_result` reads one result file into a
  :class:`BeadResult`; problems raise :class:`ResultFileError`.
* :mod:`beadmob_post.beadplot` -- :func:`plot_beads` draws the bead model in three views.
* :mod:`beadmob_post.mobility` -- the paper's coefficients mu11 ... mu51, frame, off-pattern.
* :mod:`beadmob_post.classify` -- settler / drifter / flutterer, times, physical units.
* :mod:`beadmob_post.dynamics` -- 3-D orientation under gravity (quaternions, solve_ivp).
* :mod:`beadmob_post.fitting`  -- the weighted fit of the paper's Appendix D.
* :mod:`beadmob_post.tables`   -- batch tables and the comparison with Table tab_mob_num.
* :mod:`beadmob_post.bench`    -- benchmark CSV ("beadmob-bench 1").
* :mod:`beadmob_post.plots`    -- coefficient, dynamics, fit and benchmark figures.
* :mod:`beadmob_post.paper`    -- the paper's numbers (tables), with their source.
* :mod:`beadmob_post.cli`, :mod:`beadmob_post.commands` -- the ``beadmob-post`` command.
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
