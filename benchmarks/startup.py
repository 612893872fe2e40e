#!/usr/bin/env python
"""Start-up: time from process start to the first samples, cold and warm, and where it goes.

    python benchmarks/startup.py                 # the benchmark lattices and Fig. 7, median of 5
    python benchmarks/startup.py --reps 3 PATCH  # other patches

For each patch, in fresh processes, `hapticgraph run PATCH --seconds S --out X.wav --quiet` with S
= 64 samples (so the figure is the time to the first samples, WAV written, plus 64 samples' work),
timed from process start to exit:

- *cold*: a new, empty HAPTICGRAPH_CACHE (the kernel is compiled);
- *warm*: the same cache again (the compiled kernel is loaded);
- *size edited*: the cache filled by the patch, then the patch with every lattice's extents
  grown by one (sizes are data: the kernel is re-used, so this should cost what warm costs).

Then `python -X importtime` of the warm run: the top-level imports that cost most, and
`import hapticgraph` alone.

Bytecode: the children run without PYTHONDONTWRITEBYTECODE (benchlib.child_env), so the cold
run writes hapticgraph's .pyc files as Python does on a user's machine.
"""
import argparse
import pathlib
import re
import statistics
import subprocess
import sys
import tempfile
import time
import benchlib

HERE = pathlib.Path(__file__).resolve().parent
PATCHES = [HERE / "sheet_32.yaml", HERE / "string_100.yaml", HERE.parent / "patches" / "fig7_bowed_string.yaml"]
EXE = pathlib.Path(sys.executable).with_name("hapticgraph")


def run(patch, env, wav, extra=()):
    text = pathlib.Path(patch).read_text()
    m = re.search(r"^rate:\s*([0-9.eE+]+)", text, re.MULTILINE)
    rate = float(m.group(1)) if m else 44100.0
    start = time.perf_counter()
    subprocess.run([*extra, str(EXE), "run", str(patch), "--seconds", repr(64 / rate), "--out", str(wav), "--quiet"],
                   check=True, capture_output=True, env=env)
    return time.perf_counter() - start


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


def one_patch(patch, reps, folder):
    wav = folder / "out.wav"
    cold, warm, edited = [], [], []
    for r in range(reps):
        env = benchlib.child_env(HAPTICGRAPH_CACHE=str(folder / f"cache{r}"))
        cold.append(run(patch, env, wav))
        warm.append(run(patch, env, wav))
        other = grown(patch, folder)
        if other is not None:
            edited.append(run(other, env, wav))
    return cold, warm, edited


def imports(patch, folder):
    """(seconds, module) of the costliest top-level imports of a warm run, and `import hapticgraph`."""
    env = benchlib.child_env(HAPTICGRAPH_CACHE=str(folder / "cache0"))
    out = subprocess.run([sys.executable, "-X", "importtime", str(EXE), "run", str(patch), "--seconds", "0.001",
                          "--out", str(folder / "out.wav"), "--quiet"], check=True, capture_output=True, text=True, env=env).stderr
    top = []
    for line in out.splitlines():
        m = re.match(r"import time:\s+\d+ \|\s+(\d+) \| (\S.*)$", line)   # no indent: a top-level import
        if m:
            top.append((int(m.group(1)) / 1e6, m.group(2)))
    alone = subprocess.run([sys.executable, "-X", "importtime", "-c", "import hapticgraph"], env=benchlib.child_env(),
                           check=True, capture_output=True, text=True).stderr.splitlines()[-1]
    return sorted(top, reverse=True), int(alone.split("|")[1]) / 1e6


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("patches", nargs="*", default=PATCHES)
    ap.add_argument("--reps", type=int, default=5)
    args = ap.parse_args(argv)
    print(f"| patch | cold | warm | size edited (kernel re-used) |  (median of {args.reps}, seconds, process start to exit)")
    print("|---|---:|---:|---:|")
    with tempfile.TemporaryDirectory(prefix="hg-startup-") as folder:
        folder = pathlib.Path(folder)
        for patch in args.patches:
            cold, warm, edited = one_patch(patch, args.reps, folder)
            med = statistics.median
            print(f"| `{pathlib.Path(patch).name}` | {med(cold):.2f} | {med(warm):.2f} | "
                  f"{med(edited):.2f} |" if edited else f"| `{pathlib.Path(patch).name}` | {med(cold):.2f} | "
                  f"{med(warm):.2f} | — |")
        top, alone = imports(args.patches[0], folder)
    print(f"\n`import hapticgraph` alone: {alone:.3f} s. Costliest top-level imports of a warm run "
          f"(`-X importtime`, {pathlib.Path(args.patches[0]).name}):")
    for seconds, name in top[:10]:
        print(f"  {seconds:6.3f} s  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
