"""One block's part of a Program: where each of its function arguments comes from, its slots."""
import numpy as np


def freeze(value):
    """Lists become tuples of floats (literals), numpy scalars become Python scalars."""
    if isinstance(value, np.ndarray):
        return tuple(float(x) for x in value.ravel())
    if isinstance(value, (list, tuple)):
        return tuple(float(x) for x in value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    return value


class BlockPlan:
    """One block's part of the plan."""

    def __init__(self, index, inst):
        self.index, self.inst, self.cls, self.name = index, inst, inst.cls, inst.name
        self.values = dict(inst.values)
        self.inputs = {}          # public input name -> (source node, ...)
        self.live = {}            # live param -> slot
        self.live_sources = {}    # connected live param -> sources
        self.states = []          # slots
        self.state_nodes = []     # StateSlot of each state, named after the block
        self.live_nodes = {}      # live param -> Live
        self.coef_nodes = {}      # coefficient -> Coef
        self.ident = None         # the sanitized, unique prefix of the block's kernel locals
        self.buffers = []         # indices into Program.buffers
        self.coef_mode = None     # None | "literal" | "slot" | "per_sample"
        self.coefs = {}
        self.coef_slots = {}
        self.coef_arrays = {}     # array coefficients of a slot-mode block -> ArrayRef
        self.output_args = ()
        self.update_args = ()
        self.derive_args = {}     # for per-sample derive: param -> binding
        self.device = None        # the device entry this block is bound to
        self.ext = {}             # External attr -> column of the ext array
        # output attr -> (buffer attr, index): outputs the block writes into a buffer (Out.element)
        self.elements = {p.attr: p.element for p in inst.outputs if getattr(p, "element", None)}

    def params(self):
        return self.cls.param_tuple()(**self.values)
