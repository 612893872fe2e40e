"""The sound cards PortAudio sees (through sounddevice, imported when first asked for): listing
them (`hapticgraph devices`) and finding the one `play --audio-device` names."""


class AudioError(Exception):
    """A sound card problem the user can fix (unknown device, unsupported rate, no PortAudio)."""


def sounddevice():
    """The sounddevice module, or AudioError saying what to install."""
    try:
        import sounddevice as sd
    except ImportError:
        raise AudioError("play needs the sounddevice package: pip install 'hapticgraph[audio]'") from None
    except OSError as exc:
        raise AudioError(f"the PortAudio library was not found ({exc}); on Debian/Ubuntu: "
                         "apt-get install libportaudio2") from None
    return sd


def rescan():
    """Make PortAudio enumerate the devices again (e.g. after a JACK server started)."""
    sd = sounddevice()
    sd._terminate()
    sd._initialize()


def sound_cards():
    """[{index, name, hostapi, inputs, outputs, rate, default_in, default_out}] of every device."""
    sd = sounddevice()
    apis = sd.query_hostapis()
    out = []
    try:
        devices = sd.query_devices()
    except sd.PortAudioError:
        return out
    try:
        din, dout = sd.default.device
    except Exception:  # noqa: BLE001 - no default device
        din = dout = -1
    for i, d in enumerate(devices):
        out.append({"index": i, "name": d["name"], "hostapi": apis[d["hostapi"]]["name"],
                    "inputs": d["max_input_channels"], "outputs": d["max_output_channels"],
                    "rate": d["default_samplerate"], "default_in": i == din, "default_out": i == dout})
    return out


def find_device(spec, kind="output", channels=1):
    """The PortAudio index of a device given by index or by (part of) its name; None: the default."""
    sd = sounddevice()
    cards = [c for c in sound_cards() if c["inputs" if kind == "input" else "outputs"] > 0]
    listing = "; ".join(f"{c['index']}: {c['name']} ({c['hostapi']})" for c in cards) or "none found"
    if spec is None or spec == "":
        try:
            info = sd.query_devices(kind=kind)
        except sd.PortAudioError:
            raise AudioError(f"no default audio {kind} device (devices: {listing})") from None
        index = int(info["index"]) if "index" in info else None
    elif str(spec).strip().lstrip("-").isdigit():
        index = int(spec)
        if not any(c["index"] == index for c in cards):
            raise AudioError(f"no audio {kind} device with index {index} (devices: {listing})")
    else:
        needle = str(spec).lower()
        exact = [c for c in cards if c["name"].lower() == needle]
        found = exact or [c for c in cards if needle in c["name"].lower()]
        if not found:
            raise AudioError(f"no audio {kind} device named {spec!r} (devices: {listing})")
        if len(found) > 1:
            raise AudioError(f"audio {kind} device {spec!r} is ambiguous: "
                             + "; ".join(f"{c['index']}: {c['name']}" for c in found))
        index = found[0]["index"]
    if index is not None:
        have = next(c for c in sound_cards() if c["index"] == index)
        n = have["inputs" if kind == "input" else "outputs"]
        if n < channels:
            raise AudioError(f"audio {kind} device {have['name']!r} has {n} channel(s); the patch needs {channels}")
    return index


__all__ = ["AudioError", "find_device", "rescan", "sound_cards", "sounddevice"]
