"""Recording a performance (`hapticgraph play --record TAKE`) and replaying it offline
(`hapticgraph run PATCH --replay TAKE`, or a device entry `{driver: replay, file: TAKE.hgrec}`).

A take is two files with one stem:

- `TAKE.hgrec`: every device input the drivers supplied to the kernel, sample by sample (the
  `ext` columns of each driver: a simulated hand's trajectory, a HID device's axes and buttons,
  a live audio input's samples), followed by the force the patch sent to each device (zero in a
  block stopped for safety). Layout: 8 bytes `HGREC\\0` + format version (uint16 LE), the header
  length (uint64 LE), a JSON header (UTF-8, padded with spaces to a multiple of 8 bytes), then
  float64 little-endian rows, one per sample, of `len(header["columns"])` values. The header
  never changes after it is written — the number of rows is (file size − data offset) / row
  size — so the file is complete at every moment (stray bytes after the last whole row, as a
  writer killed mid-row may leave, are refused with the `truncate` that keeps the whole rows).
- `TAKE.wav`: the audio sent to the sound card, 32-bit float; its header (RIFF, fact and data
  sizes) is rewritten at every flush (every 0.2 s) and on close, so it is a valid file at every
  stop.

Both files are appended whole rows (frames) at a time; when the disk is full (or a file size
limit is reached) that file is cut back to its last whole row, the WAV header is rewritten to
match, its recording stops with a message (`play` then exits with status 1) and the music goes
on: what was written stays readable.

The header names the patch by a fingerprint of what a take has to match: the rate, the device
names with their axes, and the audio_in blocks. A take from another patch is refused before
anything starts (exit status 2); a take from the same patch with changed parameters re-renders
the same gestures through the changed instrument. Each driver's entry keeps what makes the kernel
identical on replay: its columns, the device model it substitutes for the patch's block, named
as data (`"model"`: the name of the driver kind that simulates the device, or null; looked up in
the fixed table MODELS — a take never
names a module, and reading one imports nothing) and that model's internal values (mass, grip,
max_force), each checked against the model's declared range.

Reading a take checks everything before anything runs: the magic and version, a header length
within MAX_HEADER bytes and the file, JSON (no NaN), the header against HEADER_SCHEMA, columns
that add up (inputs, forces, each driver's slice), a data part that is a whole number of rows,
and finite data. Every problem is one TakeError line naming the file (exit status 2).
Replaying always checks the take against the patch: `--replay` the whole signature, a device
entry `driver: replay` the rate and that device's axes.

While playing, the audio callback only copies each block into preallocated ring buffers; a
writer thread appends them to the files.
"""
import datetime
import errno
import hashlib
import json
import math
import os
import stat
import struct
import sys
import threading

import jsonschema
import numpy as np

from ..graph.engine import Driver
from ..graph.patch import device_axes
from . import DeviceError
from .kinds import KINDS, SimulatedKind, input_kind, kinds_of

MAGIC = b"HGREC\x00"
VERSION = 1
SUFFIX = ".hgrec"
PREAMBLE = len(MAGIC) + 2 + 8     # magic, version (uint16), header length (uint64)
MAX_HEADER = 1 << 20              # bytes of JSON header a take may have
MAX_COLUMNS = 4096

# The device models a take may name, as data: "model" in a driver's entry -> the block type, as
# the driver kinds that simulate their device declare it, with the columns each model reads first.
MODELS = {kind.name: kind.model for kind in KINDS if kind.model is not None}
MODEL_COLUMNS = {kind.name: tuple(kind.model_columns) for kind in KINDS if kind.model is not None}
# Takes written before the model was named as data held a `module:qualname`; only these known
# strings are understood (looked up, never imported).
LEGACY_TYPES = {"hapticgraph.devices.simulated:SimulatedHaptic": SimulatedKind.name}
FORCE_COLUMN = "force"     # a take's label of the force column of each device (format version 1)

_NAMES = {"type": "array", "maxItems": MAX_COLUMNS, "items": {"type": "string", "maxLength": 256}}
HEADER_SCHEMA = {
    "type": "object",
    "required": ["version", "patch", "rate", "columns", "inputs", "forces", "drivers"],
    "properties": {
        "version": {"const": VERSION},
        "rate": {"type": "number", "minimum": 100, "maximum": 1_000_000},
        "inputs": {"type": "integer", "minimum": 0, "maximum": MAX_COLUMNS},
        "columns": {"type": "array", "maxItems": MAX_COLUMNS,
                    "items": {"type": "array", "minItems": 2, "maxItems": 2,
                              "items": {"type": "string", "maxLength": 256}}},
        "forces": _NAMES,
        "patch": {"type": "object", "required": ["fingerprint", "signature"],
                  "properties": {
                      "name": {"type": "string"}, "file": {"type": "string"},
                      "fingerprint": {"type": "string"},
                      "signature": {"type": "object", "required": ["rate", "devices", "inputs"],
                                    "properties": {"rate": {"type": "number"},
                                                   "devices": {"type": "object", "additionalProperties": _NAMES},
                                                   "inputs": _NAMES}}}},
        "drivers": {"type": "object", "maxProperties": MAX_COLUMNS,
                    "additionalProperties": {
                        "type": "object", "required": ["columns", "offset"],
                        "properties": {"kind": {"type": "string"},
                                       "model": {"enum": [None, *MODELS]},
                                       "block_type": {"type": ["string", "null"]},
                                       "columns": _NAMES,
                                       "offset": {"type": "integer", "minimum": 0, "maximum": MAX_COLUMNS},
                                       "block_values": {"type": "object",
                                                        "additionalProperties": {"type": "number"}},
                                       "input": {"type": "boolean"}}}},
        "audio": {"type": "object"},
        "blocksize": {"type": "integer"},
    },
}


class TakeError(DeviceError):
    """A take that cannot be read, or that does not belong to the patch."""


# -- the patch a take belongs to ------------------------------------------------------------------
def patch_signature(patch):
    """What a take must match: the rate, each device's name and axes, the blocks fed from
    outside (audio_in)."""
    kinds = kinds_of(patch)
    return {
        "rate": float(patch.rate),
        "devices": {name: list(device_axes(patch.devices, name, kinds)) for name in sorted(patch.devices)},
        "inputs": sorted(inst.name for inst in patch.blocks.values() if input_kind(inst.cls) is not None),
    }


def fingerprint(signature):
    return hashlib.sha256(json.dumps(signature, sort_keys=True).encode()).hexdigest()[:16]


def _describe(sig):
    devs = ", ".join(f"{n}({', '.join(['x', 'v'] + a)})" for n, a in sig["devices"].items()) or "none"
    ins = ", ".join(sig["inputs"]) or "none"
    return f"{sig['rate']:g} Hz, devices {devs}, audio inputs {ins}"


def _model_of(driver):
    """The name a take gives the model a driver substitutes (None: the patch's own block)."""
    cls = driver.block_type
    if cls is None:
        return None
    for name, model in MODELS.items():
        if cls is model:
            return name
    raise TakeError(f"device {driver.name!r}: its model {cls.__name__} cannot be recorded "
                    f"(a take names one of: {', '.join(MODELS)})")


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
                           "offset": offset, "model": _model_of(d),
                           "block_values": _jsonable(d.block_values()),
                           "input": device in sig["inputs"]}
        offset += len(cols)
    columns = [[dev, c] for dev, c in prog.ext_columns]
    columns += [[dev, FORCE_COLUMN] for dev, _ in prog.device_records]
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
class DiskFull(OSError):
    """A write that did not fit: the file was cut back to its last whole row (frame)."""


class _Appender:
    """An unbuffered file appended in whole units (rows, frames) after a head: a write that fails
    part-way (a full disk, a file size limit) cuts the file back to its last whole unit and
    raises DiskFull, so the file stays readable."""

    def __init__(self, path, head, unit):
        self.path, self.unit, self.head = path, unit, len(head)
        self.size = 0
        self.f = open(path, "wb", buffering=0)
        try:
            self._append(head, 1)
        except DiskFull:
            self.f.close()
            raise

    def _append(self, data, unit):
        view, done = memoryview(data), 0
        try:
            while done < len(view):
                n = self.f.write(view[done:])
                if not n:
                    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
                done += n
        except OSError as exc:
            self.size += done - done % unit
            try:
                os.ftruncate(self.f.fileno(), self.size)
                self.f.seek(self.size)
            except OSError:
                pass
            raise DiskFull(exc.errno, f"{os.path.basename(self.path)}: {exc.strerror or exc}") from None
        self.size += done
        return done

    def write(self, data):
        """Append whole units; returns how many."""
        return self._append(data, self.unit) // self.unit

    @property
    def units(self):
        return (self.size - self.head) // self.unit

    def put_head(self, head):
        os.pwrite(self.f.fileno(), head, 0)      # inside the file: never grows it

    def close(self):
        if not self.f.closed:
            self.f.close()


class FloatWav:
    """An incrementally written 32-bit IEEE-float WAV whose header is rewritten at every flush;
    a failing write keeps the whole frames written and a header that matches them."""

    def __init__(self, path, rate, channels):
        self.path, self.rate, self.channels = path, int(round(rate)), int(channels)
        self.frames = 0
        self.out = _Appender(path, self._head(), 4 * self.channels)

    def _head(self):
        ch, rate = self.channels, self.rate
        data = self.frames * 4 * ch
        fmt = struct.pack("<HHIIHHH", 3, ch, rate, rate * 4 * ch, 4 * ch, 32, 0)
        return (b"RIFF" + struct.pack("<I", 4 + (8 + len(fmt)) + 12 + 8 + data) + b"WAVE"
                + b"fmt " + struct.pack("<I", len(fmt)) + fmt
                + b"fact" + struct.pack("<II", 4, self.frames)
                + b"data" + struct.pack("<I", data))

    def write(self, frames):
        frames = np.ascontiguousarray(frames, dtype="<f4")
        try:
            self.out.write(frames.tobytes())
        finally:
            self.frames = self.out.units

    def flush(self):
        self.out.put_head(self._head())

    def close(self):
        if not self.out.f.closed:
            self.flush()
            self.out.close()


def header_bytes(header):
    """The preamble and JSON header of a take, padded so the rows start at a multiple of 8."""
    body = json.dumps(header, indent=1, allow_nan=False).encode("utf-8")
    body += b" " * ((-(PREAMBLE + len(body))) % 8)
    return MAGIC + struct.pack("<H", VERSION) + struct.pack("<Q", len(body)) + body


class Recorder:
    """Takes blocks from the audio callback into ring buffers (no allocation, no I/O there) and
    writes them to TAKE.hgrec and TAKE.wav from its own thread."""

    def __init__(self, path, session, channels, blocksize, kinds=None, ring_seconds=4.0, flush_every=0.2,
                 stream=None):
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
        self.failed = None             # why recording stopped early (a full disk), else None
        self.stopped = set()           # the files that stopped (each keeps what it holds)
        self.stream = stream if stream is not None else sys.stderr
        self.f = _Appender(self.path, header_bytes(self.header), 8 * max(1, self.nin + self.nforce))
        try:
            self.wav = FloatWav(self.wav_path, prog.rate, channels)
        except OSError:
            self.f.close()
            raise
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
                try:
                    while r < w and out not in self.stopped:
                        i = r & self.mask
                        k = min(w - r, self.size - i)
                        chunk = ring[i:i + k]
                        if out is self.f:
                            try:
                                out.write(np.ascontiguousarray(chunk, dtype="<f8").tobytes())
                            finally:
                                self.rows_written = out.units if chunk.shape[1] else r + k
                        else:
                            out.write(chunk)
                        r += k
                    if out is self.wav and out not in self.stopped:
                        out.flush()
                except OSError as exc:
                    self._fail(out, exc)
                setattr(self, attr_r, w)

    def _fail(self, out, exc):
        """A file did not fit (a full disk): keep its whole rows (frames), stop writing it, play on."""
        self.stopped.add(out)
        why = f"{exc.strerror or exc}" if isinstance(exc, DiskFull) else f"{out.path}: {exc}"
        self.failed = self.failed or why
        if out is self.wav:
            try:
                self.wav.flush()
            except OSError:
                pass
            kept = f"{self.wav.frames} frames of audio"
        else:
            kept = f"{self.rows_written} samples of device inputs"
        print(f"hapticgraph: recording stopped: {why}; the file keeps the {kept} written before; still playing",
              file=self.stream)

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
        try:
            self.wav.close()
        except OSError as exc:
            self.failed = self.failed or f"{self.wav_path}: {exc.strerror or exc}"

    @property
    def frames(self):
        return self.wav.frames


# -- reading and replaying -----------------------------------------------------------------------
def _no_constant(name):
    raise ValueError(f"{name} is not a number a take may hold")


class Take:
    """A recorded take: `header`, `inputs` (samples × input columns), `forces`, `rate`.
    Everything is checked on reading (see the module's doc); a problem raises TakeError."""

    def __init__(self, path):
        self.path = os.fspath(path)
        self.name = os.path.basename(self.path)
        try:
            if not stat.S_ISREG(os.stat(self.path).st_mode):     # a FIFO would block the open
                raise TakeError(f"{self.path}: not a take: not a regular file")
            with open(self.path, "rb") as f:
                st = os.fstat(f.fileno())
                head = f.read(PREAMBLE)
                if len(head) < PREAMBLE or head[:len(MAGIC)] != MAGIC:
                    raise TakeError(f"{self.path}: not a hapticgraph take (.hgrec) file")
                version = struct.unpack("<H", head[len(MAGIC):len(MAGIC) + 2])[0]
                if version != VERSION:
                    raise TakeError(f"{self.path}: take format version {version}; this hapticgraph reads {VERSION}")
                length = struct.unpack("<Q", head[len(MAGIC) + 2:])[0]
                if length > st.st_size - PREAMBLE:
                    raise self._bad(f"its header says {length} bytes but the file holds only "
                                    f"{st.st_size - PREAMBLE} after the preamble (truncated?)")
                if length > MAX_HEADER:
                    raise self._bad(f"a header of {length} bytes (at most {MAX_HEADER})")
                text = f.read(length)
                offset = PREAMBLE + length
                size = st.st_size
                self.header = json.loads(text.decode("utf-8"), parse_constant=_no_constant)
        except OSError as exc:
            raise TakeError(f"cannot read take {self.path}: {exc.strerror or exc}") from None
        except (ValueError, UnicodeDecodeError, RecursionError) as exc:
            raise self._bad(f"its header is not valid JSON: {str(exc)[:200]}") from None
        h = self.header
        self._check_header(h)
        ncol = len(h["columns"])
        rowbytes = 8 * ncol
        extra = size - offset
        if ncol == 0:
            if extra:
                raise self._bad(f"{extra} bytes of data but no columns")
            rows = 0
        else:
            rows, stray = divmod(extra, rowbytes)
            if stray:
                raise self._bad(f"its data is {rows} rows of {rowbytes} bytes and {stray} bytes more (a writer "
                                f"stopped mid-row?); `truncate -s {offset + rows * rowbytes} {self.path}` keeps "
                                f"the {rows} whole rows")
        try:
            data = np.fromfile(self.path, dtype="<f8", offset=offset, count=rows * ncol) if rows else np.zeros(0)
        except (OSError, ValueError, MemoryError) as exc:
            raise TakeError(f"cannot read take {self.path}: {exc}") from None
        if data.size != rows * ncol:
            raise self._bad("the file changed while it was read")
        self.data = data.reshape(rows, ncol) if ncol else np.zeros((0, 0))
        bad = ~np.isfinite(self.data)
        if bad.any():
            r, c = np.argwhere(bad)[0]
            raise self._bad(f"sample {r}, column {'.'.join(h['columns'][c])} is {self.data[r, c]} "
                            f"({int(bad.sum())} values are not finite numbers)")
        self.rate = float(h["rate"])
        self.inputs = self.data[:, :h["inputs"]]
        self.forces = self.data[:, h["inputs"]:]
        self.frames = rows

    def _bad(self, why):
        return TakeError(f"{self.path}: not a readable take: {why}")

    def _check_header(self, h):
        try:
            jsonschema.Draft202012Validator(HEADER_SCHEMA).validate(h)
        except jsonschema.ValidationError as exc:
            where = ".".join(str(p) for p in exc.absolute_path) or "the header"
            raise self._bad(f"{where}: {exc.message[:200]}") from None
        if float(h["patch"]["signature"]["rate"]) != float(h["rate"]):
            raise self._bad(f"its rate {h['rate']:g} Hz is not its patch's, {h['patch']['signature']['rate']:g} Hz")
        cols, nin, forces = h["columns"], h["inputs"], h["forces"]
        if len(cols) != nin + len(forces):
            raise self._bad(f"{len(cols)} columns, but {nin} inputs and {len(forces)} forces")
        if cols[nin:] != [[d, FORCE_COLUMN] for d in forces]:
            raise self._bad("the force columns do not match `forces`")
        for name, info in h["drivers"].items():
            off, dcols = info["offset"], info["columns"]
            if off + len(dcols) > nin or cols[off:off + len(dcols)] != [[name, c] for c in dcols]:
                raise self._bad(f"driver {name!r}: its columns do not match columns {off} … "
                                f"{off + len(dcols) - 1} of the take")
            model = self.model_of(name, info)
            values = info.get("block_values") or {}
            cls = MODELS.get(model)
            for key, value in values.items():
                param = cls.params.get(key) if cls is not None else None
                if param is None or not param.internal:
                    allowed = ", ".join(n for n, p in cls.params.items() if p.internal) if cls else "none"
                    raise self._bad(f"driver {name!r}: unknown model value {key!r} (allowed: {allowed})")
                try:
                    jsonschema.validate(value, param.schema())
                except jsonschema.ValidationError as exc:
                    raise self._bad(f"driver {name!r}: {key} {exc.message[:200]}") from None
            if cls is not None:
                needed = list(MODEL_COLUMNS[model])
                if dcols[:len(needed)] != needed:
                    raise self._bad(f"driver {name!r}: model {model} takes columns {', '.join(needed)} first, "
                                    f"the take has {', '.join(dcols) or 'none'}")

    def model_of(self, name, info):
        if "model" in info:
            return info["model"]
        legacy = info.get("block_type")
        if legacy is None:
            return None
        if legacy in LEGACY_TYPES:
            return LEGACY_TYPES[legacy]
        raise self._bad(f"driver {name!r} names the device model {legacy[:80]!r}, which is not one of "
                        f"hapticgraph's ({', '.join(MODELS)}); a take names no code")

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
            raise TakeError(f"{self.name} was recorded from another patch: {p.get('name', '?')!r} "
                            f"({p.get('file', '?')}: {self._describe(theirs)}); {os.path.basename(patch.file)} has "
                            f"{_describe(mine)}")

    def check_device(self, patch, name):
        """Raise TakeError unless device `name` of this take fits device `name` of `patch` (a
        `driver: replay` entry): the same rate and the same axes."""
        mine = patch_signature(patch)
        theirs = self.header["patch"]["signature"]
        if name not in theirs["devices"]:
            have = ", ".join(sorted(theirs["devices"])) or "none"
            raise TakeError(f"{self.name} has no device named {name!r} (it has: {have})")
        if self.rate != mine["rate"]:
            raise TakeError(f"{self.name} was recorded at {self.rate:g} Hz; {os.path.basename(patch.file)} runs "
                            f"at {mine['rate']:g} Hz")
        if list(theirs["devices"][name]) != mine["devices"].get(name):
            raise TakeError(f"device {name!r} of {self.name} has the axes x, v"
                            f"{''.join(', ' + a for a in theirs['devices'][name])}; in "
                            f"{os.path.basename(patch.file)} it has x, v"
                            f"{''.join(', ' + a for a in mine['devices'].get(name, []))}")

    @staticmethod
    def _describe(sig):
        try:
            return _describe(sig)
        except (KeyError, TypeError, ValueError):
            return "an unreadable signature"


class ReplayDriver(Driver):
    """Feeds one device (or audio input) of a patch from a take, sample for sample; past the
    end a device holds its last values and an audio input is silent. It offers the block type
    and internal values the device had when recorded, so the kernel is the one that played."""

    def __init__(self, name, take, info):
        self.name, self.take = name, take
        self.columns = tuple(info["columns"])
        self.block_type = MODELS.get(take.model_of(name, info))
        self.values = dict(info.get("block_values") or {})
        self.max_force = float(self.values.get("max_force", math.inf))   # a HID device's: not in the take
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
        # nothing reaches a hand here, but what is kept is what a device would have received
        force = np.nan_to_num(np.asarray(force, dtype=np.float64), nan=0.0, posinf=0.0, neginf=0.0)
        self.sent.append(np.clip(force, -self.max_force, self.max_force))

    def force_sent(self):
        return np.concatenate(self.sent) if self.sent else np.zeros(0)


def ReplayDevice(name, spec, patch):
    """`driver: replay` in a device entry: `{driver: replay, file: TAKE.hgrec}` (the file is
    relative to the patch); feeds that device from the take, checked against the patch's device."""
    path = spec.get("file")
    if not path:
        raise TakeError(f"device {name!r}: driver replay needs a take: give the entry `file: TAKE.hgrec`, "
                        "or replay a whole take with `hapticgraph run PATCH --replay TAKE.hgrec`")
    take = Take(path)
    take.check_device(patch, name)
    return take.driver(name)


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
