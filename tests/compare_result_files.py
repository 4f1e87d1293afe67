#!/usr/bin/env python3
"""compare_result_files.py A.h5 B.h5: exit 0 when two beadmob result files hold the same data.

Every dataset and attribute must be equal (floating point: bit for bit), except the
run-specific metadata: the creation time and the number of MPI ranks.
"""
import sys

import h5py
import numpy as np

RUN_SPECIFIC = {"created", "mpi_ranks"}


def collect(path):
    items = {}
    with h5py.File(path, "r") as f:
        for name, value in f.attrs.items():
            items["@/" + name] = value
        def visit(name, obj):
            for attr, value in obj.attrs.items():
                items[f"@{name}/{attr}"] = value
            if isinstance(obj, h5py.Dataset):
                items[name] = obj[()]
        f.visititems(visit)
    return {k: v for k, v in items.items() if k.rsplit("/", 1)[-1] not in RUN_SPECIFIC}


def main(a, b):
    first, second = collect(a), collect(b)
    problems = [f"only in {a}: {k}" for k in sorted(first.keys() - second.keys())]
    problems += [f"only in {b}: {k}" for k in sorted(second.keys() - first.keys())]
    for key in sorted(first.keys() & second.keys()):
        x, y = np.asarray(first[key]), np.asarray(second[key])
        if x.shape != y.shape or not np.array_equal(x, y):
            problems.append(f"differs: {key}")
    for p in problems:
        print(p)
    print(f"compared {len(first)} items: {'identical' if not problems else f'{len(problems)} differences'}")
    return 1 if problems else 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1], sys.argv[2]))
