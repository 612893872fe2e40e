#!/usr/bin/env python
"""Start-up: a whole short `hapticgraph run`, process start to exit, warm and cold, beside the
interpreter's own floor, and where a warm run's time goes.

    python benchmarks/startup.py                 # the benchmark patches, 7 rounds
    python benchmarks/startup.py --reps 3 PATCH  # other patches

Each round runs, in fresh processes and interleaved (so a busy machine slows every column alike):
`python -c pass` and `python -c "import numpy"` (the floor every run stands on), then for each
patch `hapticgraph run PATCH --seconds 0.5 --out X.wav --quiet` (0.5 s of audio: a whole short
render, WAV written):

- *cold*: an empty kernel cache folder (HAPTICGRAPH_CACHE; the kernel is compiled), with this
  installation's shared cache (HAPTICGRAPH_SHARED_CACHE: numba's C runtime and the built-in
  helpers' machine code, built once per installation) already built;
- *warm*: the same kernel cache again (the compiled kernel is loaded);
- *size edited*: then the patch with every lattice's extents grown by one (sizes are data: the
  kernel is re-used, so this should cost what warm costs).

Before the rounds, one run with an empty shared cache too (*first use*: what the first kernel of
a new installation costs, once). Figures are the median and the minimum over the rounds, in
seconds. Then `python -X importtime` of a warm run: the top-level imports that cost most.

Goals (issue 25): warm <= 0.35 s (sheet_32, string_100); cold <= 2 s for a 1,000-cell patch
(sheet_1000).

Bytecode: the children run without PYTHONDONTWRITEBYTECODE (benchlib.child_env), so the first
run writes hapticgraph's .pyc files as Python does on a user's machine.
"""
import argparse
import pathlib
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import benchlib

HERE = pathlib.Path(__file__).resolve().parent
PATCHES = [HERE / "sheet_32.yaml", HERE / "string_100.yaml", HERE / "sheet_1000.yaml",
           HERE.parent / "patches" / "fig7_bowed_string.yaml"]
EXE = pathlib.Path(sys.executable).with_name("hapticgraph")
SECONDS = 0.5
GOALS = {"sheet_32.yaml": ("warm", 0.35), "string_100.yaml": ("warm", 0.35), "sheet_1000.yaml": ("cold", 2.0)}


def timed(cmd, env):
    """(wall seconds, CPU seconds: user + system) of a child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, env=env)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def hg(patch, env, wav):
    return timed([str(EXE), "run", str(patch), "--seconds", repr(SECONDS), "--out", str(wav), "--quiet"], env)


def grown(patch, folder):
    """The patch with every `shape: [a, b]` extent grown by one (another size, same structure)."""
    text = pathlib.Path(patch).read_text()
    new = re.sub(r"(shape:\s*\[)([0-9,\s]+)\]",
                 lambda m: m.group(1) + ", ".join(str(int(s) + 1) for s in m.group(2).split(",")) + "]", text)
    if new == text:
        return None
    out = folder / ("grown_" + pathlib.Path(patch).name)
    out.write_text(new)
    return out


def one_round(patches, folder, r, rows):
    shared = str(folder / "shared")
    rows["python -c pass"].append(timed([sys.executable, "-c", "pass"], benchlib.child_env()))
    rows["python -c 'import numpy'"].append(timed([sys.executable, "-c", "import numpy"], benchlib.child_env()))
    for k, patch in enumerate(patches):
        env = benchlib.child_env(HAPTICGRAPH_CACHE=str(folder / f"cache{r}_{k}"), HAPTICGRAPH_SHARED_CACHE=shared)
        wav = folder / "out.wav"
        row = rows.setdefault(pathlib.Path(patch).name, {"cold": [], "warm": [], "size edited": []})
        row["cold"].append(hg(patch, env, wav))
        row["warm"].append(hg(patch, env, wav))
        other = grown(patch, folder)
        if other is not None:
            row["size edited"].append(hg(other, env, wav))


def imports(patch, folder):
    """(seconds, module) of the costliest top-level imports of a warm run (-X importtime)."""
    env = benchlib.child_env(HAPTICGRAPH_CACHE=str(folder / "cache0_0"), HAPTICGRAPH_SHARED_CACHE=str(folder / "shared"))
    out = subprocess.run([sys.executable, "-X", "importtime", str(EXE), "run", str(patch), "--seconds", repr(SECONDS),
                          "--out", str(folder / "out.wav"), "--quiet"], check=True, capture_output=True, text=True,
                         env=env).stderr
    top = []
    for line in out.splitlines():
        m = re.match(r"import time:\s+\d+ \|\s+(\d+) \| (\S.*)$", line)   # no indent: a top-level import
        if m:
            top.append((int(m.group(1)) / 1e6, m.group(2)))
    return sorted(top, reverse=True)


def fmt(values):
    """median / min of the wall times (CPU: min of the CPU times)."""
    if not values:
        return "—"
    walls = [w for w, _ in values]
    return f"{statistics.median(walls):.2f} / {min(walls):.2f} (CPU {min(c for _, c in values):.2f})"


def report(rows, first, reps):
    print(f"Whole `hapticgraph run PATCH --seconds {SECONDS} --out X.wav --quiet`, process start to exit, "
          f"median / min of {reps} interleaved rounds, seconds, and the least CPU time (user + system) of a "
          f"round, which another load on the machine disturbs less ({benchlib.cpu_model()}):\n")
    for name in ("python -c pass", "python -c 'import numpy'"):
        print(f"- `{name}`: {fmt(rows[name])}")
    print(f"- first use (empty shared and kernel caches), {first[0]}: {first[1][0]:.2f} (CPU {first[1][1]:.2f})\n")
    print("| patch | cold (empty kernel cache) | warm | size edited (kernel re-used) | goal |")
    print("|---|---:|---:|---:|---|")
    for name, row in rows.items():
        if not isinstance(row, dict):
            continue
        goal = GOALS.get(name)
        verdict = ""
        if goal:
            met = statistics.median(w for w, _ in row[goal[0]]) <= goal[1]
            verdict = f"{goal[0]} ≤ {goal[1]:g} s: {'met' if met else '**not met**'}"
        print(f"| `{name}` | {fmt(row['cold'])} | {fmt(row['warm'])} | {fmt(row['size edited'])} | {verdict} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("patches", nargs="*", default=PATCHES)
    ap.add_argument("--reps", type=int, default=7)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="hg-startup-") as folder:
        folder = pathlib.Path(folder)
        env = benchlib.child_env(HAPTICGRAPH_CACHE=str(folder / "first"), HAPTICGRAPH_SHARED_CACHE=str(folder / "shared"))
        first = (pathlib.Path(args.patches[0]).name, hg(args.patches[0], env, folder / "out.wav"))
        rows = {"python -c pass": [], "python -c 'import numpy'": []}
        for r in range(args.reps):
            one_round(args.patches, folder, r, rows)
        report(rows, first, args.reps)
        top = imports(args.patches[0], folder)
    print(f"\nCostliest top-level imports of a warm run (`-X importtime`, {pathlib.Path(args.patches[0]).name}):")
    for seconds, name in top[:10]:
        print(f"  {seconds:6.3f} s  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
