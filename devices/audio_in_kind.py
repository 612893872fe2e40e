"""The driver of a block the sound enters by (audio_in): its WAV `file` beside the patch (the
driver: hapticgraph.devices.files.WavInput), or with none, while playing, a live input channel of
the sound card (`live_input(block)`, hapticgraph.devices.audio.LiveInput)."""
import os

from ..blocks.sources import AudioIn
from .driver_kind import InputKind
from .errors import DeviceError


class AudioInputKind(InputKind):
    name = "audio input"
    feeds = AudioIn

    def open(self, inst, base, live_input=None, drivers=None):
        from .files import WavInput       # the driver's module (soundfile): when opened
        what = f"block {inst.name!r} ({inst.cls.type_name})"
        if not inst.values["file"]:
            if live_input is not None:
                return live_input(inst)
            raise DeviceError(f"{what}: no file given, and live input needs `play`")
        path = os.path.join(base, inst.values["file"])
        try:
            return WavInput(path, inst.values["channel"], inst.values["loop"])
        except (OSError, ValueError) as exc:
            raise DeviceError(f"{what}: cannot read {inst.values['file']!r}: {exc}") from None


__all__ = ["AudioInputKind"]
