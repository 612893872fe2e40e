"""Audio files through soundfile (libsndfile): written by extension (WAV, FLAC, OGG, ...), streamed
block by block into a temporary file beside the target and renamed into place when complete or
stopped; read as float64 frames × channels."""
import os
import tempfile

import numpy as np
import soundfile

# extension -> libsndfile major format, and the subtype written when none is asked
FORMATS = {".wav": "WAV", ".flac": "FLAC", ".ogg": "OGG", ".mp3": "MP3", ".aiff": "AIFF", ".aif": "AIFF"}
DEFAULT_SUBTYPE = {"WAV": "FLOAT", "FLAC": "PCM_24", "OGG": "VORBIS", "MP3": "MPEG_LAYER_III", "AIFF": "FLOAT"}


class AudioFileError(ValueError):
    pass


def writable_extensions():
    have = soundfile.available_formats()
    return [ext for ext, fmt in FORMATS.items() if fmt in have]


def audio_format(path, subtype=None):
    """(format, subtype) to write `path`, chosen by its extension; AudioFileError says what can be."""
    ext = os.path.splitext(str(path))[1].lower()
    fmt = FORMATS.get(ext)
    if fmt is None or fmt not in soundfile.available_formats():
        raise AudioFileError(f"cannot write audio as {ext or 'a file without an extension'!r}; "
                             f"the extension chooses the format: {', '.join(writable_extensions())}")
    sub = (subtype or DEFAULT_SUBTYPE[fmt]).upper()
    if not soundfile.check_format(fmt, sub):
        can = [s for s in soundfile.available_subtypes(fmt) if soundfile.check_format(fmt, s)]
        raise AudioFileError(f"{fmt} files cannot hold subtype {sub}; they can hold {', '.join(can)}")
    return fmt, sub


def beside(target, suffix=".part"):
    """A new, empty temporary file in the target's folder (same file system: renamed into place)."""
    folder, name = os.path.split(os.path.abspath(target))
    fd, tmp = tempfile.mkstemp(prefix=f".{name}.", suffix=suffix, dir=folder)
    os.close(fd)
    return tmp


def put_in_place(tmp, target):
    """Rename a finished temporary file onto its target, with the mode a new file would have."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    os.replace(tmp, target)


class AudioWriter:
    """Frames × channels appended block by block to `path` (format by extension, see audio_format,
    unless `container` names another libsndfile major format, as RF64 for a WAV past 4 GB).
    The samples go to a temporary file beside it; `close()` finishes the header (libsndfile writes
    the true sizes) and renames it onto `path` — also after a failed write, so what was written
    before a full disk is kept. PCM subtypes clip at ±1 instead of wrapping around."""

    def __init__(self, path, rate, channels, subtype=None, container=None):
        self.path = str(path)
        self.format, self.subtype = audio_format(self.path, subtype)
        self.format = container or self.format      # "RF64": a .wav past 4 GB (its 32-bit sizes cannot say)
        self.clip = self.subtype.startswith("PCM")
        self.tmp = beside(self.path)
        try:
            self.file = soundfile.SoundFile(self.tmp, "w", int(round(rate)), channels, self.subtype,
                                            format=self.format)
        except Exception as exc:
            os.unlink(self.tmp)
            raise AudioFileError(f"cannot write {self.format} {self.subtype} at {rate:g} Hz, "
                                 f"{channels} channel(s): {exc}") from None
        self.frames = 0
        self.peak = 0.0
        self._buffer = None

    def _float32(self, block):
        """The block as contiguous float32 frames. A block of the kernel's records is a column
        slice (the audio channels of rec), strided: numpy converts such a slice ~4x slower than
        it converts its columns one by one into a buffer kept for the next block (a 600 s Fig. 7
        render: 77 against 20 ms)."""
        if block.flags["C_CONTIGUOUS"] or block.ndim != 2:
            return np.asarray(block, dtype=np.float32)
        frames, channels = block.shape
        if self._buffer is None or self._buffer.shape[0] < frames or self._buffer.shape[1] != channels:
            self._buffer = np.empty((frames, channels), dtype=np.float32)
        data = self._buffer[:frames]
        for c in range(channels):
            data[:, c] = block[:, c]
        return data

    def write(self, block):
        data = self._float32(np.asarray(block))
        finite = np.isfinite(data)
        if finite.all():
            if data.size:
                self.peak = max(self.peak, float(np.abs(data).max()))
        elif finite.any():
            self.peak = max(self.peak, float(np.abs(data[finite]).max()))
        if self.clip:
            data = np.clip(data, -1.0, 1.0)
        self.file.write(data)
        self.frames += data.shape[0]

    def close(self):
        """Finish the file and rename it into place; returns the frames it holds."""
        if self.file is None:
            return self.frames
        try:
            self.file.close()
        finally:
            self.file = None
            try:
                self.frames = soundfile.info(self.tmp).frames
            except Exception:  # noqa: BLE001 - an unfinished header: report what was handed over
                pass
            put_in_place(self.tmp, self.path)
        return self.frames

    def discard(self):
        if self.file is not None:
            try:
                self.file.close()
            except Exception:  # noqa: BLE001 - it is being thrown away
                pass
            self.file = None
            os.unlink(self.tmp)


def write_wav(path, audio, rate, subtype="FLOAT"):
    """Write frames × channels as a WAV file (32-bit float by default) at an integer rate."""
    audio = np.asarray(audio, dtype=np.float64)
    if audio.ndim == 1:
        audio = audio[:, None]
    soundfile.write(str(path), audio.astype(np.float32), int(round(rate)), subtype=subtype, format="WAV")


def read_wav(path):
    """(float64 frames × channels scaled to ±1, rate)."""
    data, rate = soundfile.read(str(path), dtype="float64", always_2d=True)
    return data, rate
