"""What the command line's commands share: the usage error (exit status 2), `--device` choices,
the audio channels a patch sends out, and the check every output path passes before any work
(it never names a file the command reads)."""
import inspect
import os


class UsageError(Exception):
    """A command line that cannot be run as given: one `hapticgraph: error:` line, exit status 2."""


def device_choices(items):
    """`--device NAME=DRIVER[,KEY=VALUE...]` -> {name: Choice}; a bad one is a UsageError that
    says what the driver accepts."""
    if not items:
        return {}
    from ..devices import DeviceError, parse_choice
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


def input_files(patch, replay=None):
    """Every file a command on `patch` reads: the patch, its plugin files and block modules,
    audio_in files, the files its devices name (a profile, a MIDI file...), the take replayed."""
    base = os.path.dirname(os.path.abspath(patch.file))
    files = [patch.file, *patch.registry.plugin_files]
    plugins = patch.doc.get("plugins") if isinstance(patch.doc, dict) else None
    files += [os.path.join(base, p) for p in plugins or () if isinstance(p, str) and p.endswith(".py")]
    for inst in patch.blocks.values():
        try:
            files.append(inspect.getfile(inst.cls))
        except (TypeError, OSError):
            pass
        files += [os.path.join(base, inst.values[n]) for n, p in inst.cls.params.items()
                  if p.refers == "file" and inst.values.get(n)]
    for spec in patch.devices.values():       # any setting naming a file beside the patch
        if isinstance(spec, dict):
            files += [os.path.join(base, v) for v in spec.values()
                      if isinstance(v, str) and v and os.path.isfile(os.path.join(base, v))]
    if replay:
        from ..devices.take import take_paths
        files += [replay, *take_paths(replay)]
    return files


def same_file(a, b):
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_output(option, path, inputs, command="run"):
    """Refuse, before any work, an output that would overwrite an input (`inputs`, see
    input_files) or cannot be written; returns the path to write (a symbolic link is written
    through)."""
    for used in inputs:
        if same_file(path, used):
            raise UsageError(f"{option} {os.fspath(path)!r} is a file this {command} reads "
                             f"({os.path.basename(used)}); choose another name")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise UsageError(f"{option} {path!r}: the folder {os.path.dirname(path) or '.'!r} does not exist")
    if os.path.lexists(path):
        if os.path.isdir(path):
            raise UsageError(f"{option} {path!r} is a folder")
        if not os.path.isfile(path):
            raise UsageError(f"{option} {path!r} exists and is not a regular file (a device or a pipe)")
        path = os.path.realpath(path)
    if not os.access(os.path.dirname(os.path.abspath(path)), os.W_OK | os.X_OK):
        raise UsageError(f"{option} {path!r}: the folder is not writable")
    return path
