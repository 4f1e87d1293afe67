"""check_table_cache_runs.py FIRST.h5 SECOND.h5 CACHE.h5: the run that filled the table cache and
the run that read it hold the same friction to the last bit; the first computed every block and
lubrication correction, the second read them all from the cache."""
import sys

import h5py
import numpy as np


def main(first_path, second_path, cache_path):
    failures = []
    with h5py.File(first_path, "r") as first, h5py.File(second_path, "r") as second:
        a, b = first["hydrodynamics"], second["hydrodynamics"]
        for name in ("friction", "multipole_friction", "mobility"):
            if not np.array_equal(a[name][()], b[name][()]):
                failures.append(f"{name} differs: largest difference {np.max(np.abs(a[name][()] - b[name][()]))}")
        if not (a.attrs["cached_blocks"] == 0 and a.attrs["computed_blocks"] > 0):
            failures.append(f"first run: {a.attrs['cached_blocks']} blocks read, expected 0")
        if not (b.attrs["cached_blocks"] == a.attrs["computed_blocks"] and b.attrs["computed_blocks"] == 0):
            failures.append(f"second run: {b.attrs['cached_blocks']} read, {b.attrs['computed_blocks']} computed")
        if not (a.attrs["lubrication_computed_distances"] > 0 and b.attrs["lubrication_computed_distances"] == 0
                and b.attrs["lubrication_cached_distances"] == a.attrs["lubrication_computed_distances"]):
            failures.append("lubrication corrections not all read from the cache in the second run")
        for run in (a, b):
            if not run.attrs["cache_file"].decode().endswith("table_cache.h5"):
                failures.append(f"cache_file attribute: {run.attrs['cache_file']!r}")
    with h5py.File(cache_path, "r") as cache:
        if cache.attrs["format"] != b"beadmob-table-cache" or "blocks" not in cache or "lubrication" not in cache:
            failures.append("the cache file lacks its format attribute or groups")
    for failure in failures:
        print("FAIL:", failure)
    if not failures:
        print("PASS: cached run bitwise equal, every block and correction read from the cache")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:4]))
