"""Recording a performance (`hapticgraph play --record TAKE`) and replaying it offline
(`hapticgraph run PATCH --replay TAKE`, or a device entry `{driver: replay, file: TAKE.hgrec}`).

A take is two files with one stem:

- `TAKE.hgrec`: every device input the drivers supplied to the kernel, sample by sample (the
  `ext` columns of each driver: a simulated hand's trajectory, a HID device's axes and buttons,
  a live audio input's samples), followed by the force the patch sent to each device (zero in a
  block stopped for safety). Layout: 8 bytes `HGREC\\0` + format version (uint16 LE), the header
  length (uint64 LE), a JSON header (UTF-8, padded with spaces to a multiple of 8 bytes), then
  float64 little-endian rows, one per sample, of `len(header["columns"])` values. The header
  never changes after it is written — the number of rows is (file size − data offset) // row
  size — so the file is complete at every moment.
- `TAKE.wav`: the audio sent to the sound card, 32-bit float; its header (RIFF, fact and data
  sizes) is rewritten at every flush (every 0.2 s) and on close, so it is a valid file at every
  stop.

The header names the patch by a fingerprint of what a take has to match: the rate, the device
names with their axes, and the audio_in blocks. A take from another patch is refused before
anything starts (exit status 2); a take from the same patch with changed parameters re-renders
the same gestures through the changed instrument. Each driver's entry keeps what makes the kernel
identical on replay: its columns, the block type it substitutes (e.g. the simulated device's
model) and that block's internal values (mass, grip, max_force).

While playing, the audio callback only copies each block into preallocated ring buffers; a
writer thread appends them to the files.
"""
import datetime
import hashlib
import importlib
import json
import os
import struct
import sys
import threading

import numpy as np

from ..graph.engine import Driver
from ..graph.patch import device_axes
from . import DeviceError

MAGIC = b"HGREC\x00"
VERSION = 1
SUFFIX = ".hgrec"


class TakeError(DeviceError):
    """A take that cannot be read, or that does not belong to the patch."""


# -- the patch a take belongs to ------------------------------------------------------------------
def patch_signature(patch):
    """What a take must match: the rate, each device's name and axes, the audio_in blocks."""
    return {
        "rate": float(patch.rate),
        "devices": {name: list(device_axes(patch.devices, name)) for name in sorted(patch.devices)},
        "inputs": sorted(inst.name for inst in patch.blocks.values() if inst.cls.type_name == "audio_in"),
    }


def fingerprint(signature):
    return hashlib.sha256(json.dumps(signature, sort_keys=True).encode()).hexdigest()[:16]


def _describe(sig):
    devs = ", ".join(f"{n}({', '.join(['x', 'v'] + a)})" for n, a in sig["devices"].items()) or "none"
    ins = ", ".join(sig["inputs"]) or "none"
    return f"{sig['rate']:g} Hz, devices {devs}, audio inputs {ins}"


def _type_path(cls):
    return None if cls is None else f"{cls.__module__}:{cls.__qualname__}"


def _import_type(path):
    if path is None:
        return None
    module, _, qual = path.partition(":")
    try:
        obj = importlib.import_module(module)
        for part in qual.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as exc:
        raise TakeError(f"the take's device model {path} is not available: {exc}") from None
    return obj


def _jsonable(value):
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    return value


def take_paths(path):
    """(TAKE.hgrec, TAKE.wav) for `--record TAKE`, `TAKE.hgrec` or `TAKE.wav`."""
    stem, ext = os.path.splitext(os.fspath(path))
    if ext.lower() not in (SUFFIX, ".wav"):
        stem = os.fspath(path)
    return stem + SUFFIX, stem + ".wav"


def take_header(session, channels, blocksize, kinds=None):
    """The JSON header of a take of `session` (its Program's ext columns and forces)."""
    prog, patch = session.prog, session.prog.patch
    sig = patch_signature(patch)
    drivers, offset = {}, 0
    order = []
    for device, _ in prog.ext_columns:
        if device not in order:
            order.append(device)
    for device in order:
        d = prog.drivers[device]
        cols = [c for dev, c in prog.ext_columns if dev == device]
        drivers[device] = {"kind": (kinds or {}).get(device, type(d).__name__), "columns": cols,
                           "offset": offset, "block_type": _type_path(d.block_type),
                           "block_values": _jsonable(d.block_values()),
                           "input": device in sig["inputs"]}
        offset += len(cols)
    columns = [[dev, c] for dev, c in prog.ext_columns]
    columns += [[dev, "force"] for dev, _ in prog.device_records]
    return {
        "format": "hapticgraph take", "version": VERSION,
        "patch": {"name": patch.name, "file": os.path.basename(patch.file), "fingerprint": fingerprint(sig),
                  "signature": sig},
        "rate": float(patch.rate), "columns": columns, "inputs": len(prog.ext_columns),
        "forces": [dev for dev, _ in prog.device_records], "drivers": drivers,
        "audio": {"channels": int(channels)}, "blocksize": int(blocksize),
        "started": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    }


# -- writing -------------------------------------------------------------------------------------
class FloatWav:
    """An incrementally written 32-bit IEEE-float WAV whose header is rewritten at every flush."""

    def __init__(self, path, rate, channels):
        self.path, self.rate, self.channels = path, int(round(rate)), int(channels)
        self.frames = 0
        self.f = open(path, "wb")
        self._header()

    def _header(self):
        ch, rate = self.channels, self.rate
        data = self.frames * 4 * ch
        fmt = struct.pack("<HHIIHHH", 3, ch, rate, rate * 4 * ch, 4 * ch, 32, 0)
        head = (b"RIFF" + struct.pack("<I", 4 + (8 + len(fmt)) + 12 + 8 + data) + b"WAVE"
                + b"fmt " + struct.pack("<I", len(fmt)) + fmt
                + b"fact" + struct.pack("<II", 4, self.frames)
                + b"data" + struct.pack("<I", data))
        self.f.seek(0)
        self.f.write(head)
        self.f.seek(0, os.SEEK_END)

    def write(self, frames):
        frames = np.ascontiguousarray(frames, dtype="<f4")
        self.f.write(frames.tobytes())
        self.frames += frames.shape[0]

    def flush(self):
        self._header()
        self.f.flush()

    def close(self):
        if not self.f.closed:
            self.flush()
            self.f.close()


def write_take_header(f, header):
    body = json.dumps(header, indent=1).encode("utf-8")
    start = len(MAGIC) + 2 + 8
    body += b" " * ((-(start + len(body))) % 8)
    f.write(MAGIC + struct.pack("<H", VERSION) + struct.pack("<Q", len(body)) + body)


class Recorder:
    """Takes blocks from the audio callback into ring buffers (no allocation, no I/O there) and
    writes them to TAKE.hgrec and TAKE.wav from its own thread."""

    def __init__(self, path, session, channels, blocksize, kinds=None, ring_seconds=4.0, flush_every=0.2):
        self.path, self.wav_path = take_paths(path)
        prog = session.prog
        self.layout = (list(prog.ext_columns), [d for d, _ in prog.device_records])
        self.header = take_header(session, channels, blocksize, kinds)
        self.nin, self.nforce = len(prog.ext_columns), len(prog.device_records)
        size = 1 << max(12, int(np.ceil(np.log2(max(1.0, ring_seconds * prog.rate)))))
        self.size, self.mask = size, size - 1
        self.rows = np.zeros((size, self.nin + self.nforce))
        self.audio = np.zeros((size, channels), dtype=np.float32)
        self.rw = self.rr = 0          # rows written by the callback / read by the writer
        self.aw = self.ar = 0
        self.dropped = 0
        self.inputs_stopped = None     # a reload changed the devices: inputs no longer recorded
        self.rows_written = 0
        self.flush_every = flush_every
        self.f = open(self.path, "wb")
        write_take_header(self.f, self.header)
        self.f.flush()
        self.wav = FloatWav(self.wav_path, prog.rate, channels)
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self.thread = threading.Thread(target=self._loop, name="hapticgraph-recorder", daemon=True)
        self.thread.start()

    # called from the audio callback ---------------------------------------------------------
    def _ring(self, ring, w, src, col0=0):
        n = src.shape[0]
        i = w & self.mask
        k = min(n, self.size - i)
        c1 = col0 + src.shape[1]
        np.copyto(ring[i:i + k, col0:c1], src[:k], casting="same_kind")
        if k < n:
            np.copyto(ring[:n - k, col0:c1], src[k:], casting="same_kind")

    def push_inputs(self, ext, force):
        """A processed block: its device inputs (n × inputs) and forces (n × devices, or None: zero)."""
        if self.inputs_stopped:
            return
        n = ext.shape[0]
        if self.rw + n - self.rr > self.size:
            self.dropped += n
            return
        if self.nin:
            self._ring(self.rows, self.rw, ext)
        if self.nforce:
            if force is None:
                i = self.rw & self.mask
                k = min(n, self.size - i)
                self.rows[i:i + k, self.nin:] = 0.0
                self.rows[:n - k, self.nin:] = 0.0
            else:
                self._ring(self.rows, self.rw, force, self.nin)
        self.rw += n

    def push_audio(self, audio):
        n = audio.shape[0]
        if self.aw + n - self.ar > self.size:
            self.dropped += n
            return
        self._ring(self.audio, self.aw, audio)
        self.aw += n

    def session_changed(self, session):
        """A reload swapped the session: keep recording inputs only if the layout is the same."""
        prog = session.prog
        if (list(prog.ext_columns), [d for d, _ in prog.device_records]) != self.layout:
            self.inputs_stopped = "a reload changed the patch's devices or inputs"

    # the writer thread ----------------------------------------------------------------------
    def _drain(self):
        with self._lock:
            for ring, attr_w, attr_r, out in ((self.rows, "rw", "rr", self.f), (self.audio, "aw", "ar", self.wav)):
                w, r = getattr(self, attr_w), getattr(self, attr_r)
                while r < w:
                    i = r & self.mask
                    k = min(w - r, self.size - i)
                    chunk = ring[i:i + k]
                    if out is self.f:
                        out.write(np.ascontiguousarray(chunk, dtype="<f8").tobytes())
                        self.rows_written += k
                    else:
                        out.write(chunk)
                    r += k
                setattr(self, attr_r, r)
            self.f.flush()
            self.wav.flush()

    def _loop(self):
        while not self._stop.wait(self.flush_every):
            self._drain()

    def close(self):
        """Write everything taken so far and close both files (complete files)."""
        self._stop.set()
        if self.thread.is_alive() and self.thread is not threading.current_thread():
            self.thread.join(5.0)
        self._drain()
        self.f.close()
        self.wav.close()

    @property
    def frames(self):
        return self.wav.frames


# -- reading and replaying -----------------------------------------------------------------------
class Take:
    """A recorded take: `header`, `inputs` (samples × input columns), `forces`, `rate`."""

    def __init__(self, path):
        self.path = os.fspath(path)
        try:
            with open(self.path, "rb") as f:
                head = f.read(len(MAGIC) + 10)
                if len(head) < len(MAGIC) + 10 or head[:len(MAGIC)] != MAGIC:
                    raise TakeError(f"{self.path}: not a hapticgraph take (.hgrec) file")
                version = struct.unpack("<H", head[len(MAGIC):len(MAGIC) + 2])[0]
                if version != VERSION:
                    raise TakeError(f"{self.path}: take format version {version}; this hapticgraph reads {VERSION}")
                length = struct.unpack("<Q", head[len(MAGIC) + 2:])[0]
                if length > 16 << 20:
                    raise TakeError(f"{self.path}: corrupt header")
                self.header = json.loads(f.read(length).decode("utf-8"))
                offset = len(MAGIC) + 10 + length
        except OSError as exc:
            raise TakeError(f"cannot read take {self.path}: {exc.strerror or exc}") from None
        except (ValueError, UnicodeDecodeError) as exc:
            raise TakeError(f"{self.path}: corrupt header: {exc}") from None
        h = self.header
        ncol = len(h["columns"])
        data = np.fromfile(self.path, dtype="<f8", offset=offset)
        rows = data.size // ncol if ncol else 0
        self.data = data[:rows * ncol].reshape(rows, ncol) if ncol else np.zeros((0, 0))
        self.rate = float(h["rate"])
        self.inputs = self.data[:, :h["inputs"]]
        self.forces = self.data[:, h["inputs"]:]
        self.frames = rows

    @property
    def seconds(self):
        return self.frames / self.rate

    def force_of(self, device):
        return self.forces[:, self.header["forces"].index(device)]

    def driver(self, name):
        info = self.header["drivers"].get(name)
        if info is None:
            have = ", ".join(sorted(self.header["drivers"])) or "none"
            raise TakeError(f"{self.path} has no device or input named {name!r} (it has: {have})")
        return ReplayDriver(name, self, info)

    def check(self, patch):
        """Raise TakeError unless this take was recorded from (a version of) this patch."""
        mine = patch_signature(patch)
        theirs = self.header["patch"]["signature"]
        if fingerprint(mine) != self.header["patch"]["fingerprint"] or mine != theirs:
            p = self.header["patch"]
            raise TakeError(f"{os.path.basename(self.path)} was recorded from another patch: {p['name']!r} "
                            f"({p['file']}: {_describe(theirs)}); {os.path.basename(patch.file)} has "
                            f"{_describe(mine)}")


class ReplayDriver(Driver):
    """Feeds one device (or audio input) of a patch from a take, sample for sample; past the
    end a device holds its last values and an audio input is silent. It offers the block type
    and internal values the device had when recorded, so the kernel is the one that played."""

    def __init__(self, name, take, info):
        self.name, self.take = name, take
        self.columns = tuple(info["columns"])
        self.block_type = _import_type(info.get("block_type"))
        self.values = dict(info.get("block_values") or {})
        off = int(info["offset"])
        self.signal = np.ascontiguousarray(take.inputs[:, off:off + len(self.columns)])
        self.hold = not info.get("input", False)
        self.sent = []

    def block_values(self):
        return dict(self.values)

    def start(self, rate):
        if float(rate) != self.take.rate:
            raise TakeError(f"{os.path.basename(self.take.path)} was recorded at {self.take.rate:g} Hz, "
                            f"the patch runs at {float(rate):g} Hz")
        self.sent = []

    def fill(self, t0, ext):
        n, total = ext.shape[0], self.signal.shape[0]
        k = max(0, min(n, total - t0))
        if k:
            ext[:k] = self.signal[t0:t0 + k]
        if k < n:
            ext[k:] = self.signal[-1] if (self.hold and total) else 0.0

    def send(self, t0, force):
        self.sent.append(np.array(force, dtype=np.float64))

    def force_sent(self):
        return np.concatenate(self.sent) if self.sent else np.zeros(0)


def ReplayDevice(name, spec):
    """`driver: replay` in a device entry: `{driver: replay, file: TAKE.hgrec}` (the file is
    relative to the patch); feeds that device from the take."""
    path = spec.get("file")
    if not path:
        raise TakeError(f"device {name!r}: driver replay needs a take: give the entry `file: TAKE.hgrec`, "
                        "or replay a whole take with `hapticgraph run PATCH --replay TAKE.hgrec`")
    return Take(path).driver(name)


def replay_drivers(patch, path):
    """Drivers for every device and audio input of `patch` from the take at `path` (checked)."""
    take = Take(path)
    take.check(patch)
    return take, {name: take.driver(name) for name in take.header["drivers"]} | {
        name: _Idle(name) for name in patch.devices if name not in take.header["drivers"]}


class _Idle(Driver):
    """A declared device no block used when the take was made (it supplied no columns)."""

    def __init__(self, name):
        self.name = name


def _main(argv=None):   # pragma: no cover - a debugging aid: python -m hapticgraph.devices.record TAKE
    take = Take((argv or sys.argv[1:])[0])
    print(json.dumps(take.header, indent=1))
    print(f"{take.frames} samples ({take.seconds:.3f} s)")


if __name__ == "__main__":  # pragma: no cover
    _main()
