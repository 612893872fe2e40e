"""A test plugin: a gain whose process is killed (SIGKILL) when it is built with `die` = 1, as a
worker killed by the system in the middle of a variant (out of memory)."""
import os
import signal

from hapticgraph.blocks import Block, In, Out, Param


class Crash(Block, name="crash"):
    """out[n] = in[n]; building it with die = 1 kills the process."""

    x = In(name="in")
    y = Out(name="out")
    die = Param(0.0, minimum=0.0, maximum=1.0, live=False)

    @staticmethod
    def derive(p, fs):
        if p.die > 0.5:
            os.kill(os.getpid(), signal.SIGKILL)
        return {"k": 1.0}

    @staticmethod
    def output(x, k):
        return k * x
