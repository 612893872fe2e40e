"""An example plugin: a soft clipper, the kind of nonlinearity a string's bridge might add."""
import math

from hapticgraph.blocks import Block, In, Out, Param


class SoftClip(Block, name="soft_clip"):
    """out[n] = limit · tanh(in[n] / limit)."""

    x = In(name="in")
    y = Out(name="out")
    limit = Param(1.0, unit="N", above=0.0, maximum=1e6, doc="the level the output approaches")

    @staticmethod
    def output(x, limit):
        return limit * math.tanh(x / limit)
