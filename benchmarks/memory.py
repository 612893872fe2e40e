#!/usr/bin/env python
"""Memory per cell of a uniform lattice, as a user's `hapticgraph run` holds it (issue 25, item 6).

    python benchmarks/memory.py          # 1-D, 2-D and 3-D, one million cells each; about 1 minute (run from benchmarks/ or the root)

For each dimension: (peak RSS of `hapticgraph run` rendering 100 samples of a 1,000,000-cell
lattice − the same for a tiny lattice of that dimension) / cells, both with a warm kernel cache,
measured by scale.py's `peak_rss` (ru_maxrss of a child forked from a small wrapper). The
lattices are run_all.py's (fixed boundary, a pluck on one cell, a nearby cell's position as the
sound). The goal: at most 48 bytes a cell (the stencil keeps positions now and one sample
before, and the forces, each with a ghost border: 24 bytes a cell, less where the forces' pages
are never touched).
"""
import os
import pathlib
import sys
import tempfile

from scale import RATE, peak_rss, write_patch

GOAL = 48.0
SIZES = (([10], [1_000_000]), ([4, 4], [1000, 1000]), ([4, 4, 4], [100, 100, 100]))


def per_cell(small, big, folder, env):
    """(bytes a cell, peak RSS of the big run) for lattices of shapes small and big."""
    rss = []
    for shape in (small, big):
        path, _, _ = write_patch(folder, shape)
        cmd = [sys.executable, "-m", "hapticgraph", "run", str(path), "--seconds", str(100 / RATE),
               "--out", str(folder / "out.wav"), "--quiet"]
        peak_rss(cmd, env)                                   # the kernel compiled and cached first
        rss.append(peak_rss(cmd, env))
    cells = 1
    for extent in big:
        cells *= extent
    return (rss[1] - rss[0]) / cells, rss[1]


def main():
    with tempfile.TemporaryDirectory(prefix="hapticgraph-memory-") as tmp:
        folder = pathlib.Path(tmp)
        env = dict(os.environ, HAPTICGRAPH_CACHE=str(folder / "cache"))
        print("| lattice | cells | peak RSS of the run | bytes per cell | goal |")
        print("|---|---:|---:|---:|---|")
        worst = 0.0
        for small, big in SIZES:
            b, peak = per_cell(small, big, folder, env)
            worst = max(worst, b)
            print(f"| {' x '.join(map(str, big))} | {1_000_000:,} | {peak / 2 ** 20:.0f} MiB | {b:.1f} | "
                  f"≤ {GOAL:g}: {'met' if b <= GOAL else 'not met'} |")
    return 0 if worst <= GOAL else 1


if __name__ == "__main__":
    sys.exit(main())
