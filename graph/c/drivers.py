"""The devices of an exported patch: every device (and every block fed from outside, an audio
input) is a driver whose columns come in through `NAME_process`'s `in`, and whose force goes out
through `out`. The block bound to it keeps its own type (a haptic block reads its sensor columns;
no simulated model is substituted: the host is the device now), and the force it receives is
clamped to the `max_force` of its entry, as the kernel clamps it for any driver (graph/guard.py)."""
import math
from dataclasses import dataclass, field

from ..engine import Driver
from ..entries import driver_of


class ColumnDriver(Driver):
    """A device whose inputs are columns the host supplies (`columns`: the block's External
    attributes, then the device's axes)."""

    def __init__(self, name, columns, max_force):
        self.name, self.columns, self.max_force = name, tuple(columns), max_force


@dataclass
class Hosted:
    """Device columns an exported instance computes itself, from what the host gives it through
    `NAME_midi` (hapticgraph.devices.midi_c: a MIDI device's events), instead of reading them in
    `in`. Its C: `declarations` (types and static functions, before the instance's struct),
    `field` (its member of the struct), statements of NAME_new (`new`, after the instance is
    allocated) and NAME_reset (`reset`), `fill` (the columns of samples s->t … s->t + m − 1 into
    s->hcol[k][0 … m), k a column's index in the program's external columns) and `give` (the body
    of NAME_midi(s, offset, bytes, len))."""
    columns: frozenset          # the (device, column) pairs of the program's external columns it fills
    declarations: str
    field: str
    fill: str
    give: str
    new: list = field(default_factory=list)
    reset: list = field(default_factory=list)


def _max_force(patch, device):
    """The entry's max_force, else its driver kind's default for it; inf when neither says."""
    spec = patch.devices.get(device) if isinstance(patch.devices, dict) else None
    if not isinstance(spec, dict):
        return math.inf
    if spec.get("max_force") is not None:
        return float(spec["max_force"])
    kind = driver_of(spec, patch.registry.drivers)
    setting = kind.settings().get("max_force", {}) if kind is not None else {}
    return float(setting.get("default", math.inf))


def column_drivers(patch):
    """{device or block name: ColumnDriver} for every block bound to a device or fed from outside."""
    drivers = {}
    for name in patch.order:
        inst = patch.blocks[name]
        cls = inst.cls
        refs = [n for n, p in cls.params.items() if p.refers == "devices"]
        if not refs and not cls.externals:
            continue
        device = inst.values[refs[0]] if refs else name
        columns = [e.attr for e in cls.externals]
        columns += [p.name for p in inst.outputs if getattr(p, "external", False) and p.name not in columns]
        drivers[device] = ColumnDriver(device, columns, _max_force(patch, device) if refs else math.inf)
    return drivers


def input_kind(patch, device):
    """"cv" for the columns of a device (a haptic device, a controller), "audio" for a block fed
    from outside by its own driver (an audio input)."""
    if device in (patch.devices or {}):
        return "cv"
    inst = patch.blocks.get(device)
    if inst is not None and any(p.refers in ("controller", "devices") for p in inst.cls.params.values()):
        return "cv"
    return "audio"


__all__ = ["ColumnDriver", "Hosted", "column_drivers", "input_kind"]
