"""NAME_process_float (issue 31: a float variant of process for hosts that want it): float32
columns in and out, the instance computing in double as NAME_process does (chunk by chunk, no
allocation): its outputs are NAME_process's on the float inputs, each rounded once to float32."""
import subprocess

import numpy as np

from hapticgraph import load
from hapticgraph.export.bundle import write_c
from hapticgraph.export.compiler import build
from hapticgraph.graph.c import export_c
from project_env import ROOT
from test_c_waveguides import python_run

DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "{name}.h"

/* total inputs.bin : outputs of NAME_process_float (float32 rows) then of NAME_process (float64 rows) */
int main(int argc, char **argv)
{{
    long total = atol(argv[1]), k;
    int c, nin = {NAME}_N_INPUTS, nout = {NAME}_N_OUTPUTS;
    float **fin = calloc(nin + 1, sizeof *fin), **fout = calloc(nout + 1, sizeof *fout);
    double **din = calloc(nin + 1, sizeof *din), **dout = calloc(nout + 1, sizeof *dout), *all = NULL;
    {name} *a = {name}_new({NAME}_RATE), *b = {name}_new({NAME}_RATE);
    if (a == NULL || b == NULL) return 3;
    if (nin) {{
        FILE *f = fopen(argv[2], "rb");
        all = calloc((size_t)total * nin, sizeof(double));
        if (f == NULL || fread(all, sizeof(double), (size_t)total * nin, f) != (size_t)total * nin) return 5;
        fclose(f);
    }}
    for (c = 0; c < nin; c++) {{
        fin[c] = calloc(total, sizeof(float));
        din[c] = calloc(total, sizeof(double));
        for (k = 0; k < total; k++) {{ fin[c][k] = (float)all[k * nin + c]; din[c][k] = (double)fin[c][k]; }}
    }}
    for (c = 0; c < nout; c++) {{ fout[c] = calloc(total, sizeof(float)); dout[c] = calloc(total, sizeof(double)); }}
    if ({name}_process_float(a, (const float *const *)fin, fout, (int)total) != 0) return 6;
    if ({name}_process(b, (const double *const *)din, dout, (int)total) != 0) return 7;
    for (k = 0; k < total; k++) for (c = 0; c < nout; c++) fwrite(&fout[c][k], sizeof(float), 1, stdout);
    for (k = 0; k < total; k++) for (c = 0; c < nout; c++) fwrite(&dout[c][k], sizeof(double), 1, stdout);
    return 0;
}}
"""


def _run(tmp_path, name, inputs, total):
    lowered = export_c(load(ROOT / "patches" / f"{name}.yaml"), name)
    write_c(lowered, tmp_path)
    (tmp_path / "driver.c").write_text(DRIVER.format(name=name, NAME=name.upper()), encoding="utf-8")
    exe = build([tmp_path / "driver.c", tmp_path / f"{name}.c"], tmp_path / "driver", extra=["-I", str(tmp_path)])
    path = tmp_path / "inputs.bin"
    np.ascontiguousarray(inputs, dtype=np.float64).tofile(path)
    out = subprocess.run([str(exe), str(total), str(path)], capture_output=True, check=True).stdout
    nout = len(lowered.outputs)
    floats = np.frombuffer(out[:4 * total * nout], dtype=np.float32).reshape(total, nout)
    doubles = np.frombuffer(out[4 * total * nout:], dtype=np.float64).reshape(total, nout)
    return floats, doubles


def test_process_float_is_process_rounded_once(tmp_path, same_bits):
    floats, doubles = _run(tmp_path, "karplus_strong", np.zeros((1, 0)), 3000)      # 3000: several chunks
    assert np.abs(doubles).max() > 0.1
    assert same_bits(floats, doubles.astype(np.float32))


def test_process_float_takes_float_device_columns(tmp_path, same_bits):
    """Fig. 8's finger as the Python run's simulated device moved it (plucking at 41 ms)."""
    path = ROOT / "patches" / "fig8_pluck_damp.yaml"
    _, _, columns, _ = python_run(path, export_c(load(path), "fig8_pluck_damp"), 0.1, 950)
    floats, doubles = _run(tmp_path, "fig8_pluck_damp", columns, len(columns))
    assert np.abs(doubles[:, -1]).max() > 0.0                # a force was sent
    assert same_bits(floats, doubles.astype(np.float32))
