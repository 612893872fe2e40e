"""Listening points and the patch's sound output."""
import math

from .vocabulary import Block, In, Out, Param


class Mic(Block, name="mic"):
    """left = gain·cos θ·in, right = gain·sin θ·in, θ = (pan + 1)·π/4 (constant-power pan)."""

    x = In(name="in")
    left = Out()
    right = Out()
    gain = Param(1.0, minimum=-1e9, maximum=1e9)
    pan = Param(0.0, minimum=-1.0, maximum=1.0, doc="−1 left … 1 right")

    @staticmethod
    def output(x, gain, pan):
        theta = (pan + 1.0) * (0.25 * math.pi)
        g = gain * x
        return g * math.cos(theta), g * math.sin(theta)


class AudioOut(Block, name="audio_out"):
    """The patch's sound: each input channel, summed over its connections, one frame per sample."""

    channels = Param(2, minimum=1, maximum=64, doc="2: ports left, right; otherwise ch0 … chN−1")
    audio_sink = True
    drawing = {"dot": "house"}

    @classmethod
    def ports(cls, values):
        n = int(values.get("channels", 2))
        names = ["left", "right"] if n == 2 else [f"ch{i}" for i in range(n)]
        ports = []
        for name in names:
            port = In(name=name)
            port.attr = name
            ports.append(port)
        return tuple(ports), ()
