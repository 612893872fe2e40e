"""NAME_refused in WebAssembly says why, as the native build does: the module links no stdio (it
imports nothing), so the runtime formats the refusals itself (graph/c/runtime.py's hg_vsnprintf:
%s, %g with a precision, %%), and that formatter writes what printf writes."""
import math
import random
import struct
import subprocess

import pytest

from hapticgraph.export.compiler import FLAGS, compiler
from hapticgraph.graph.c.runtime import PRELUDE
from project_env import ROOT

CYMATIC = ROOT / "patches" / "cymatic_string.yaml"

# the formatter built on the host, beside the C library's snprintf: "%a P" lines in, one line out
# for each, the formatter's text, or MISMATCH and both texts
CHECK = "#define HG_NO_STDIO\n" + PRELUDE + r"""
#include <stdio.h>
static int hg_test_format(char *p, size_t size, const char *f, ...)
{
    va_list ap;
    int k;
    va_start(ap, f);
    k = hg_vsnprintf(p, size, f, ap);
    va_end(ap);
    return k;
}
int main(void)
{
    double v;
    int p, k, n, size, cut;
    static const int sizes[] = {1, 5, 12, 0};                    /* cut short as vsnprintf cuts; whole */
    char ours[1100], theirs[1100], format[64];
    while (scanf("%la %d", &v, &p) == 2) {
        snprintf(format, sizeof format, "%%s|%%.%dg|%%g|%%%%", p);
        for (cut = 0; cut < 4; cut++) {
            size = sizes[cut];
            memset(ours, 'x', sizeof ours);
            memset(theirs, 'x', sizeof theirs);
            k = hg_test_format(ours, size ? (size_t)size : sizeof ours, format, "at", v, v);
            n = snprintf(theirs, size ? (size_t)size : sizeof theirs, format, "at", v, v);
            if (k != n || memcmp(ours, theirs, sizeof ours) != 0) {
                printf("MISMATCH %d: %s | %s\n", size, ours, theirs);
                break;
            }
        }
        if (cut == 4) printf("%s\n", ours);
    }
    return 0;
}
"""


def _wasm_refused(built, rate, size=8192):
    """(NAME_refused's code, its text) in wasmtime."""
    import wasmtime

    store = wasmtime.Store(built.engine)
    x = wasmtime.Instance(store, built.module, []).exports(store)
    why = x["malloc"](store, size)
    code = x[f"{built.lowered.name}_refused"](store, float(rate), why, size)
    text = bytes(x["memory"].read(store, why, why + size)).split(b"\0")[0].decode("utf-8")
    x["free"](store, why)
    return code, text


def test_the_wasm_refusal_says_what_the_native_build_says(c_export, wasm_export):
    native, wasm = c_export(CYMATIC), wasm_export(CYMATIC)
    assert wasm.imports() == []
    code, text = _wasm_refused(wasm, 2000.0)
    assert code == 1
    assert "unstable at 2000 Hz" in text
    assert text.splitlines() == native.refusal(2000)
    code, text = _wasm_refused(wasm, 50.0)                  # outside the patch format's rates
    assert (code, text.splitlines()) == (1, native.refusal(50))
    assert _wasm_refused(wasm, wasm.lowered.rate) == (0, "")


def _values(count):
    rnd = random.Random(31)
    yield from (0.0, -0.0, 0.5, 2.5, 0.125, 9.9995, 99999.5, 999999.5, 1e-5, 1e-4, 5e-324,
                2.2250738585072014e-308, 1.7976931348623157e308, math.inf, -math.inf, math.nan, 2000.0, 1e23)
    for _ in range(count):
        pick = rnd.random()
        if pick < 0.3:
            v = struct.unpack("<d", struct.pack("<Q", rnd.getrandbits(64)))[0]    # any double
        elif pick < 0.6:
            v = rnd.uniform(-1e6, 1e6)
        else:
            v = rnd.randint(0, 10 ** rnd.randint(1, 8)) * 10.0 ** rnd.randint(-10, 10) + rnd.choice(
                [0.0, 0.5, 0.05, 0.005])                                           # decimal ties
        yield v


def test_the_formatter_writes_what_printf_writes(tmp_path):
    source, exe = tmp_path / "check.c", tmp_path / "check"
    source.write_text(CHECK, encoding="utf-8")
    proc = subprocess.run(compiler() + list(FLAGS) + [str(source), "-o", str(exe), "-lm"],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        pytest.fail(proc.stderr)
    rnd = random.Random(7)
    rows = [(v, rnd.choice([0, 1, 2, 3, 4, 6, 10, 17, 25])) for v in _values(5000)]
    lines = "".join(f"{v.hex() if math.isfinite(v) else repr(v)} {p}\n" for v, p in rows)
    got = subprocess.run([str(exe)], input=lines, capture_output=True, text=True, check=True).stdout.splitlines()
    assert [line for line in got if line.startswith("MISMATCH")] == []
    assert len(got) == len(rows)
    for (v, p), line in zip(rows, got):                     # and what Python's %-format writes
        assert math.isnan(v) or line == f"at|{v:.{p}g}|{v:g}|%", (v, p)
