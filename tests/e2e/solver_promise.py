"""What a beadmob run promises about the solver error of its friction (docs/theory.md T5,
"Solver error bound"), for the tests that compare runs: every entry of the variational friction
is within b sqrt(zeta_mm zeta_nn) of the exact solve's, b the file's `solver_error_bound`
(-1: none stated)."""
import numpy as np


def bound(hydrodynamics, name="solver_error_bound"):
    """The stated bound of an open /hydrodynamics group (or its attributes), None if none."""
    attrs = getattr(hydrodynamics, "attrs", hydrodynamics)
    if name not in attrs or float(attrs[name]) < 0:
        return None
    return float(attrs[name])


def entry_scale(friction):
    """sqrt(zeta_mm zeta_nn): the scale of entry (m, n) (NaN where a motion was not computed)."""
    diagonal = np.sqrt(np.abs(np.diag(friction)))
    return np.outer(diagonal, diagonal)


def allowed_difference(bounds, multipole_friction):
    """|zeta_1 - zeta_2| two runs may show, entry by entry: each within its own bound of the
    exact solve (bounds: the runs' b), on the scale of the order-L friction."""
    return sum(bounds) * entry_scale(multipole_friction)
