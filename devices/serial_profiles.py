"""Serial wire-protocol profiles: how a haptic device on a serial line (USB CDC, UART) frames its
sensor values and takes its force, in YAML, in the manner of the HID profiles
(hapticgraph.devices.hid_profiles, whose field syntax and checks are reused).

Profile format (version 1)::

    serial_profile: 1
    name: fader_1dof                  # optional; defaults to the file's stem
    description: ...
    baudrate: 115200                  # a device entry may override it (a USB CDC device ignores it)
    max_force: 2.0                    # N: the device's bound; every force sent is clamped to it
    input:                            # device -> host frames
      sync: [0xA5, 0x5A]              # the bytes every frame starts with (1–4)
      length: 6                       # payload bytes after the sync
      checksum: sum8                  # one byte after the payload: sum8 (sum mod 256), xor, or none
      interval: 0.001                 # s between frames (the device streams)
      timeout: 0.02                   # s of silence that mean the device stopped answering
      position: pos                   # as in a HID profile: position axis, velocity axis or `estimate`
      velocity: estimate
      velocity_cutoff: 100
      axes: {pos: {byte: 0, size: 16, signed: true, scale: 1.0e-5, unit: m}}
      buttons: {touch: {byte: 4, bit: 0}}
    output:                           # host -> device frames
      sync: [0xA5, 0x46]
      length: 2
      checksum: sum8
      force: {byte: 0, size: 16, signed: true, scale: 10000}   # counts per newton

Field offsets (`byte`) count from the first payload byte.
"""
import os
from dataclasses import dataclass

from ..blocks.numbers import is_whole, whole_number
from ..graph.source import LDict, load_yaml
from .hid_profiles import AXIS_KEYS, BUTTON_KEYS, FORCE_KEYS, check_field, check_fields, check_overlaps
from .limits import FORCE_CEILING
from .yaml_checks import Checker as _Checker
from .yaml_checks import line_of as _line

SUFFIXES = (".yaml", ".yml")
CHECKSUMS = ("sum8", "xor", "none")
TOP_KEYS = ("serial_profile", "name", "description", "baudrate", "max_force", "input", "output")
INPUT_KEYS = ("sync", "length", "checksum", "interval", "timeout", "position", "velocity", "velocity_cutoff",
              "axes", "buttons")
OUTPUT_KEYS = ("sync", "length", "checksum", "force")
MAX_FRAME = 256


def checksum(kind, payload):
    if kind == "sum8":
        return sum(payload) & 0xFF
    if kind == "xor":
        x = 0
        for b in payload:
            x ^= b
        return x
    return None


@dataclass(frozen=True)
class Framing:
    sync: bytes
    length: int
    checksum: str

    @property
    def size(self):
        return len(self.sync) + self.length + (self.checksum != "none")

    def frame(self, payload):
        tail = b"" if self.checksum == "none" else bytes([checksum(self.checksum, payload)])
        return self.sync + bytes(payload) + tail

    def check(self, frame):
        """The payload of a whole frame (starting with sync), or None if its checksum is wrong."""
        payload = frame[len(self.sync):len(self.sync) + self.length]
        if self.checksum != "none" and frame[len(self.sync) + self.length] != checksum(self.checksum, payload):
            return None
        return payload


@dataclass(frozen=True)
class SerialInput:
    framing: Framing
    interval: float
    timeout: float
    axes: tuple
    buttons: tuple
    position: str = None
    velocity: str = "estimate"
    velocity_cutoff: float = 50.0

    def data(self, payload):                 # what hid.Decoder asks of an input report
        return payload


@dataclass(frozen=True)
class SerialOutput:
    framing: Framing
    force: object

    def encode(self, force):
        buf = bytearray(self.framing.length)
        self.force.put(buf, 0, round(force * self.force.scale))
        return self.framing.frame(buf)

    def decode(self, frame):
        payload = self.framing.check(frame)
        return None if payload is None else self.force.counts(bytes(payload)) / self.force.scale


@dataclass(frozen=True)
class SerialProfile:
    name: str
    file: str
    baudrate: int
    max_force: float
    input: SerialInput
    output: SerialOutput
    description: str = ""

    @property
    def ports(self):
        return tuple(f.name for f in self.input.axes) + tuple(f.name for f in self.input.buttons)


def shipped_dir():
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "profiles", "serial")


def shipped_profiles():
    return sorted(os.path.splitext(f)[0] for f in os.listdir(shipped_dir()) if f.endswith(SUFFIXES))


def find_profile(ref, base=None):
    """A profile file: `ref` beside the patch (a .yaml path) or a shipped profile's name; None if absent."""
    if ref.endswith(SUFFIXES):
        path = os.path.join(base or os.getcwd(), ref)
        return path if os.path.isfile(path) else None
    path = os.path.join(shipped_dir(), ref + ".yaml")
    return path if ref in shipped_profiles() else None


def load_profile(path):
    """Parse and check a profile file; raises PatchError listing every problem (FILE:LINE)."""
    doc, problems = load_yaml(path)
    profile = _parse(doc, path, problems) if doc is not None else None
    problems.raise_if_any()
    return profile


def _framing(chk, node, where):
    sync = node.get("sync")
    if isinstance(sync, list) and all(is_whole(b) for b in sync):
        sync = [whole_number(b) for b in sync]          # 165.0 is the byte 165
    if not (isinstance(sync, list) and 1 <= len(sync) <= 4 and all(is_whole(b) and 0 <= b <= 255 for b in sync)):
        chk.add(_line(node, "sync"), f"{where}.sync: expected 1 to 4 byte values, e.g. [0xA5, 0x5A]")
        sync = [0]
    length = chk.integer(node, "length", where, 1, MAX_FRAME, required=True)
    kind = chk.text(node, "checksum", where, "sum8")
    if kind not in CHECKSUMS:
        chk.add(_line(node, "checksum"), f"{where}.checksum: {kind!r} is not one of {', '.join(CHECKSUMS)}")
    return Framing(bytes(sync), length or 1, kind), length


def _input(chk, doc):
    inp = chk.mapping(doc, "input", "profile")
    if inp is None:
        return None
    chk.keys(inp, INPUT_KEYS, "input")
    framing, length = _framing(chk, inp, "input")
    interval = chk.number(inp, "interval", "input", None, required=True, positive=True)
    timeout = chk.number(inp, "timeout", "input", None, required=True, positive=True)
    if timeout is not None and interval is not None and timeout <= interval:
        chk.add(_line(inp, "timeout"), f"input.timeout: {timeout:g} s must be longer than the interval {interval:g} s")
    names = {}
    axes = check_fields(chk, inp, "axes", "input", AXIS_KEYS, 8, length, names)
    buttons = check_fields(chk, inp, "buttons", "input", BUTTON_KEYS, 1, length, names)
    check_overlaps(chk, axes + buttons, "input")
    position = chk.text(inp, "position", "input", None)
    velocity = chk.text(inp, "velocity", "input", "estimate")
    for key, value in (("position", position), ("velocity", velocity)):
        if value is not None and value != "estimate" and value not in names:
            chk.add(_line(inp, key), f"input.{key}: no axis named {value!r}")
    if position is None:
        chk.add(inp.line, "input: a haptic device needs a `position` axis")
    cutoff = chk.number(inp, "velocity_cutoff", "input", 50.0, nonneg=True)
    return SerialInput(framing, interval or 1.0, timeout or 1.0, tuple(axes), tuple(buttons), position,
                       velocity, cutoff)


def _output(chk, doc):
    outp = chk.mapping(doc, "output", "profile")
    if outp is None:
        return None
    chk.keys(outp, OUTPUT_KEYS, "output")
    framing, length = _framing(chk, outp, "output")
    node = outp.get("force")
    if isinstance(node, LDict):
        node.line = _line(outp, "force")
    force = check_field(chk, "force", node, "output.force", FORCE_KEYS, 16, length, _line(outp, "force"))
    return SerialOutput(framing, force) if force is not None else None


def _parse(doc, path, problems):
    chk = _Checker(problems)
    if not isinstance(doc, LDict) or doc.get("serial_profile") != 1:
        chk.add(getattr(doc, "line", 1), "a serial profile is a mapping starting with `serial_profile: 1`")
        return None
    chk.keys(doc, TOP_KEYS, "profile")
    name = chk.text(doc, "name", "profile", os.path.splitext(os.path.basename(path))[0])
    baud = chk.integer(doc, "baudrate", "profile", 300, 50_000_000, default=115200)
    max_force = chk.number(doc, "max_force", "profile", None, required=True, positive=True)
    if max_force is not None and max_force > FORCE_CEILING:
        chk.add(_line(doc, "max_force"), f"profile.max_force: {max_force:g} N is above {FORCE_CEILING:g} N")
    inp, out = _input(chk, doc), _output(chk, doc)
    if not chk.ok:
        return None
    return SerialProfile(name, path, baud, max_force, inp, out, chk.text(doc, "description", "profile"))


__all__ = ["Framing", "SerialProfile", "checksum", "find_profile", "load_profile", "shipped_profiles"]
