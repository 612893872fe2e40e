"""Files in and out of an offline run, all streamed: a WAV (or FLAC, OGG…) file into an `audio_in`
block, resampled block by block; and the sink of `hapticgraph run`, which writes the audio and an
.npz of probes as the blocks come, so memory stays flat whatever the length."""
import collections
import os
import zipfile
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import soundfile

from ..graph.engine import Driver
from .wav import AudioWriter, beside, put_in_place

IN_MEMORY_FRAMES = 1 << 20     # a shorter input file is read whole (8 MB at most); a longer one streams
MAX_SPAN = 1 << 16             # frames read at once for one piece of a block


class WavInput(Driver):
    """Plays one channel of an audio file into an audio_in block, resampled (linearly) to the patch
    rate as it plays: each block reads only the frames it needs, so a file at 1 Hz costs no more
    than one at the patch's rate. Past the end: silence, or the file again with `loop`."""

    columns = ("sample",)

    def __init__(self, path, channel=0, loop=False):
        self.path, self.channel, self.loop = str(path), int(channel), loop
        name = os.path.basename(self.path)
        try:
            with soundfile.SoundFile(self.path) as f:
                channels, self.frames, self.file_rate = f.channels, f.frames, float(f.samplerate)
                if channels < 1:
                    raise ValueError(f"{name} has no audio channel")
                if self.channel >= channels:
                    raise ValueError(f"{name} has {channels} channel(s); channel {self.channel} asked")
                if self.file_rate <= 0:
                    raise ValueError(f"{name} has a sample rate of {f.samplerate}")
                self.data = None
                if self.frames <= IN_MEMORY_FRAMES:
                    self.data = f.read(dtype="float64", always_2d=True)[:, self.channel].copy()
                    self.frames = len(self.data)
        except (soundfile.SoundFileError, RuntimeError, TypeError) as exc:
            raise ValueError(f"{name} is not a readable audio file: {exc}") from None
        self.rate = self.file_rate
        self.length = self.frames
        self.file = None

    def start(self, rate):
        self.rate = float(rate)
        if self.rate != self.file_rate and self.frames > 1:
            self.length = int(round(self.frames * self.rate / self.file_rate))
        else:
            self.length = self.frames
        if self.data is None and self.file is None:
            self.file = soundfile.SoundFile(self.path)

    def stop(self):
        if self.file is not None:
            self.file.close()
            self.file = None

    def fill(self, t0, ext):
        out = ext[:, 0]
        out[:] = 0.0
        n, length = out.shape[0], self.length
        if not length:
            return
        if self.loop:
            first = 0
            while first < n:            # pieces that do not wrap around the end of the file
                m = (t0 + first) % length
                k = min(n - first, length - m)
                self._segment(m, out[first:first + k])
                first += k
        elif t0 < length:
            self._segment(t0, out[:min(n, length - t0)])

    def _segment(self, m0, out):
        """out[i] = the file at output sample m0 + i (all inside the resampled length)."""
        if self.rate == self.file_rate or self.frames <= 1:
            out[:] = self._frames(m0, m0 + out.shape[0] - 1)
            return
        ratio = self.file_rate / self.rate
        step = max(1, int(MAX_SPAN / ratio))
        for first in range(0, out.shape[0], step):
            m = np.arange(m0 + first, m0 + min(out.shape[0], first + step), dtype=np.float64)
            pos = m * self.file_rate / self.rate           # as np.interp over the whole file would
            lo = min(int(pos[0]), self.frames - 1)
            hi = min(int(pos[-1]) + 1, self.frames - 1)
            out[first:first + m.shape[0]] = np.interp(pos, np.arange(lo, hi + 1, dtype=np.float64),
                                                      self._frames(lo, hi))

    def _frames(self, lo, hi):
        """The channel's frames lo … hi (inclusive)."""
        if self.data is not None:
            return self.data[lo:hi + 1]
        self.file.seek(lo)
        return self.file.read(hi + 1 - lo, dtype="float64", always_2d=True)[:, self.channel]


class ProbeWriter:
    """Probe columns streamed to a temporary file beside the target (each block stored probe after
    probe), assembled by `close()` into an .npz — one .npy per probe and `rate`, as numpy.savez
    writes — a chunk at a time, then renamed into place. Memory stays one block whatever the length."""

    def __init__(self, path, rate, probes):
        self.path, self.rate, self.probes = str(path), float(rate), list(probes)
        self.tmp = beside(self.path, ".raw")
        self.raw = open(self.tmp, "wb")
        self.blocks = []           # (offset, samples) of each block stored whole
        self.samples = self.offset = 0

    def write(self, block):
        data = np.ascontiguousarray(block.T, dtype="<f8")
        self.raw.write(memoryview(data).cast("B"))
        self.raw.flush()
        self.blocks.append((self.offset, block.shape[0]))
        self.offset += data.nbytes
        self.samples += block.shape[0]

    def close(self):
        """Assemble the .npz from every block stored whole and rename it into place."""
        if self.raw is None:
            return self.samples
        self.raw.close()
        self.raw = None
        npz = beside(self.path)
        try:
            with open(self.tmp, "rb") as raw, zipfile.ZipFile(npz, "w", zipfile.ZIP_STORED, allowZip64=True) as zf:
                with zf.open("rate.npy", "w") as entry:
                    np.lib.format.write_array(entry, np.array(self.rate))
                for j, label in enumerate(self.probes):
                    with zf.open(f"{label}.npy", "w", force_zip64=True) as entry:
                        np.lib.format.write_array_header_1_0(
                            entry, {"descr": "<f8", "fortran_order": False, "shape": (self.samples,)})
                        for offset, n in self.blocks:
                            raw.seek(offset + 8 * j * n)
                            entry.write(raw.read(8 * n))
            put_in_place(npz, self.path)
        except BaseException:
            os.unlink(npz)
            raise
        finally:
            os.unlink(self.tmp)
        return self.samples

    def discard(self):
        if self.raw is not None:
            self.raw.close()
            self.raw = None
            os.unlink(self.tmp)


class OutputError(Exception):
    """Writing an output failed (a full disk, a file-size limit…); what was written is kept."""


class FileSink:
    """The sink of `hapticgraph run`: the audio to `audio_path` (format by extension, see
    devices.wav.audio_format) and the probes to an .npz, both opened before rendering so a bad
    path fails before any work, both put in place by `close()` — after a stop or a failure too.

    The files are written by a thread of their own while the kernel computes the next block (the
    kernel releases the GIL, and so do numpy's conversions and libsndfile's writes): a render's
    time is the larger of the two, not their sum. `write` hands over a copy of the block (the
    caller's view is valid only during the call) and waits only when PENDING blocks are still
    unwritten, so memory stays PENDING + 1 blocks. A write that failed is raised (OutputError) by
    the next `write`, or by `drain`; `close` drains first, so every block handed over before a
    stop, a failure or an error is in the files."""

    PENDING = 2

    def __init__(self, audio_path, probes_path, rate, channels, probes, subtype=None, container=None):
        self.channels, self.probe_names = channels, list(probes)
        self.audio = (AudioWriter(audio_path, rate, channels, subtype, container=container)
                      if audio_path and channels else None)
        try:
            self.probes = ProbeWriter(probes_path, rate, probes) if probes_path and probes else None
        except BaseException:
            if self.audio is not None:
                self.audio.discard()
            raise
        self._writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="hapticgraph-writer")
        self._pending = collections.deque()
        self._failure = None          # the first failed write's message (set by the writer thread)
        self._told = False            # raised to the caller as OutputError
        self._buffers, self._turn = [None] * (self.PENDING + 1), 0

    def start(self, rate, channels, probes, total):
        assert channels == self.channels and list(probes) == self.probe_names, "the patch changed"

    def write(self, block):
        while self._pending and (self._pending[0].done() or len(self._pending) >= self.PENDING):
            self._pending.popleft().result()      # a failed write is in _failure; a bug is raised
        self._raise_failure()
        self._pending.append(self._writer.submit(self._write_now, self._copy(block)))

    def _copy(self, block):
        """The block copied into the next of PENDING + 1 buffers kept for the run (all but the one
        filled now may be queued or being written), stored one channel after another: a copy of a
        column slice of the kernel's records that way takes an eighth of numpy's strided copy
        (696 blocks of a Fig. 7 render: 13 against 105 ms), and each writer reads its channels
        whole (the probes' .npz stores them so)."""
        frames, columns = block.shape
        k = self._turn = (self._turn + 1) % (self.PENDING + 1)
        buf = self._buffers[k]
        if buf is None or buf.shape[1] < frames or buf.shape[0] != columns:
            buf = self._buffers[k] = np.empty((columns, frames))
        np.copyto(buf[:, :frames].T, block)
        return buf[:, :frames].T

    def drain(self):
        """Wait until every block handed over is written; OutputError if one could not be."""
        while self._pending:
            self._pending.popleft().result()
        self._raise_failure()

    def _raise_failure(self):
        if self._failure is not None:
            self._told = True
            raise OutputError(self._failure)

    def _write_now(self, block):
        """One block into the files (in the writer thread); a failure's message goes to _failure."""
        if self._failure is not None:
            return                            # nothing after a failed block: the files end before it
        for writer, part in ((self.audio, block[:, :self.channels]), (self.probes, block[:, self.channels:])):
            if writer is None:
                continue
            try:
                writer.write(part)
            except (OSError, RuntimeError, soundfile.SoundFileError) as exc:
                reason = getattr(exc, "strerror", None) or str(exc).strip().rstrip(".")
                self._failure = f"cannot write {writer.path} ({reason}; is the disk full?)"
                return

    def _stop_writer(self):
        """Wait until every block handed over is written; what went wrong that no one was told
        of, as text (a failed write; an error of the writer itself)."""
        errors = [f"{type(e).__name__}: {e}" for e in (f.exception() for f in self._pending) if e is not None]
        self._pending.clear()
        self._writer.shutdown(wait=True)
        if self._failure is not None and not self._told:
            errors.insert(0, self._failure)
        return errors

    @property
    def peak(self):
        return self.audio.peak if self.audio is not None else 0.0

    def close(self):
        """Finish every output (every block handed over written first); returns [(path, samples
        it holds)] and the errors met, as text (a failed write no one was told of among them)."""
        done, errors = [], self._stop_writer()
        for writer in (self.audio, self.probes):
            if writer is None:
                continue
            try:
                done.append((writer.path, writer.close()))
            except (OSError, RuntimeError, soundfile.SoundFileError) as exc:
                errors.append(f"cannot finish {writer.path}: {getattr(exc, 'strerror', None) or exc}")
        return done, errors

    def discard(self):
        self._stop_writer()
        for writer in (self.audio, self.probes):
            if writer is not None:
                writer.discard()
