"""A compact random lattice body without symmetry (Eden growth), for the tests and the benches."""
import numpy as np


def eden_body(n, seed=1):
    """From one bead at the origin, add a random free face neighbour of a random bead until there
    are n beads; their centres (bead diameters) as an (n, 3) array."""
    rng = np.random.default_rng(seed)
    beads, taken = [(0, 0, 0)], {(0, 0, 0)}
    steps = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
    while len(beads) < n:
        x, y, z = beads[rng.integers(len(beads))]
        dx, dy, dz = steps[rng.integers(6)]
        candidate = (x + dx, y + dy, z + dz)
        if candidate not in taken:
            taken.add(candidate)
            beads.append(candidate)
    return np.array(beads, float)
