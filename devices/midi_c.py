"""The MIDI driver of an exported patch, in C: `NAME_midi(s, offset, bytes, len)` queues a channel
message, and each `NAME_process` turns the queue into the columns of the patch's `midi_note` and
`midi_cc` blocks, sample by sample, as hapticgraph.devices.midi (NoteTap, ControlTap) and
hapticgraph.devices.voices (Allocator, with hapticgraph.devices.mpe's Zones) turn a MIDI file's
events into them: the same resolution of the events of one sample, the same voice taken, the same
one-sample dip before a restrike, the same MPE zones. It is their twin, written in C because the
host runs it without Python; tests/export/test_c_midi.py holds the two equal, column for column,
on the shipped patches' files and on fuzzed event streams.

Timing. An event given at `offset` takes effect at sample t + offset, t being the first sample of
the next `NAME_process` call (an offset past that call's end waits for a later call). A voice
allocator reads one sample past each call (a restruck voice's gate dips at the sample before its
note-on), so an event given for a sample the instance has read already falls on the first sample
it has not: as a live port's events do in Python (hapticgraph.devices.events), a host that gives
each call's events at that call hears a note-on at its first sample one sample late when the patch
has `voices:`; a host that gives them a call ahead (a file, a sequencer) hears every event at its
sample, exactly as `hapticgraph run` plays the file.

Every MIDI device of the patch hears the one stream `NAME_midi` carries (a plugin has one MIDI
input); each block keeps its own channel.
"""
from dataclasses import dataclass
from importlib import resources

from ..graph.c.drivers import Hosted
from .midi import ControlTap, NoteTap
from .mpe import (BEND_RANGE, CONFIGURATION, DATA_MSB, LOWER, MASTER_RANGE, MASTERS, MEMBER_RANGE, NRPN_LSB, NRPN_MSB,
                  PLAYED, RPN_CONTROLS, RPN_LSB, RPN_MSB, UPPER)
from .voices import ALL_OFF, COLUMNS, SLIDE_CC

QUEUE = 1024          # events given and not yet played, per instance
MODES = {"off": 0, "lower": 1, "upper": 2, "auto": 3}     # a group's `mpe:`, as the C numbers it



def _c_set(values):
    return " || ".join(f"(c) == {v}" for v in sorted(values))


def runtime(notes, ccs, allocs, voices):
    """The C of the MIDI driver for a patch with that many blocks of each kind (HG_VOICES: its
    largest group)."""
    text = (resources.files(__package__) / "c" / "midi.c").read_text(encoding="utf-8")
    for key, value in (("QUEUE", QUEUE), ("MEMBER_RANGE", repr(float(MEMBER_RANGE))),
                       ("MASTER_RANGE", repr(float(MASTER_RANGE))), ("SLIDE_CC", SLIDE_CC),
                       ("ALL_OFF", _c_set(ALL_OFF)), ("RPN", _c_set(RPN_CONTROLS)),
                       ("MASTERS", ", ".join(map(str, MASTERS))),
                       ("COLUMNS", ", ".join("HG_" + c.removeprefix("midi_").upper() for c in COLUMNS)),
                       ("PLAYS", ", ".join("{" + ", ".join(str(int(z in PLAYED.get(mode, ()))) for z in (LOWER, UPPER)) + "}"
                                           for mode in MODES)),
                       ("UPPER_MODE", MODES["upper"]), ("UPPER", UPPER), ("LOWER", LOWER),
                       ("NRPN_MSB", NRPN_MSB), ("NRPN_LSB", NRPN_LSB), ("RPN_MSB", RPN_MSB), ("RPN_LSB", RPN_LSB),
                       ("DATA_MSB", DATA_MSB), ("CONFIGURATION_MSB", CONFIGURATION[0]),
                       ("CONFIGURATION_LSB", CONFIGURATION[1]), ("BEND_RANGE_MSB", BEND_RANGE[0]),
                       ("BEND_RANGE_LSB", BEND_RANGE[1])):
        text = text.replace(f"@{key}@", str(value))
    sizes = f"#define HG_N_NOTES {notes}\n#define HG_N_CCS {ccs}\n#define HG_N_ALLOCS {allocs}\n#define HG_VOICES {max(1, voices)}\n"
    return sizes + text


@dataclass
class _Group:
    device: str
    channel: int
    count: int
    mpe: str
    voices: dict        # voice index (0-based) -> the first column


def _channel(inst):
    channel = int(inst.values.get("channel", 0))
    return channel - 1 if channel else -1


def midi_hosted(patch, ext_columns):
    """The Hosted driver (graph/c/drivers.py) of the patch's midi_note and midi_cc blocks, whose
    columns are `ext_columns` positions ((block name, column) in the kernel's order); None when
    the patch has none."""
    where = {}
    for k, (device, column) in enumerate(ext_columns):
        where.setdefault(device, k)
    notes, ccs, groups, hosted = [], [], {}, set()
    for name in patch.order:
        inst = patch.blocks[name]
        spec = (patch.devices or {}).get(inst.values.get("device"))
        taken = tuple(e.attr for e in inst.cls.externals)       # the columns its tap writes in Python
        if name not in where or not isinstance(spec, dict) or spec.get("driver") != "midi":
            continue
        if taken == ControlTap.columns:
            ccs.append((_channel(inst), int(inst.values.get("number", 1)), where[name]))
        elif taken == NoteTap.columns and int(inst.values.get("voice", 0)) > 0:
            key = (inst.values.get("device"), _channel(inst), int(inst.values.get("voices", 1)), inst.values.get("mpe", "off"))
            group = groups.setdefault(key, _Group(*key, {}))
            group.voices[int(inst.values["voice"]) - 1] = where[name]
        elif taken == NoteTap.columns:
            notes.append((_channel(inst), where[name]))
        else:
            continue
        hosted.add(name)
    if not hosted:
        return None
    columns = {(device, column) for device, column in ext_columns if device in hosted}
    setup = []
    for k, (channel, col) in enumerate(notes):
        setup += [f"s->midi.notes[{k}].channel = {channel};", f"s->midi.notes[{k}].col = {col};"]
    for k, (channel, number, col) in enumerate(ccs):
        setup += [f"s->midi.ccs[{k}].channel = {channel};", f"s->midi.ccs[{k}].number = {number};",
                  f"s->midi.ccs[{k}].col = {col};"]
    for k, g in enumerate(groups.values()):
        a = f"s->midi.allocs[{k}]"
        setup += [f"{a}.channel = {g.channel};", f"{a}.count = {g.count};", f"{a}.mpe = {int(g.mpe != 'off')};",
                  f"{a}.zones.mode = {MODES[g.mpe]};"]
        setup += [f"{a}.col[{v}] = {g.voices.get(v, -1)};" for v in range(g.count)]
    voices = max((g.count for g in groups.values()), default=1)
    return Hosted(columns=columns, declarations=runtime(len(notes), len(ccs), len(groups), voices),
                  field="hg_midi midi;", new=setup, reset=["hg_midi_reset(&s->midi);"],
                  fill="hg_midi_fill(&s->midi, s->t, m, s->hcol);",
                  give="return hg_midi_give(&s->midi, s->t + (offset > 0 ? offset : 0), bytes, len);")


__all__ = ["QUEUE", "midi_hosted", "runtime"]
