"""Signals from outside the patch: recorded or live audio."""
from .vocabulary import Block, External, Out, Param


class AudioIn(Block, name="audio_in"):
    """out[n] = gain · in[n]: a WAV file (relative to the patch) or, while playing, a live input channel."""

    y = Out(name="out")
    file = Param("", refers="file", doc="a WAV file beside the patch; empty: the live audio input (play)")
    channel = Param(0, minimum=0, maximum=63, doc="which channel of the file or input")
    gain = Param(1.0, unit="N", minimum=-1e6, maximum=1e6, doc="scale: a full-scale sample becomes `gain` newtons")
    loop = Param(False, doc="repeat the file; otherwise silence after its end")
    sample = External()

    @staticmethod
    def output(sample, gain):
        return gain * sample
