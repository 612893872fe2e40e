"""What the command line's commands share: the usage error (exit status 2), `--device` choices
and the audio channels a patch sends out."""


class UsageError(Exception):
    """A command line that cannot be run as given: one `hapticgraph: error:` line, exit status 2."""


def device_choices(items):
    """`--device NAME=DRIVER[,KEY=VALUE...]` -> {name: Choice}; a bad one is a UsageError that
    says what the driver accepts."""
    if not items:
        return {}
    from .devices import DeviceError, parse_choice
    choices = {}
    for item in items:
        try:
            name, choice = parse_choice(item)
        except DeviceError as exc:
            raise UsageError(str(exc)) from None
        if name in choices:
            raise UsageError(f"--device {item!r}: device {name!r} is given twice")
        choices[name] = choice
    return choices


def audio_channels(patch):
    """The channels of the patch's audio sink (0: it has none)."""
    for inst in patch.blocks.values():
        if getattr(inst.cls, "audio_sink", False):
            return len(inst.inputs)
    return 0
