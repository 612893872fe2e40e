"""Ring buffers in the exported C: a ring whose size reads neither the rate nor a live parameter
has the same length at every rate, so its mask is the literal the numba kernel is given (a
register kept free in the sample loop, as numba keeps it: Fig. 7's five rings); a ring sized from
the rate (a plugin's echo of `delay` seconds) is sized by NAME_new at the host's rate and read
through its length, and gives the bits of the Python run at the patch's rate and at another."""
import re

import numpy as np

import hapticgraph
from hapticgraph.graph.patch import load
from project_env import ROOT

ECHO = '''\
import math

from hapticgraph.blocks import Block, Buffer, In, Out, Param


class Echo(Block, name="echo_seconds"):
    """out[n] = in[n − ceil(delay·fs)] + 0.5·in[n].  Ref: a test's plugin."""
    x = In(name="in")
    y = Out(name="out")
    delay = Param(0.001, unit="s", minimum=1e-4, maximum=0.1, live=False)
    line = Buffer(lambda p, fs: int(math.ceil(p.delay * fs)) + 1)

    @staticmethod
    def derive(p, fs):
        return {"n": int(math.ceil(p.delay * fs))}

    @staticmethod
    def output(line, line_mask, t, n, x):
        return line[(t - n) & line_mask] + 0.5 * x

    @staticmethod
    def update(line, line_mask, t, x):
        line[t & line_mask] = x
'''


def test_fig7s_rings_have_literal_masks(c_export):
    built = c_export(ROOT / "patches" / "fig7_bowed_string.yaml")
    source = (built.exe.parent / "fig7_bowed_string.c").read_text(encoding="utf-8")
    assert ".n - 1)" not in source                       # no mask read from a ring's length
    assert re.search(r"line\.p\[\(\(t - n\) & 15\)\]", source)


def test_a_ring_sized_from_the_rate_is_sized_at_the_hosts_rate(c_export, write_patch, same_bits):
    (write_patch("x", name="echo.py")).write_text(ECHO, encoding="utf-8")
    path = write_patch("""
        hapticgraph: 1
        rate: 44100
        plugins: [echo.py]
        blocks:
          osc: {type: wavetable, frequency: 440.0, amplitude: 0.5}
          echo: {type: echo_seconds, delay: 0.003}
          out: {type: audio_out, channels: 1}
        connect:
          - osc.out -> echo.in
          - echo.out -> out.ch0
        """)
    built = c_export(path)
    source = (built.exe.parent / "p.c").read_text(encoding="utf-8")
    assert "(line.n - 1)" in source or "_line.n - 1)" in source     # its mask follows its length
    for rate in (44100, 48000, 96000):
        patch = load(path, text=re.sub(r"(?m)^rate: .*$", f"rate: {rate}", path.read_text(encoding="utf-8")))
        expected = hapticgraph.render(patch, 0.05).audio
        assert np.abs(expected).max() > 0.0
        assert same_bits(built.run(rate, len(expected)), expected)
