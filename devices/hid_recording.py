"""Descriptor and recording files: `read_descriptor(path)` reads a report descriptor given as raw
bytes, as a hex dump, or as the `R:` line of a hid-recorder recording; `load_recording(path)`
reads a whole hid-recorder recording (hid-tools' `hid-recorder`, also in bentiss/hid-devices):

    # comments
    D: 0                             the device the following lines are about (the first is used)
    R: 148 05 01 09 04 a1 01 ...     the report descriptor: its length, then its bytes in hex
    N: Sony PLAYSTATION(R)3 Controller
    P: usb-0000:00:14.0-2/input0
    I: 3 054c 0268                   bus, vendor id, product id (hex)
    E: 0.000000 49 01 00 00 ...      a report: seconds since the start, its length, its bytes

Reading a file never runs anything in it. A problem is a RecordingError whose text is
`FILE:LINE: message` (or `FILE: message`).
"""
import os
import re
from dataclasses import dataclass

HEX_BYTE = re.compile(r"(?:0[xX])?([0-9a-fA-F]{1,2})")
COMMENTS = re.compile(r"/\*.*?\*/|//[^\n]*|#[^\n]*|;[^\n]*", re.S)


class RecordingError(ValueError):
    """A descriptor or recording file that cannot be read; its text is FILE:LINE: message."""


@dataclass(frozen=True)
class Recording:
    path: str
    name: str
    bus: int
    vendor_id: int
    product_id: int
    descriptor: bytes
    events: tuple            # (t [s], report bytes), in time order

    def interval(self, default=0.008):
        """The median time between reports [s] (within 1 … 100 ms): the device's report interval."""
        gaps = sorted(b[0] - a[0] for a, b in zip(self.events, self.events[1:]) if b[0] > a[0])
        if not gaps:
            return default
        return min(max(gaps[len(gaps) // 2], 0.001), 0.1)


def _hex_bytes(tokens, path, number):
    out = bytearray()
    for tok in tokens:
        m = HEX_BYTE.fullmatch(tok)
        if m is None:
            raise RecordingError(f"{path}:{number}: {tok!r} is not a byte in hex")
        out.append(int(m.group(1), 16))
    return bytes(out)


def _counted(rest, path, number, what):
    """`COUNT HEX HEX ...` -> bytes, the count checked."""
    tokens = rest.split()
    if not tokens or not tokens[0].isdigit():
        raise RecordingError(f"{path}:{number}: {what}: expected the length, then the bytes in hex")
    count, data = int(tokens[0]), _hex_bytes(tokens[1:], path, number)
    if count != len(data):
        raise RecordingError(f"{path}:{number}: {what}: the length says {count} bytes, the line has {len(data)}")
    return data


def _read_text(path):
    try:
        with open(path, "rb") as f:
            raw = f.read()
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        return raw, raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw, None


def load_recording(path):
    """The Recording in a hid-recorder file (its first device)."""
    path = os.fspath(path)
    _, text = _read_text(path)
    if text is None:
        raise RecordingError(f"{path}: not a hid-recorder recording (not text)")
    device, current, name, ids, descriptor, events = None, 0, "", (0, 0, 0), None, []
    for number, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        key, _, rest = line.partition(":")
        rest = rest.strip()
        if key == "D":
            if not rest.isdigit():
                raise RecordingError(f"{path}:{number}: D: expected a device number")
            current = int(rest)
            if device is None:
                device = current
            continue
        if device is not None and current != device:
            continue
        if key == "R" and descriptor is None:
            descriptor = _counted(rest, path, number, "R")
        elif key == "N" and not name:
            name = rest
        elif key == "I":
            ids = _ids(rest, path, number)
        elif key == "E":
            events.append(_event(rest, path, number, events[-1][0] if events else None))
        elif key not in ("N", "P", "I", "R", "S"):
            raise RecordingError(f"{path}:{number}: {line[:20]!r} is not a line of a hid-recorder recording "
                                 f"(D:, R:, N:, P:, I:, E:)")
    if descriptor is None:
        raise RecordingError(f"{path}: no `R:` line (the report descriptor): not a hid-recorder recording")
    if events:
        t0 = events[0][0]
        events = [(t - t0, data) for t, data in events]
    return Recording(path, name, ids[0], ids[1], ids[2], descriptor, tuple(events))


def _ids(rest, path, number):
    """(bus, vendor, product) of an `I:` line."""
    try:
        ids = tuple(int(p, 16) for p in rest.split()[:3])
    except ValueError:
        ids = ()
    if len(ids) != 3:
        raise RecordingError(f"{path}:{number}: I: expected `BUS VENDOR PRODUCT` in hex")
    return ids


def _event(rest, path, number, last):
    """(time, report bytes) of an `E:` line; `last`: the time of the event before, or None."""
    t, _, data = rest.partition(" ")
    try:
        stamp = float(t)
    except ValueError:
        raise RecordingError(f"{path}:{number}: E: {t!r} is not a time in seconds") from None
    report = _counted(data, path, number, "E")
    if last is not None and stamp < last:
        raise RecordingError(f"{path}:{number}: E: the time {stamp:g} s goes back "
                             f"(the report before is at {last:g} s)")
    return stamp, report


def read_descriptor(path):
    """(descriptor bytes, a title) from a file: raw bytes, a hex dump (`05 01 09 04`, `0x05, 0x01,`
    with #, //, /* */ comments) or a hid-recorder recording's `R:` line."""
    path = os.fspath(path)
    raw, text = _read_text(path)
    if not raw:
        raise RecordingError(f"{path}: the file is empty")
    if text is None or (raw and raw[0] < 0x20 and raw[:1] not in (b"\t", b"\n", b"\r")):
        return raw, f"{path}: {len(raw)} bytes (raw)"
    if re.search(r"^R:", text, re.M):
        rec = load_recording(path)
        who = rec.name or "?"
        return rec.descriptor, f"{path}: {who} ({rec.vendor_id:04x}:{rec.product_id:04x}), {len(rec.descriptor)} bytes"
    out = bytearray()
    stripped = COMMENTS.sub(lambda m: "\n" * m.group(0).count("\n"), text)
    for number, line in enumerate(stripped.splitlines(), 1):
        tokens = [t for t in re.split(r"[\s,]+", line) if t]
        out += _hex_bytes(tokens, path, number)
    if not out:
        raise RecordingError(f"{path}: no bytes: expected a report descriptor (raw, hex, or a recording's R: line)")
    return bytes(out), f"{path}: {len(out)} bytes"


__all__ = ["Recording", "RecordingError", "load_recording", "read_descriptor"]
