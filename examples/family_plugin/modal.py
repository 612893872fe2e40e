"""A fused family from a plugin file: `modal_bank`, a bank of damped resonators (mass 1 kg,
x'' = F − ω²x − (2/τ)x', semi-implicit Euler) whose modes are points `bank[i]` with a `force`
input and a `position` output. Every bank in a patch is stepped by ONE loop per sample; graph/
is not touched: the block names its family, the family builds a Group (blocks/family.py)."""
import math

import numpy as np

from hapticgraph.blocks import Block, Param, helper
from hapticgraph.blocks.family import Array, Family, Group, Number


@helper
def modal_step(x, v, f, k, c, dt):
    for i in range(x.shape[0]):
        v[i] += dt * (f[i] - k[i] * x[i] - c[i] * v[i])
        f[i] = 0.0
        x[i] += dt * v[i]


class Bank(Group):
    def __init__(self, members, rate):
        self.names, self.offset = [m.name for m in members], {}
        freqs, decays = [], []
        for m in members:
            self.offset[m.name] = len(freqs)
            freqs += list(m.values["freqs"])
            decays += [m.values["decay"]] * len(m.values["freqs"])
        n, w = len(freqs), 2 * math.pi * np.array(freqs)
        self.arrays = {"x": np.zeros(n), "v": np.zeros(n), "f": np.zeros(n), "k": w * w,
                       "c": 2.0 / np.array(decays)}
        self.dt, self.sizes = 1.0 / rate, {m.name: len(m.values["freqs"]) for m in members}

    def point(self, block, index):
        ok = index is not None and len(index) == 1 and 0 <= index[0] < self.sizes.get(block, 0)
        return self.offset[block] + index[0] if ok else None

    def point_array(self, port):
        return {"position": "x", "force": "f"}[port]

    def step(self):
        keys = ("x", "v", "f", "k", "c")
        return modal_step, [Array(k) for k in keys] + [Number(self.dt, "float", "dt")]


class Modal(Family):
    point_ports = {"force": "input", "position": "output"}

    @classmethod
    def index_problem(cls, inst, index):
        n = len(inst.values["freqs"])
        return None if len(index) == 1 and 0 <= index[0] < n else f"no such mode; the bank has modes [0] … [{n - 1}]"

    @classmethod
    def build(cls, members, rate, editable=False):
        return Bank(members, rate)


class ModalBank(Block, name="modal_bank"):
    """x_i'' = F_i − (2π f_i)² x_i − (2/decay)·x_i' for each mode i (1 kg each)."""

    freqs = Param([440.0], minimum=1.0, maximum=20000.0, min_items=1, max_items=4096, doc="mode frequencies [Hz]")
    decay = Param(1.0, unit="s", above=0.0, maximum=1e3, doc="amplitude decay time τ of every mode")
    family = Modal
