"""The exported C against the numba kernel it is translated from (issue 31's speed row): the
30,000-cell string, the 32 × 32 sheet and Fig. 7, each kernel alone over the whole render in one
call, into prefaulted buffers.

- numba: `CompiledKernel.run` over the render (run_all.kernel_run: the simulated hand's columns
  computed beforehand; the device's mass-and-hand model steps inside the kernel).
- C: the patch exported (hapticgraph.graph.c), compiled by `--cc` (default $CC, else cc) with
  `-O3 -march=native -ffp-contract=off -fno-math-errno` (the numbers stay the kernel's; no errno
  lets the compiler hoist a loop-invariant sin as LLVM does for numba) and a driver that times one
  `NAME_process` over the render (clock_gettime around the call). Its output columns are
  prefaulted by volatile stores, as numba's `rec.fill(0.0)` prefaults its rows: a `memset(p, 0, n)`
  after `malloc(n)` is turned into `calloc(n)` by clang and GCC at -O2 and above, whose fresh pages
  are then faulted in inside the timed call (at 19 kHz, 60 s of three columns, about 6,700 faults:
  a third of the C's time on Fig. 7). Fig. 7's
  device is the host's: its position and velocity columns are the Python run's, read from a file
  (so the C does not step the device model the numba kernel steps).
- Interleaved: each repetition runs numba and C one after the other, alternating which goes first;
  medians. Ratio = numba seconds / C seconds: > 1 means the exported C is faster. The first
  seconds of each side are checked to be the same float64 bits (channel 0) before anything is timed.

    python benchmarks/export_speed.py --reps 5 --cc clang     # ~2 min; --cc gcc for GCC
    python benchmarks/export_speed.py --reps 5 --cc gcc --cflags=-funroll-loops
"""
import argparse
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile

import numpy as np

import hapticgraph
from hapticgraph.export.bundle import write_c
from hapticgraph.export.compiler import compiler
from hapticgraph.graph.c import export_c
from run_all import fig7_patch, kernel_run

HERE = pathlib.Path(__file__).resolve().parent
FLAGS = ("-std=c99", "-O3", "-march=native", "-ffp-contract=off", "-fno-math-errno")
# (label, patch, seconds)
ROWS = [("1-D string, 30,000 cells", HERE / "string_30000.yaml", 2.0),
        ("2-D sheet, 32 x 32", HERE / "sheet_32.yaml", 20.0),
        ("Fig. 7 bowed string, simulated device", "fig7", 60.0)]

DRIVER = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "{name}.h"

/* every page of p[0..n) written before the timed call (a memset of zeros after malloc would
   become calloc, and the pages would be faulted in inside it) */
static void prefault(double *p, long n)
{{
    volatile double *v = p;
    long k;
    for (k = 0; k < n; k++) v[k] = 0.0;
}}

/* total inputs.bin|- out.bin : one timed NAME_process over `total` samples; prints its seconds */
int main(int argc, char **argv)
{{
    long total = atol(argv[1]), k;
    int c, nin = {NAME}_N_INPUTS, nout = {NAME}_N_OUTPUTS;
    double **in = calloc(nin + 1, sizeof *in), **out = calloc(nout + 1, sizeof *out), *rows = NULL;
    struct timespec a, b;
    FILE *f;
    {name} *s = {name}_new({NAME}_RATE);
    if (s == NULL) return 3;
    for (c = 0; c < nout; c++) {{ out[c] = malloc(total * sizeof(double)); prefault(out[c], total); }}
    if (nin) {{
        rows = malloc((size_t)total * nin * sizeof(double));
        f = fopen(argv[2], "rb");
        if (f == NULL || fread(rows, sizeof(double), (size_t)total * nin, f) != (size_t)total * nin) return 5;
        fclose(f);
        for (c = 0; c < nin; c++) {{
            in[c] = malloc(total * sizeof(double));
            for (k = 0; k < total; k++) in[c][k] = rows[k * nin + c];
        }}
    }}
    clock_gettime(CLOCK_MONOTONIC, &a);
    {name}_process(s, (const double *const *)in, out, (int)total);
    clock_gettime(CLOCK_MONOTONIC, &b);
    printf("%.9f\n", (b.tv_sec - a.tv_sec) + 1e-9 * (b.tv_nsec - a.tv_nsec));
    f = fopen(argv[3], "wb");
    fwrite(out[0], sizeof(double), total, f);
    fclose(f);
    return 0;
}}
"""


def device_columns(path, lowered, samples):
    """The inputs the C reads: each device column as the Python run's haptic block saw it."""
    if not lowered.inputs:
        return None
    patch = hapticgraph.load(path)
    probes = []
    for port in lowered.inputs:
        device, _, column = port.name.partition(".")
        block = next(b.name for b in patch.blocks.values() if any(
            p.refers == "devices" and b.values.get(n) == device for n, p in b.cls.params.items()))
        probes.append(f"{block}.{ {'sensor_x': 'x', 'sensor_v': 'v'}[column] }")
    block = 4096
    rows = []
    with hapticgraph.Session.open(path, probes=sorted(set(probes)), blocksize=block, editable=False) as s:
        for _ in range(-(-samples // block)):
            probed = s.probes_of(s.process(block))
            rows.append(np.stack([probed[p] for p in probes], axis=1))
    return np.concatenate(rows)[:samples]


def build(path, folder, samples, cc, extra=()):
    """The exported C of `path` with the timing driver; (command, its inputs' file or '-')."""
    name = "bench"
    lowered = export_c(hapticgraph.load(path), name)
    write_c(lowered, folder)
    (folder / "driver.c").write_text(DRIVER.format(name=name, NAME=name.upper()), encoding="utf-8")
    exe = folder / "driver"
    subprocess.run(cc + list(FLAGS) + list(extra) + [str(folder / "driver.c"), str(folder / f"{name}.c"), "-I", str(folder),
                                               "-o", str(exe), "-lm"], check=True)
    inputs = device_columns(path, lowered, samples)
    source = "-"
    if inputs is not None:
        source = str(folder / "inputs.bin")
        np.ascontiguousarray(inputs, dtype=np.float64).tofile(source)
    return [str(exe), str(samples), source, str(folder / "out.bin")]


def c_run(command):
    proc = subprocess.run(command, check=True, capture_output=True, text=True)
    return float(proc.stdout.split()[0]), np.fromfile(command[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--cc", default=None, help="the C compiler (default: $CC, else cc)")
    ap.add_argument("--cflags", default="", help="flags added to the C's (e.g. -funroll-loops for GCC)")
    args = ap.parse_args(argv)
    cc = [args.cc] if args.cc else compiler()
    load = [os.getloadavg()[0]]
    lines = []
    with tempfile.TemporaryDirectory(prefix="hg-export-speed-") as tmp:
        tmp = pathlib.Path(tmp)
        os.environ.setdefault("HAPTICGRAPH_CACHE", str(tmp / "cache"))
        for label, path, seconds in ROWS:
            path = fig7_patch(tmp) if path == "fig7" else path
            samples = int(round(seconds * hapticgraph.load(path).rate))
            folder = tmp / pathlib.Path(path).stem
            folder.mkdir()
            command = build(path, folder, samples, cc, args.cflags.split())
            numba_s, numba_out = kernel_run(path, samples)           # compiles; checked, not timed
            c_s, c_out = c_run(command)
            same = np.array_equal(numba_out.view(np.uint64), c_out.view(np.uint64))
            peak = max(np.abs(numba_out).max(), 1e-300)
            agreement = "same bits" if same else f"{np.abs(numba_out - c_out).max() / peak:.1e} of peak"
            times = {"numba": [], "c": []}
            for rep in range(args.reps):
                for side in (("numba", "c") if rep % 2 == 0 else ("c", "numba")):
                    times[side].append(kernel_run(path, samples)[0] if side == "numba" else c_run(command)[0])
                load.append(os.getloadavg()[0])
            nb, c = statistics.median(times["numba"]), statistics.median(times["c"])
            lines.append(f"| {label} | {seconds:g} s at {samples / seconds:g} Hz | {samples / nb / 1e6:.3g} / "
                         f"{samples / c / 1e6:.3g} | **{nb / c:.2f}×** | {agreement} |")
            print(lines[-1], flush=True)
    print(f"{' '.join(cc + args.cflags.split())}; load (1 min) {min(load):.1f}–{max(load):.1f}, {args.reps} repetitions, medians")
    return 0


if __name__ == "__main__":
    sys.exit(main())
