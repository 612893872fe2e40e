"""The take file format (`TAKE.hgrec`, made by `hapticgraph play --record TAKE`) and its reader.

`TAKE.hgrec` holds every device input the drivers supplied to the kernel, sample by sample (the
`ext` columns of each driver: a simulated hand's trajectory, a HID device's axes and buttons, a
live audio input's samples), followed by the force the patch sent to each device (zero in a
block stopped for safety). Layout: 8 bytes `HGREC\\0` + format version (uint16 LE), the header
length (uint64 LE), a JSON header (UTF-8, padded with spaces to a multiple of 8 bytes), then
float64 little-endian rows, one per sample, of `len(header["columns"])` values. The header never
changes after it is written — the number of rows is (file size − data offset) / row size — so
the file is complete at every moment (stray bytes after the last whole row, as a writer killed
mid-row may leave, are refused with the `truncate` that keeps the whole rows).

The header names the patch by a fingerprint of what a take has to match: the rate, the device
names with their axes, and the audio_in blocks. A take from another patch is refused before
anything starts (exit status 2); a take from the same patch with changed parameters re-renders
the same gestures through the changed instrument. Each driver's entry keeps what makes the kernel
identical on replay: its columns, the device model it substitutes for the patch's block, named
as data (`"model"`: the name of the driver kind that simulates the device, or null; looked up in
the fixed table MODELS — a take never names a module, and reading one imports nothing) and that
model's internal values (mass, grip, max_force), each checked against the model's declared range.
A device with no model (serial, HID) keeps the bound its driver clamped every force to as
`"max_force"` (newtons), so a replay's forces are the ones the device received.

Reading a take checks everything before anything runs: the magic and version, a header length
within MAX_HEADER bytes and the file, JSON (no NaN), the header against HEADER_SCHEMA, columns
that add up (inputs, forces, each driver's slice), a data part that is a whole number of rows,
and finite data. Every problem is one TakeError line naming the file (exit status 2).
Replaying (hapticgraph.devices.replay) always checks the take against the patch: `--replay` the
whole signature, a device entry `driver: replay` the rate and that device's axes.
"""
import hashlib
import json
import os
import stat
import struct
import sys

import jsonschema
import numpy as np

from ..graph.entries import device_axes
from .errors import DeviceError
from .table import driver_kinds, input_kind, kinds_of

MAGIC = b"HGREC\x00"
VERSION = 1
SUFFIX = ".hgrec"
PREAMBLE = len(MAGIC) + 2 + 8     # magic, version (uint16), header length (uint64)
MAX_HEADER = 1 << 20              # bytes of JSON header a take may have
MAX_COLUMNS = 4096

# The device models a take may name, as data: "model" in a driver's entry -> the block type, as
# the driver kinds that simulate their device declare it, with the columns each model reads first.
MODELS = {kind.name: kind.model for kind in driver_kinds().values() if kind.model is not None}
MODEL_COLUMNS = {kind.name: tuple(kind.model_columns) for kind in driver_kinds().values() if kind.model is not None}
# Takes written before the model was named as data held a `module:qualname`; only these known
# strings are understood (looked up, never imported).
LEGACY_TYPES = {"hapticgraph.devices.simulated:SimulatedHaptic": "simulated"}
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
                                       "input": {"type": "boolean"},
                                       "max_force": {"type": "number", "exclusiveMinimum": 0}}}},
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


def take_paths(path):
    """(TAKE.hgrec, TAKE.wav) for `--record TAKE`, `TAKE.hgrec` or `TAKE.wav`."""
    stem, ext = os.path.splitext(os.fspath(path))
    if ext.lower() not in (SUFFIX, ".wav"):
        stem = os.fspath(path)
    return stem + SUFFIX, stem + ".wav"


def header_bytes(header):
    """The preamble and JSON header of a take, padded so the rows start at a multiple of 8."""
    body = json.dumps(header, indent=1, allow_nan=False).encode("utf-8")
    body += b" " * ((-(PREAMBLE + len(body))) % 8)
    return MAGIC + struct.pack("<H", VERSION) + struct.pack("<Q", len(body)) + body


# -- reading ---------------------------------------------------------------------------------------
def _no_constant(name):
    raise ValueError(f"{name} is not a number a take may hold")


class Take:
    """A recorded take: `header`, `inputs` (samples × input columns), `forces`, `rate`.
    Everything is checked on reading (see the module's doc); a problem raises TakeError."""

    def __init__(self, path):
        self.path = os.fspath(path)
        self.name = os.path.basename(self.path)
        offset, size = self._read_header()
        h = self.header
        self._check_header(h)
        rows = self._count_rows(len(h["columns"]), offset, size)
        self.data = self._read_rows(len(h["columns"]), offset, rows)
        self.rate = float(h["rate"])
        self.inputs = self.data[:, :h["inputs"]]
        self.forces = self.data[:, h["inputs"]:]
        self.frames = rows

    def _read_header(self):
        """Read the preamble and the JSON header into `header`; (offset of the rows, file size)."""
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
                self.header = json.loads(text.decode("utf-8"), parse_constant=_no_constant)
                return PREAMBLE + length, st.st_size
        except OSError as exc:
            raise TakeError(f"cannot read take {self.path}: {exc.strerror or exc}") from None
        except (ValueError, UnicodeDecodeError, RecursionError) as exc:
            raise self._bad(f"its header is not valid JSON: {str(exc)[:200]}") from None

    def _count_rows(self, ncol, offset, size):
        """The whole rows after the header; stray bytes (a writer stopped mid-row) are refused."""
        rowbytes = 8 * ncol
        extra = size - offset
        if ncol == 0:
            if extra:
                raise self._bad(f"{extra} bytes of data but no columns")
            return 0
        rows, stray = divmod(extra, rowbytes)
        if stray:
            raise self._bad(f"its data is {rows} rows of {rowbytes} bytes and {stray} bytes more (a writer "
                            f"stopped mid-row?); `truncate -s {offset + rows * rowbytes} {self.path}` keeps "
                            f"the {rows} whole rows")
        return rows

    def _read_rows(self, ncol, offset, rows):
        """The rows × ncol data, every value a finite number."""
        try:
            data = np.fromfile(self.path, dtype="<f8", offset=offset, count=rows * ncol) if rows else np.zeros(0)
        except (OSError, ValueError, MemoryError) as exc:
            raise TakeError(f"cannot read take {self.path}: {exc}") from None
        if data.size != rows * ncol:
            raise self._bad("the file changed while it was read")
        data = data.reshape(rows, ncol) if ncol else np.zeros((0, 0))
        bad = ~np.isfinite(data)
        if bad.any():
            r, c = np.argwhere(bad)[0]
            raise self._bad(f"sample {r}, column {'.'.join(self.header['columns'][c])} is {data[r, c]} "
                            f"({int(bad.sum())} values are not finite numbers)")
        return data

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

    def driver_info(self, name):
        """What the take's header says of device (or input) `name`: its columns, model, values;
        TakeError if it has none of that name. (hapticgraph.devices.replay feeds it.)"""
        info = self.header["drivers"].get(name)
        if info is None:
            have = ", ".join(sorted(self.header["drivers"])) or "none"
            raise TakeError(f"{self.path} has no device or input named {name!r} (it has: {have})")
        return info

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


__all__ = ["FORCE_COLUMN", "HEADER_SCHEMA", "MAGIC", "MAX_COLUMNS", "MAX_HEADER", "MODELS", "PREAMBLE", "SUFFIX",
           "VERSION", "Take", "TakeError", "fingerprint", "header_bytes", "patch_signature", "take_paths"]


def _main(argv=None):   # pragma: no cover - a debugging aid: python -m hapticgraph.devices.take TAKE
    take = Take((argv or sys.argv[1:])[0])
    print(json.dumps(take.header, indent=1))
    print(f"{take.frames} samples ({take.seconds:.3f} s)")


if __name__ == "__main__":  # pragma: no cover
    _main()
