#!/usr/bin/env python3
"""check_layers.py SRC_DIR: the folders of src/ are layers that only look down.

Reads every Fortran source under SRC_DIR, maps each module to the folder that defines it, and
draws an edge folder A -> folder B for every `use` of a module of B in A. Passes when that folder
graph has no cycle; otherwise prints every cycle with the file and line of each upward `use` in
it, and fails. It also prints the layers in order (each folder above everything it uses).
"""
import re
import sys
from collections import defaultdict
from pathlib import Path

MODULE = re.compile(r"^\s*module\s+(\w+)\s*(!.*)?$", re.IGNORECASE)
USE = re.compile(r"^\s*use\s*(?:,\s*(?:non_)?intrinsic\s*::)?\s*(?:::)?\s*(\w+)", re.IGNORECASE)


def read_sources(src):
    files = sorted(p for p in Path(src).rglob("*") if p.suffix.lower() in (".f90", ".f90.in"))
    files += sorted(Path(src).rglob("*.f90.in"))
    owner, uses = {}, []
    for path in files:
        folder = path.relative_to(src).parts[0] if len(path.relative_to(src).parts) > 1 else "."
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            if m := MODULE.match(line):
                if m.group(1).lower() != "procedure":
                    owner[m.group(1).lower()] = folder
            elif m := USE.match(line):
                uses.append((folder, m.group(1).lower(), f"{path}:{number}"))
    return owner, uses


def strongly_connected(nodes, edges):
    """Tarjan's components (each a list of folders) of the graph."""
    index, low, stack, on_stack, result = {}, {}, [], set(), []
    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            result.append(component)
    for v in sorted(nodes):
        if v not in index:
            visit(v)
    return result


def main(src):
    owner, uses = read_sources(src)
    edges, where = defaultdict(set), defaultdict(list)
    for folder, module, place in uses:
        target = owner.get(module)
        if target is None or target == folder:
            continue   # an external module (petsc, hdf5, mpi, fftw) or one of the same layer
        edges[folder].add(target)
        where[(folder, target)].append(f"{place} uses {module}")
    nodes = set(owner.values())
    cycles = [c for c in strongly_connected(nodes, edges) if len(c) > 1]
    if cycles:
        for component in cycles:
            print(f"cycle between the layers {', '.join(sorted(component))}:")
            for a in sorted(component):
                for b in sorted(edges[a] & set(component)):
                    for place in where[(a, b)]:
                        print(f"  {a} -> {b}: {place}")
        return 1
    # Tarjan returns components in reverse topological order: the lowest layer first.
    order = [c[0] for c in strongly_connected(nodes, edges)]
    print("layers, lowest first: " + " < ".join(order))
    for folder in order:
        print(f"  {folder} uses {', '.join(sorted(edges[folder])) or 'nothing of src/'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "src"))
