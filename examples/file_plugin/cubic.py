"""A plugin as a plain .py file beside the patch that names it in `plugins:`."""
from hapticgraph.blocks import Block, In, Out, Param


class Cubic(Block, name="cubic"):
    """out[n] = in[n] − amount · in[n]³ (a gentle odd-harmonic saturation)."""

    x = In(name="in")
    y = Out(name="out")
    amount = Param(0.3, minimum=0.0, maximum=1.0)

    @staticmethod
    def output(x, amount):
        return x - amount * x * x * x
