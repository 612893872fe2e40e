"""The C export's tests: a patch exported, a small C driver (written here, as a host would) built
with it by the system's compiler, run for N samples, its outputs read back as raw doubles; and the
same patch built to WebAssembly (hapticgraph.export.wasm) and run in wasmtime through the module's
buffer interface, as the AudioWorklet runs it."""
import os
import subprocess

import numpy as np
import pytest
import wasmtime

from hapticgraph import load
from hapticgraph.export.bundle import export_name, lower, write_c
from hapticgraph.export.compiler import build
from hapticgraph.export.wasm import write_wasm

DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "{name}.h"

/* rate total block inputs.bin|- [SAMPLE INDEX VALUE]... : outputs as raw doubles, row by row.
   $HG_MIDI_EVENTS: a file of MIDI events, 5 int64 each (sample, length, 3 bytes), in order; each
   given to {name}_midi before the call whose samples (or the sample after them) it falls on */
int main(int argc, char **argv)
{{
    double rate = atof(argv[1]);
    long total = atol(argv[2]), done, k, n_events = 0, given = 0;
    int block = atoi(argv[3]), n, c, a;
    int nin = {NAME}_N_INPUTS, nout = {NAME}_N_OUTPUTS;
    double *all = NULL, **in, **out;
    long long *events = NULL;
    const char *midi = getenv("HG_MIDI_EVENTS");
    {name} *s = {name}_new(rate);
    if (s == NULL) {{
        static char why[8192];
        if (!{name}_refused(rate, why, (int)sizeof why)) {{ fputs("NULL but not refused\n", stderr); return 6; }}
        fputs(why, stderr);
        return 3;
    }}
    in = calloc(nin + 1, sizeof *in);
    out = calloc(nout + 1, sizeof *out);
    for (c = 0; c < nin; c++) in[c] = calloc(block, sizeof(double));
    for (c = 0; c < nout; c++) out[c] = calloc(block, sizeof(double));
    if (nin) {{
        FILE *f = fopen(argv[4], "rb");
        all = calloc((size_t)total * nin, sizeof(double));
        if (f == NULL || fread(all, sizeof(double), (size_t)total * nin, f) != (size_t)total * nin) return 5;
        fclose(f);
    }}
    if (midi != NULL) {{
        FILE *f = fopen(midi, "rb");
        if (f == NULL) return 5;
        fseek(f, 0, SEEK_END);
        n_events = ftell(f) / (5 * (long)sizeof(long long));
        rewind(f);
        events = calloc((size_t)n_events * 5 + 1, sizeof(long long));
        if (fread(events, sizeof(long long), (size_t)n_events * 5, f) != (size_t)n_events * 5) return 5;
        fclose(f);
    }}
    for (done = 0; done < total; done += n) {{
        for (a = 5; a + 2 < argc; a += 3)
            if (atol(argv[a]) == done && {name}_set(s, atoi(argv[a + 1]), atof(argv[a + 2])) != 0) return 4;
        n = total - done < block ? (int)(total - done) : block;
        for (; given < n_events && events[given * 5] <= done + n; given++) {{
            unsigned char b[3];
            long long *e = events + given * 5;
            b[0] = (unsigned char)e[2]; b[1] = (unsigned char)e[3]; b[2] = (unsigned char)e[4];
            if ({name}_midi(s, (int)(e[0] - done), b, (int)e[1]) != 0) return 7;
        }}
        for (c = 0; c < nin; c++) for (k = 0; k < n; k++) in[c][k] = all[(done + k) * nin + c];
        {name}_process(s, (const double *const *)in, out, n);
        for (k = 0; k < n; k++) for (c = 0; c < nout; c++) fwrite(&out[c][k], sizeof(double), 1, stdout);
    }}
    {name}_free(s);
    return 0;
}}
"""


def midi_records(events):
    """(sample, mido.Message) events as the driver's records: int64 sample, length, 3 bytes."""
    rows = [[sample, len(m.bytes())] + (m.bytes() + [0, 0])[:3] for sample, m in events]
    return np.array(rows, dtype=np.int64).reshape(-1, 5)


class Built:
    """An exported patch built with the test's driver: `run(rate, total, block, inputs, sets)`."""

    def __init__(self, exe, lowered):
        self.exe, self.lowered = exe, lowered

    def param(self, name):
        return [p.name for p in self.lowered.params].index(name)

    def run(self, rate, total, block=1000, inputs=None, sets=(), expect=0, midi=None):
        """`midi`: (sample, mido.Message) events, given to NAME_midi a call ahead at most."""
        folder = self.exe.parent
        path = "-"
        if inputs is not None:
            path = str(folder / "inputs.bin")
            np.ascontiguousarray(inputs, dtype=np.float64).tofile(path)
        args = [str(self.exe), repr(float(rate)), str(total), str(block), path]
        for at, index, value in sets:
            args += [str(at), str(index), repr(float(value))]
        env = dict(os.environ)
        if midi is not None:
            env["HG_MIDI_EVENTS"] = str(folder / "midi.bin")
            midi_records(midi).tofile(env["HG_MIDI_EVENTS"])
        proc = subprocess.run(args, capture_output=True, timeout=120, env=env)
        assert proc.returncode == expect, proc.stderr.decode()
        self.stderr = proc.stderr.decode("utf-8")
        return np.frombuffer(proc.stdout, dtype=np.float64).reshape(-1, len(self.lowered.outputs))

    def refusal(self, rate):
        """Why NAME_new refuses `rate` (NAME_refused's text): one problem a line."""
        self.run(rate, 1, expect=3)
        return self.stderr.splitlines()


def _c_maker(tmp_path):
    def make(patch, name=None, overrides=(), extra=()):
        if isinstance(patch, (str, os.PathLike)):
            patch = load(patch, overrides=overrides)
        name = name or export_name(patch.file)
        lowered = lower(patch, name)
        folder = tmp_path / name
        write_c(lowered, folder)
        driver = folder / "driver.c"
        driver.write_text(DRIVER.format(name=name, NAME=name.upper()), encoding="utf-8")
        exe = folder / "driver"
        build([driver, folder / f"{name}.c"], exe, extra=["-I", str(folder), *extra])
        return Built(exe, lowered)
    return make


@pytest.fixture
def c_export(tmp_path):
    """c_export(patch or path, name=None, overrides=(), extra=()) -> Built (`extra`: more compiler flags)."""
    return _c_maker(tmp_path)


@pytest.fixture(scope="module")
def c_export_module(tmp_path_factory):
    """c_export for a module's tests to share what they build (a name once per module)."""
    return _c_maker(tmp_path_factory.mktemp("c_export"))


class WasmBuilt:
    """An exported patch's NAME.wasm in wasmtime: `run(rate, total, block, inputs, sets)` as Built's."""

    def __init__(self, path, lowered):
        self.path, self.lowered = path, lowered
        engine = wasmtime.Engine()
        self.module = wasmtime.Module.from_file(engine, str(path))
        self.engine = engine

    def imports(self):
        return [(i.module, i.name) for i in self.module.imports]

    def run(self, rate, total, block=1000, inputs=None, sets=(), expect=0, midi=None):
        store = wasmtime.Store(self.engine)
        x = wasmtime.Instance(store, self.module, []).exports(store)
        name = self.lowered.name
        nin, nout = len(self.lowered.inputs), len(self.lowered.outputs)
        h = x[f"{name}_host_new"](store, float(rate), block)
        midi = list(midi or [])
        if h == 0:
            assert expect == 3, f"{name}_host_new refused {rate}"
            return None
        s = x[f"{name}_host_instance"](store, h)
        at_in = [x[f"{name}_host_input"](store, h, k) for k in range(nin)]
        at_out = [x[f"{name}_host_output"](store, h, k) for k in range(nout)]
        memory = x["memory"]
        rows = []
        for done in range(0, total, block):
            for at, index, value in sets:
                if at == done and x[f"{name}_set"](store, s, index, float(value)) != 0:
                    assert expect == 4
                    return None
            n = min(block, total - done)
            while midi and midi[0][0] <= done + n:
                at, message = midi.pop(0)
                status, d1, d2 = (message.bytes() + [0, 0])[:3]
                assert x[f"{name}_host_midi"](store, h, at - done, status, d1, d2) == 0
            for k in range(nin):
                memory.write(store, np.ascontiguousarray(inputs[done:done + n, k], dtype="<f8").tobytes(), at_in[k])
            x[f"{name}_host_process"](store, h, n)
            cols = [np.frombuffer(memory.read(store, at_out[k], at_out[k] + 8 * n), dtype="<f8") for k in range(nout)]
            rows.append(np.stack(cols, axis=1) if cols else np.zeros((n, 0)))
        x[f"{name}_host_free"](store, h)
        assert expect == 0
        return np.concatenate(rows)


@pytest.fixture
def wasm_export(tmp_path):
    """wasm_export(patch or path, name=None, overrides=()) -> WasmBuilt."""
    def make(patch, name=None, overrides=()):
        if isinstance(patch, (str, os.PathLike)):
            patch = load(patch, overrides=overrides)
        name = name or export_name(patch.file)
        lowered = lower(patch, name)
        folder = tmp_path / f"{name}_wasm"
        write_wasm(lowered, folder)
        return WasmBuilt(folder / f"{name}.wasm", lowered)
    return make


def _same_bits(a, b):
    a, b = np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64)
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


@pytest.fixture
def same_bits():
    """same_bits(a, b): equal as float64 bit patterns (-0.0 and 0.0 differ, a NaN equals itself)."""
    return _same_bits
