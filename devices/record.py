"""Recording a performance (`hapticgraph play --record TAKE`); the take is replayed offline with
`hapticgraph run PATCH --replay TAKE` or a device entry `{driver: replay, file: TAKE.hgrec}`.

A take is two files with one stem: `TAKE.hgrec`, the device inputs and forces (its format and
reader: hapticgraph.devices.take; replaying: hapticgraph.devices.replay), and `TAKE.wav`, the
audio sent to the sound card, 32-bit float; its header (RIFF, fact and data sizes) is rewritten
at every flush (every 0.2 s) and on close, so it is a valid file at every stop.

Both files are appended whole rows (frames) at a time; when the disk is full (or a file size
limit is reached) that file is cut back to its last whole row, the WAV header is rewritten to
match, its recording stops with a message (`play` then exits with status 1) and the music goes
on: what was written stays readable.

While playing, the audio callback only copies each block into preallocated ring buffers; a
writer thread appends them to the files.
"""
import datetime
import errno
import os
import struct
import sys
import threading

import numpy as np

# ReplayDevice, replay_drivers, MAGIC, PREAMBLE, Take, header_bytes: re-exported (tests, benchmarks and
# the driver kinds import them from here)
from .recordable import Recordable
from .replay import ReplayDevice, replay_drivers
from .take import (
    FORCE_COLUMN,
    MAGIC,
    MODELS,
    PREAMBLE,
    VERSION,
    Take,
    TakeError,
    fingerprint,
    header_bytes,
    patch_signature,
    take_paths,
)


def _model_of(driver):
    """The name a take gives the model a driver substitutes (None: the patch's own block): its
    `take_type` when the model it runs is not the one that replays its columns."""
    cls = driver.take_type if isinstance(driver, Recordable) else driver.block_type
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


def take_header(prog, channels, blocksize, kinds=None):
    """The JSON header of a take of a running patch (its Program `prog`: ext columns and forces)."""
    patch = prog.patch
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
                           "block_values": _jsonable(d.take_values() if isinstance(d, Recordable)
                                                     else d.block_values()),
                           "input": device in sig["inputs"]}
        bound = getattr(d, "max_force", None)      # a device's force bound (serial, HID): data, for replay
        if isinstance(bound, (int, float)) and 0 < bound < float("inf") and _model_of(d) is None:
            drivers[device]["max_force"] = float(bound)
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


def _want_columns(prog):
    """Tell the drivers whose inputs the kernel computes itself (a simulated hand's script) to
    fill their columns too, for the take."""
    for d in prog.drivers.values():
        if isinstance(d, Recordable):
            d.recording = True


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



class Recorder:
    """Takes blocks from the audio callback into ring buffers (no allocation, no I/O there) and
    writes them to TAKE.hgrec and TAKE.wav from its own thread."""

    def __init__(self, path, prog, channels, blocksize, kinds=None, ring_seconds=4.0, flush_every=0.2,
                 stream=None):
        self.path, self.wav_path = take_paths(path)
        self.layout = (list(prog.ext_columns), [d for d, _ in prog.device_records])
        self.header = take_header(prog, channels, blocksize, kinds)
        _want_columns(prog)
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

    def session_changed(self, prog):
        """A reload swapped in another patch (its Program `prog`): keep recording inputs only if
        the layout is the same."""
        if (list(prog.ext_columns), [d for d, _ in prog.device_records]) != self.layout:
            self.inputs_stopped = "a reload changed the patch's devices or inputs"
        else:
            _want_columns(prog)

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


__all__ = ["MAGIC", "PREAMBLE", "DiskFull", "FloatWav", "Recorder", "ReplayDevice", "Take", "TakeError",
           "fingerprint", "header_bytes", "patch_signature", "replay_drivers", "take_header", "take_paths"]
