"""The size of every file `run` writes, known before the first sample: from the frames, the rate,
the channels, the format and the subtype of the audio, and the probes' .npz. What the format cannot
hold or the disk cannot take is a UsageError naming the option; a WAV past 4 GB is written as RF64
instead, and a note says so. (A disk that fills during the render, from another writer, still
ends the run keeping every sample written: devices/files.py.)"""
import os

from .common import UsageError

WAV_LIMIT = (1 << 32) - 1 - 4096       # a RIFF chunk's 32-bit size, less room for the header chunks
AIFF_LIMIT = WAV_LIMIT                 # AIFF's FORM chunk: 32-bit too
FLAC_FRAMES = 1 << 36                  # STREAMINFO's total samples: 36 bits
HEADER = 1 << 16                       # headers, the .npz's zip entries, rounding
# bytes a sample takes in each subtype (soundfile's names); a compressed one at most its PCM size
SAMPLE_BYTES = {"PCM_S8": 1, "PCM_U8": 1, "ULAW": 1, "ALAW": 1, "PCM_16": 2, "PCM_24": 3, "PCM_32": 4,
                "FLOAT": 4, "DOUBLE": 8}
COMPRESSED = {"FLAC", "OGG", "MP3"}


class Plan:
    """What sizing found: `container` (None, or "RF64" for a WAV past 4 GB) and `notes` to print."""

    def __init__(self, container=None, notes=()):
        self.container, self.notes = container, list(notes)


def free_bytes(path):
    """Bytes an unprivileged writer may still use on the file system holding `path`'s folder."""
    st = os.statvfs(os.path.dirname(os.path.abspath(path)))
    return st.f_bavail * st.f_frsize


def size_outputs(audio_path, probes_path, frames, rate, channels, probes, subtype, free=free_bytes):
    """Size the audio file (None: no audio) and the probes' .npz (None: no probes) of a render of
    `frames` frames; a Plan, or UsageError naming --out or --probes."""
    from ..devices.wav import audio_format      # soundfile: imported when a run writes
    plan, needs = Plan(), []                   # needs: (option, path, bytes on its disk)
    if audio_path and channels:
        fmt, sub = audio_format(audio_path, subtype)
        size = frames * channels * SAMPLE_BYTES.get(sub, 2) + HEADER
        _format_limits(plan, audio_path, fmt, size, frames, rate)
        needs.append(("--out", audio_path, 0 if fmt in COMPRESSED else size))
        if fmt in COMPRESSED and size > free(audio_path):      # its size is known only once encoded
            plan.notes.append(f"--out {audio_path!r}: {_size(size)} before {fmt} compression; the disk "
                              f"has {_size(free(audio_path))} free: it may not fit")
    if probes_path and probes:
        size = 8 * frames * probes + HEADER
        needs.append(("--probes", probes_path, 2 * size))     # the streamed columns, then the .npz
    _disk(needs, frames, rate, free)
    return plan


def _format_limits(plan, path, fmt, size, frames, rate):
    what = f"--out {path!r}: {frames / rate:g} s at {rate:g} Hz"
    if fmt == "WAV" and size > WAV_LIMIT:
        plan.container = "RF64"
        plan.notes.append(f"{what} make {_size(size)}, more than a WAV header can describe "
                          f"({_size(WAV_LIMIT)}); writing it as RF64 (a WAV with 64-bit sizes) instead")
    elif fmt == "AIFF" and size > AIFF_LIMIT:
        raise UsageError(f"{what} make {_size(size)}; AIFF holds at most {_size(AIFF_LIMIT)}: "
                         f"write .wav (RF64 past 4 GB) or .flac")
    elif fmt == "FLAC" and frames >= FLAC_FRAMES:
        raise UsageError(f"{what} make {frames:,} frames; FLAC holds at most {FLAC_FRAMES - 1:,} "
                         f"(36-bit sample count): write .wav (RF64 past 4 GB)")


def _disk(needs, frames, rate, free):
    """Every output against the free space of its file system (outputs on one file system add up)."""
    by_disk = {}
    for option, path, size in needs:
        dev = os.stat(os.path.dirname(os.path.abspath(path))).st_dev
        by_disk.setdefault(dev, []).append((option, path, size))
    for group in by_disk.values():
        total = sum(size for _, _, size in group)
        have = free(group[0][1])
        if total > have:
            sized = [(option, path, size) for option, path, size in group if size]
            each = " and ".join(f"{option} {path!r}" + (f" ({_size(size)}{' while written' if option == '--probes' else ''})"
                                                         if len(sized) > 1 else "") for option, path, size in sized)
            raise UsageError(f"{each}: {frames / rate:g} s at {rate:g} Hz need {_size(total)}; the disk "
                             f"holding {'them' if len(sized) > 1 else 'it'} has {_size(have)} free")


def _size(n):
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n} bytes"


def size_take(wav_path, frames, rate, channels, free=free_bytes):
    """`play --record --seconds`: the take's WAV (32-bit float; devices/record.FloatWav writes a
    plain RIFF header, 32-bit sizes) must fit WAV_LIMIT and the disk, checked before any device
    opens; UsageError naming --record. (Without --seconds the length is unknown: a full disk ends
    the recording keeping what was written.)"""
    size = frames * max(1, channels) * 4 + HEADER
    what = f"--record {wav_path!r}: {frames / rate:g} s at {rate:g} Hz make {_size(size)}"
    if size > WAV_LIMIT:
        raise UsageError(f"{what}; a take's WAV holds at most {_size(WAV_LIMIT)}: record shorter takes")
    if size > free(wav_path):
        raise UsageError(f"{what}; the disk holding it has {_size(free(wav_path))} free")
