"""Powers in the exported C: numba's LLVM rewrites `b ** x` for a known base that is a power of two
into exp2(n·x), and `x ** e` for a known exponent 0.5, 2, 1 or −1 into sqrt, x·x, x, 1/x; glibc's
pow rounds otherwise on about one argument in a thousand, so the translator spells them the same
way (graph/c/ops.py: power). A plugin block takes every such power of a noise, and the C gives the
bits of the Python run over 20,000 samples (before, pow: 2.0 ** x differed on 20 of 20,000
arguments, x ** 2.0 on 16)."""
import numpy as np

import hapticgraph

POWERS = '''\
import math

from hapticgraph.blocks import Block, In, Out


class Powers(Block, name="powers"):
    """Sums of powers of |in|·20 − 10 with known bases and exponents.  Ref: a test's plugin."""
    x = In(name="in")
    a = Out(name="bases")
    b = Out(name="exponents")
    c = Out(name="others")

    @staticmethod
    def output(x):
        u = abs(x) * 20.0 - 10.0
        w = abs(x) * 20.0 + 1e-3
        bases = math.pow(2.0, u) + 2.0 ** (u * 0.7) + math.pow(0.5, u) + math.pow(8.0, u) * 1e-9
        exponents = math.pow(w, 0.5) + w ** 2.0 + math.pow(u, 1.0) + math.pow(w, -1.0)
        others = math.pow(10.0, u * 0.1) + math.pow(w, 3.0) + math.pow(w, -2.0) + w ** 0.25 + math.pow(3.0, u * 0.3)
        return bases, exponents, others
'''


def test_known_bases_and_exponents_give_the_bits_of_numba(c_export, write_patch, same_bits):
    write_patch("x", name="powers.py").write_text(POWERS, encoding="utf-8")
    path = write_patch("""
        hapticgraph: 1
        rate: 20000
        plugins: [powers.py]
        blocks:
          n: {type: noise, amplitude: 1.0, seed: 3}
          p: {type: powers}
          out: {type: audio_out, channels: 3}
        connect:
          - n.out -> p.in
          - p.bases -> out.ch0
          - p.exponents -> out.ch1
          - p.others -> out.ch2
        """)
    built = c_export(path)
    source = (built.exe.parent / "p.c").read_text(encoding="utf-8")
    assert "exp2(" in source and "sqrt(" in source
    expected = hapticgraph.render(hapticgraph.load(path), 1.0).audio
    assert np.isfinite(expected).all() and len(np.unique(expected[:, 0])) > 19000
    assert same_bits(built.run(20000, len(expected)), expected)
