"""The `hapticgraph` command line.

Exit status: 0 on success, 2 for a patch error (one `FILE:LINE: message` line per problem on
standard error, never a traceback), 1 for any other failure.
"""
import argparse
import json
import os
import sys
import textwrap

from .graph.errors import PatchError      # light: the engine is imported once a command runs


class UsageError(Exception):
    pass


def _import_engine():
    """Bind the engine's names the commands use. Called by main() after the arguments are parsed,
    so `--help` (and a usage error) never imports numpy, numba or the block library."""
    global load, PlanError, Registry, patch_schema
    from .graph.patch import load
    from .graph.program import PlanError
    from .graph.registry import Registry
    from .graph.schema import patch_schema


def _command(sub, name, help, description, examples):
    """A subcommand whose --help has a description and examples (shown as written)."""
    epilog = "examples:\n" + "\n".join(f"  {e}" for e in examples)
    return sub.add_parser(name, help=help, description=textwrap.fill(description, 88), epilog=epilog,
                          formatter_class=argparse.RawDescriptionHelpFormatter)


def _parser():
    ap = argparse.ArgumentParser(
        prog="hapticgraph", formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Physical-model haptic instruments from YAML patches, compiled to one kernel.",
        epilog="examples:\n"
               "  hapticgraph check patches/karplus_strong.yaml\n"
               "  hapticgraph run patches/karplus_strong.yaml --seconds 2 --out karplus_strong.wav\n"
               "  hapticgraph COMMAND --help        (each command's options and examples)\n\n"
               "exit status: 0 success, 2 a patch or command-line error, 1 anything else")
    sub = ap.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = _command(sub, "run", "render a patch offline to an audio file (and probes to .npz)",
                   "Render a patch offline, as fast as the machine allows, to an audio file (the format "
                   "follows the extension: .wav, .flac, .ogg) and, with --probe, the probed signals to "
                   ".npz. Devices run on their drivers (the simulated device by default).",
                   ["hapticgraph run patches/karplus_strong.yaml --seconds 2 --out karplus_strong.wav",
                    "hapticgraph run patches/karplus_strong.yaml --out ks.flac --set damp.gain=0.99",
                    "hapticgraph run patches/fig8_pluck_damp.yaml --probe tip.force --probe finger.x",
                    "hapticgraph run my_string.yaml --replay take.hgrec"])
    run.add_argument("patch")
    run.add_argument("--seconds", type=float, default=None,
                     help="length to render (default 2; with --replay, the take's length)")
    run.add_argument("--out", help="audio file to write, its format chosen by the extension: .wav, .flac, "
                                    ".ogg, .mp3, .aiff (default: the patch's name, .wav, here)")
    run.add_argument("--probe", action="append", default=[], metavar="BLOCK.PORT",
                     help="record a port (repeatable); a cell's port is name[i, j].port")
    run.add_argument("--probes", metavar="FILE.npz", help="where the probes go (default: beside the WAV)")
    run.add_argument("--set", action="append", default=[], metavar="BLOCK.PARAM=VALUE", dest="overrides",
                     help="override a parameter (repeatable)")
    run.add_argument("--engine", choices=("compiled", "python"), default="compiled",
                     help="compiled numba kernel (default) or the reference interpreter")
    run.add_argument("--device", action="append", default=[], metavar="NAME=DRIVER[,KEY=VALUE...]",
                     help="choose a device's driver (simulated, hid, replay) and settings that override its "
                          "entry's, e.g. finger=hid,profile=haptic_1dof,max_force=2 (repeatable)")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.add_argument("--subtype", metavar="PCM_16|PCM_24|FLOAT", type=str.upper,
                     help="sample format of --out, in soundfile's names (default: FLOAT for WAV and "
                          "AIFF, PCM_24 for FLAC)")
    run.add_argument("--replay", metavar="TAKE.hgrec",
                     help="feed every device and live input from a take made by `play --record` "
                          "(--seconds defaults to the take's length)")

    play = _command(sub, "play", "play a patch in real time through the sound card",
                    "Play a patch in real time: the sound card's clock drives the kernel block by block; "
                    "devices are read on their own threads and every force sent is clamped to the "
                    "device's max_force. Runs until Ctrl-C unless --seconds is given.",
                    ["hapticgraph play patches/karplus_strong.yaml --seconds 2",
                     "hapticgraph play my_string.yaml --device finger=hid,profile=haptic_1dof --blocksize 64",
                     "hapticgraph play my_string.yaml --record take --watch",
                     "hapticgraph play patches/cymatic_sheet.yaml --console"])
    play.add_argument("patch")
    play.add_argument("--audio-device", metavar="D", help="output device: index or (part of) its name "
                      "(see `hapticgraph devices`; default: the system's default)")
    play.add_argument("--input-device", metavar="D", help="input device for live audio_in blocks (default: the default)")
    play.add_argument("--blocksize", type=int, default=128, metavar="N",
                      help="frames per audio callback, the kernel's block (default 128)")
    play.add_argument("--latency", default="low", metavar="low|high|SECONDS",
                      help="PortAudio's suggested output latency (default low)")
    play.add_argument("--seconds", type=float, default=None, metavar="S",
                      help="stop after S seconds (default: play until Ctrl-C)")
    play.add_argument("--record", metavar="TAKE", help="record the device inputs to TAKE.hgrec and the "
                      "audio to TAKE.wav (replay with `hapticgraph run PATCH --replay TAKE.hgrec`)")
    play.add_argument("--replay", metavar="TAKE.hgrec", help="play a recorded take back through the sound card")
    play.add_argument("--console", action="store_true",
                      help="read edits from standard input while playing: set BLOCK.PARAM VALUE, "
                           "lock/unlock/cut NAME[i, j] (lattices then run on their editable CSR path)")
    play.add_argument("--watch", action="store_true", help="reload the patch when its file changes, keeping "
                      "the state of every block that did not change")
    play.add_argument("--set", action="append", default=[], metavar="BLOCK.PARAM=VALUE", dest="overrides",
                      help="override a parameter (repeatable)")
    play.add_argument("--device", action="append", default=[], metavar="NAME=DRIVER[,KEY=VALUE...]",
                      help="choose a device's driver (simulated, hid, replay) and settings that override its "
                           "entry's, e.g. finger=hid,profile=haptic_1dof,max_force=2 (repeatable)")
    play.add_argument("--fade", type=float, default=0.005, metavar="SECONDS", help=argparse.SUPPRESS)

    _command(sub, "devices", "list sound cards and HID devices",
             "List the sound cards PortAudio sees (index, name, channels, rate) and the HID devices "
             "hidapi sees (vendor:product id, name, the shipped profile that matches).",
             ["hapticgraph devices", "hapticgraph play PATCH --audio-device 3"])

    check = _command(sub, "check", "check a patch and report every problem",
                     "Load and check a patch without compiling or running it: every problem is printed "
                     "as FILE:LINE: message (exit 2); a good patch prints ok and its schedule.",
                     ["hapticgraph check patches/karplus_strong.yaml",
                      "hapticgraph check my_string.yaml --set bridge.gain=-0.99"])
    check.add_argument("patch")
    check.add_argument("--set", action="append", default=[], metavar="BLOCK.PARAM=VALUE", dest="overrides",
                       help="override a parameter (repeatable)")

    blocks = _command(sub, "blocks", "list the block types (built-in and plugins)",
                      "List every block type: its input ports (* a live parameter, also an input), its "
                      "outputs, its equation and its parameters with units and defaults.",
                      ["hapticgraph blocks", "hapticgraph blocks --markdown > docs/blocks.md",
                       "hapticgraph blocks --patch examples/file_plugin/saturated_string.yaml --json"])
    blocks.add_argument("--json", action="store_true", help="machine-readable")
    blocks.add_argument("--markdown", action="store_true", help="the block reference (docs/blocks.md)")
    blocks.add_argument("--patch", help="also load this patch's plugins")

    _command(sub, "schema", "print the JSON Schema of a patch (for editors)",
             "Print the JSON Schema of a patch, assembled from every block's declarations, for an "
             "editor's YAML support (completion and checking of block types and parameters).",
             ["hapticgraph schema > hapticgraph.schema.json"])

    graph = _command(sub, "graph", "export the patch graph as Graphviz dot or Mermaid",
                     "Write the patch's blocks and connections as a Graphviz dot or Mermaid graph "
                     "(nothing is compiled).",
                     ["hapticgraph graph patches/karplus_strong.yaml --format mermaid",
                      "hapticgraph graph patches/karplus_strong.yaml -o ks.dot && dot -Tpng ks.dot -o ks.png"])
    graph.add_argument("patch")
    graph.add_argument("--format", choices=("dot", "mermaid"), default="dot", help="default dot")
    graph.add_argument("-o", "--out", metavar="FILE", help="write here instead of standard output")

    plot = _command(sub, "plot", "render a patch and draw probe traces and a spectrogram to PNG",
                    "Render a patch and draw each probe against time [s], in its quantity and unit, "
                    "above a spectrogram (frequency [Hz]) of the audio; or, with --mode N, draw mode N "
                    "of a lattice (numbered from 1, the lowest, as `hapticgraph modes` lists them). "
                    "Needs matplotlib: pip install \"hapticgraph[plot]\".",
                    ["hapticgraph plot patches/karplus_strong.yaml --probe loop.out --window 0 0.02 -o ks.png",
                     "hapticgraph plot patches/fig8_pluck_damp.yaml --seconds 1.5 --probe finger.x "
                     "--probe tip.force -o fig8.png",
                     "hapticgraph plot patches/babe_is_sleeping.yaml --lattice cym_a --mode 5 -o mode.png"])
    plot.add_argument("patch")
    plot.add_argument("--probe", action="append", default=[], metavar="BLOCK.PORT", help="a trace to draw (repeatable)")
    plot.add_argument("-o", "--out", required=True, metavar="FILE.png", help="the PNG to write")
    plot.add_argument("--seconds", type=float, default=1.0, help="length to render (default 1)")
    plot.add_argument("--window", nargs=2, type=float, metavar=("T0", "T1"), help="time window of the traces [s]")
    plot.add_argument("--spectrogram", default="audio", metavar="audio|BLOCK.PORT|none",
                      help="what the spectrogram shows (default: the audio)")
    plot.add_argument("--set", action="append", default=[], metavar="BLOCK.PARAM=VALUE", dest="overrides",
                      help="override a parameter (repeatable)")
    plot.add_argument("--title", default=None, help="the figure's title (default: the patch's name)")
    plot.add_argument("--mode", type=int, metavar="N",
                      help="draw mode N of a lattice instead of rendering (1: the lowest, as `modes` "
                           "numbers them)")
    plot.add_argument("--lattice", metavar="NAME", help="the lattice or cell block whose mode is drawn "
                      "(default: the first)")

    modes = _command(sub, "modes", "predicted modal frequencies of each mass-spring network",
                     "Predict the lowest modal frequencies of each mass-spring network (lossless, with "
                     "the half-step scheme's discrete-time correction), numbered from 1 (the lowest), "
                     "so an instrument can be tuned before it is heard.",
                     ["hapticgraph modes patches/cymatic_string.yaml --count 5",
                      "hapticgraph modes patches/babe_is_sleeping.yaml --json",
                      "hapticgraph plot patches/babe_is_sleeping.yaml --lattice cym_a --mode 5 -o mode.png"])
    modes.add_argument("patch")
    modes.add_argument("--count", type=int, default=20, metavar="N", help="modes per network (default 20)")
    modes.add_argument("--json", action="store_true", help="machine-readable")
    modes.add_argument("--set", action="append", default=[], metavar="BLOCK.PARAM=VALUE", dest="overrides",
                       help="override a parameter (repeatable)")
    return ap


def describe_block(cls, origin):
    inputs, outputs = cls.ports(cls.default_params())
    return {
        "type": cls.type_name,
        "origin": origin,
        "equation": (cls.__doc__ or "").strip().splitlines()[0] if cls.__doc__ else "",
        "inputs": [p.name for p in inputs],
        "outputs": [p.name for p in outputs],
        "params": {n: {"kind": p.kind, "default": list(p.default) if p.kind == "list" else p.default,
                       "unit": p.unit, "minimum": p.minimum, "maximum": p.maximum, "above": p.above,
                       "below": p.below, "live": p.live, "choices": list(p.choices) if p.choices else None,
                       "doc": p.doc}
                   for n, p in cls.params.items()},
        "states": [s.attr for s in cls.states],
        "feedthrough": sorted(cls.feedthrough()),
    }


def _cmd_blocks(args):
    registry = Registry()
    if args.patch:
        registry = load(args.patch).registry
    if args.markdown:
        from .reference import block_reference
        sys.stdout.write(block_reference(None if not args.patch else registry))
        return 0
    rows = [describe_block(registry.types[n], registry.origin[n]) for n in sorted(registry.types)]
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    for r in rows:
        ins = ", ".join(r["inputs"] + [f"{n}*" for n, p in r["params"].items() if p["live"]])
        print(f"{r['type']}: {ins or '-'} -> {', '.join(r['outputs']) or '-'}")
        print(f"    {r['equation']}")
        for n, p in r["params"].items():
            unit = f" {p['unit']}" if p["unit"] else ""
            print(f"    {n} = {p['default']!r}{unit}{'  (live)' if p['live'] else ''}")
    print("(* a live parameter, also an input port)")
    return 0


def _cmd_check(args):
    patch = load(args.patch, overrides=args.overrides)
    origin = patch.registry.origin
    plugins = set(patch.registry.plugin_files)          # every file a `plugins:` entry imported
    plugins |= {os.path.realpath(sys.modules[inst.cls.__module__].__file__) for inst in patch.blocks.values()
                if origin.get(inst.cls.type_name) != "built-in"
                and getattr(sys.modules.get(inst.cls.__module__), "__file__", None)}  # installed plugins used
    if any(origin.get(inst.cls.type_name) != "built-in" for inst in patch.blocks.values()):
        # plugins are the only code a patch runs: each plugin block is compiled on its own here, so
        # a body numba cannot compile fails `check` at the plugin's line, not `run` in another block
        from .graph.kernel import plugin_problems
        problems = plugin_problems(patch)
        if problems:
            raise PatchError(problems)
    print(f"{args.patch}: ok: {len(patch.blocks)} blocks, {len(patch.connections)} connections at "
          f"{patch.rate:g} Hz; schedule: {' -> '.join(patch.order)}")
    for path in sorted(plugins):
        print(f"  plugins run: {os.path.basename(path)} ({path})")
    return 0


def _device_choices(items):
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


def _input_files(patch, replay=None):
    """Every file a run reads: the patch, its plugin and block modules, audio_in files, takes."""
    import inspect
    base = os.path.dirname(os.path.abspath(patch.file))
    files = [patch.file]
    plugins = patch.doc.get("plugins") if isinstance(patch.doc, dict) else None
    files += [os.path.join(base, p) for p in plugins or () if isinstance(p, str) and p.endswith(".py")]
    for inst in patch.blocks.values():
        try:
            files.append(inspect.getfile(inst.cls))
        except (TypeError, OSError):
            pass
        if inst.cls.type_name == "audio_in" and inst.values.get("file"):
            files.append(os.path.join(base, inst.values["file"]))
    files += [os.path.join(base, spec["file"]) for spec in patch.devices.values()
              if isinstance(spec, dict) and isinstance(spec.get("file"), str)]
    if replay:
        from .devices.record import take_paths
        files += [replay, *take_paths(replay)]
    return files


def _same_file(a, b):
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def _check_output(option, path, inputs):
    """Refuse, before any work, an output that would overwrite an input or cannot be written;
    returns the path to write (a symbolic link is written through)."""
    for used in inputs:
        if _same_file(path, used):
            raise UsageError(f"{option} {path!r} is a file this run reads ({os.path.basename(used)}); "
                             f"choose another name")
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


def _render_to(sink, patch, args, choices, replayed, stop):
    """Stream the render into the sink; (Streamed, safety problem, output failure), or None when
    interrupted before rendering began (the sink discarded)."""
    from .devices import DeviceError, open_drivers
    from .devices.files import OutputError
    from .graph.engine import SafetyStop, stream
    try:
        drivers = replayed if replayed is not None else open_drivers(patch, choices)
        streamed = stream(patch, args.seconds, sink, probes=args.probe, engine=args.engine,
                          progress=False if args.quiet else None, drivers=drivers, safety=True, stop=stop)
        return streamed, None, None
    except (PlanError, DeviceError) as exc:
        sink.discard()
        raise UsageError(str(exc)) from None
    except PatchError:                     # found while compiling (a plugin numba cannot compile)
        sink.discard()
        raise
    except KeyboardInterrupt as exc:
        if not stop.rendering or getattr(exc, "streamed", None) is None:
            sink.discard()
            print("hapticgraph: interrupted before rendering began; nothing written", file=sys.stderr)
            return None
        return exc.streamed, "interrupted", None
    except SafetyStop as exc:
        return exc.streamed, str(exc), None
    except OutputError as exc:
        return exc.streamed, None, str(exc)
    except BaseException:                  # a bug: keep what was made, then let main report it
        sink.close()
        raise


def _cmd_run(args):
    import math
    import signal
    from .devices import DeviceError
    from .devices.files import FileSink
    from .devices.wav import AudioFileError
    from .graph.engine import StopRequest
    choices = _device_choices(args.device)
    if args.seconds is not None and not (math.isfinite(args.seconds) and args.seconds > 0):
        raise UsageError(f"--seconds {args.seconds:g}: expected a positive, finite number of seconds")
    if args.replay and choices:
        raise UsageError("--replay feeds every device from the take; it takes no --device")
    if args.probes and not args.probes.lower().endswith(".npz"):
        raise UsageError(f"--probes {args.probes!r}: the probes are written as .npz; name a FILE.npz")
    patch = load(args.patch, overrides=args.overrides)
    if args.replay:
        from .devices.record import replay_drivers
        try:
            take, replayed = replay_drivers(patch, args.replay)
        except DeviceError as exc:
            raise UsageError(str(exc)) from None
        if args.seconds is None and take.frames:
            args.seconds = take.seconds
    if args.seconds is None:
        args.seconds = 2.0
    if round(args.seconds * patch.rate) < 1:
        raise UsageError(f"--seconds {args.seconds:g} is less than one sample at {patch.rate:g} Hz")
    stem = os.path.splitext(os.path.basename(args.patch))[0]
    out = args.out or f"{stem}.wav"
    channels = _audio_channels(patch)
    inputs = _input_files(patch, args.replay)
    audio_path = _check_output("--out", out, inputs) if channels or args.out else None
    probes_path = None
    if args.probe:
        probes_path = _check_output("--probes", args.probes or os.path.splitext(out)[0] + ".npz", inputs)
        if audio_path and channels and _same_file(os.path.abspath(probes_path), os.path.abspath(audio_path)):
            raise UsageError(f"--probes {probes_path!r} and --out name the same file")
    if not channels and not args.probe:
        print(f"hapticgraph: {args.patch} has no audio_out block and no --probe was given; nothing written",
              file=sys.stderr)
    try:
        sink = FileSink(audio_path if channels else None, probes_path, patch.rate, channels, args.probe,
                        subtype=args.subtype)
    except AudioFileError as exc:
        raise UsageError(f"--out {out!r}: {exc}") from None
    except OSError as exc:
        raise UsageError(f"cannot write beside {out!r}: {exc.strerror or exc}") from None

    stop = StopRequest()
    caught = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
    previous = {s: signal.signal(s, stop.request) for s in caught}
    try:         # the handlers stay until the files are in place: a second signal loses nothing either
        outcome = _render_to(sink, patch, args, choices, replayed if args.replay else None, stop)
        if outcome is None:
            return 1
        streamed, problem, failure = outcome
        written, errors = sink.close()
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
    rate = streamed.rate
    seconds = streamed.samples / rate
    where = ", ".join(path for path, _ in written) or "-"
    print(f"{args.patch}: {seconds:g} s at {rate:g} Hz ({args.engine}; compile "
          f"{streamed.compile_seconds:.2f} s, run {streamed.run_seconds:.2f} s), peak {sink.peak:.4g} -> {where}")
    held = "; ".join(f"{n} samples written to {path}" for path, n in written) or "nothing written"
    for error in errors:
        print(f"hapticgraph: error: {error}", file=sys.stderr)
    if failure:
        print(f"hapticgraph: error: {failure}; {held}", file=sys.stderr)
        return 1
    if streamed.stopped is not None:
        name = signal.Signals(streamed.stopped).name
        print(f"hapticgraph: interrupted ({name}) after {seconds:.3f} s; {held}", file=sys.stderr)
        return 1
    if problem == "interrupted":
        print(f"hapticgraph: interrupted after {seconds:.3f} s; {held}", file=sys.stderr)
        return 1
    if problem:
        print(f"hapticgraph: stopped after {seconds:.3f} s: {problem}; the force sent was zeroed first, "
              f"what was rendered is written ({held})", file=sys.stderr)
        return 1
    return 1 if errors else 0


def _parse_latency(text):
    if text in ("low", "high"):
        return text
    try:
        value = float(text)
    except ValueError:
        raise UsageError(f"--latency {text!r}: expected low, high or a number of seconds") from None
    if not 0 < value <= 2:
        raise UsageError(f"--latency {text!r}: expected a number of seconds in (0, 2]")
    return value


def _cmd_play(args):
    """Real-time play: the sound card's clock drives the kernel block by block."""
    import signal
    from .devices import DeviceError, open_drivers
    from .devices import audio
    from .devices.record import Recorder, replay_drivers
    if args.blocksize < 1 or args.blocksize > 1 << 15:
        raise UsageError(f"--blocksize {args.blocksize}: expected a number of frames from 1 to 32768")
    if args.seconds is not None and args.seconds <= 0:
        raise UsageError("--seconds must be positive")
    if not 0 < args.fade <= 1:
        raise UsageError("--fade must be in (0, 1] seconds")
    latency = _parse_latency(args.latency)
    if args.replay and args.device:
        raise UsageError("--replay feeds every device from the take; it takes no --device")
    choices = _device_choices(args.device)
    if args.replay and args.watch:
        raise UsageError("--replay and --watch do not go together")
    patch = load(args.patch, overrides=args.overrides)
    unknown = sorted(set(choices) - set(patch.devices))
    if unknown:
        raise UsageError(f"--device: the patch declares no device named {', '.join(unknown)} "
                         f"(its devices: {', '.join(patch.devices) or 'none'})")
    try:
        audio.sounddevice()
    except audio.AudioError as exc:
        print(f"hapticgraph: error: {exc}", file=sys.stderr)
        return 1
    try:
        out_dev = audio.find_device(args.audio_device, "output", max(1, _audio_channels(patch)))
        if args.replay:
            take, drivers = replay_drivers(patch, args.replay)
            if args.seconds is None and take.frames:
                args.seconds = take.seconds
        else:
            drivers = open_drivers(patch, choices, live_input=audio.LiveInput.for_block)
        live = [d for d in drivers.values() if isinstance(d, audio.LiveInput)]
        in_dev = audio.find_device(args.input_device, "input", 1 + max(d.channel for d in live)) if live else None
        session = audio.play_session(patch, drivers, args.blocksize, editable=args.console)
    except (PlanError, DeviceError, audio.AudioError) as exc:
        raise UsageError(str(exc)) from None
    recorder = None
    if args.record:
        kinds = {name: (choices[name].driver if name in choices else spec.get("driver", "simulated"))
                 for name, spec in patch.devices.items()}
        kinds.update({d.name: "live audio input" for d in live})
        try:
            recorder = Recorder(args.record, session, max(1, session.prog.channels), args.blocksize, kinds=kinds)
        except OSError as exc:
            session.stop()
            raise UsageError(f"--record {args.record!r}: {exc.strerror or exc}") from None
        except DeviceError as exc:
            session.stop()
            raise UsageError(str(exc)) from None
    try:
        player = audio.Player(session, device=out_dev, blocksize=args.blocksize, latency=latency,
                              input_device=in_dev, seconds=args.seconds, fade=args.fade, recorder=recorder)
    except audio.AudioError as exc:
        if recorder is not None:
            recorder.close()
        raise UsageError(str(exc)) from None
    watcher = None
    if args.watch:
        def make_session(old):
            new_patch = load(args.patch, overrides=args.overrides)
            drivers, opened, unused = audio.reload_drivers(old.prog.patch, new_patch, old.prog.drivers, choices,
                                                           live_input=audio.LiveInput.for_block)
            return audio.play_session(new_patch, drivers, args.blocksize, editable=args.console), opened, unused
        watcher = audio.Watcher(player, args.patch, make_session).start()

    def terminate(signum, frame):
        raise KeyboardInterrupt
    previous = signal.signal(signal.SIGTERM, terminate)
    if args.console:
        from .console import HELP, Console
        Console(lambda: player.bound.session).start()
        print(f"hapticgraph: {HELP}", file=sys.stderr)
    until = f"for {args.seconds:g} s" if args.seconds else "until Ctrl-C"
    print(f"hapticgraph: playing {patch.name!r} {until} on {player.device_name}", file=sys.stderr)
    try:
        report = player.run()
    finally:
        signal.signal(signal.SIGTERM, previous)
        if watcher is not None:
            watcher.stop()
    for line in report.lines(args.patch):
        print(line)
    if player.recorder is not None:
        rec = player.recorder
        print(f"  recorded {rec.rows_written} samples of device inputs to {rec.path} and "
              f"{rec.frames} frames of audio to {rec.wav_path}"
              + (f"; {rec.dropped} samples DROPPED (the disk was too slow)" if rec.dropped else "")
              + (f"; inputs not recorded after a reload: {rec.inputs_stopped}" if rec.inputs_stopped else ""))
        if rec.failed:
            print(f"hapticgraph: error: recording stopped early: {rec.failed}; {rec.path} ({rec.rows_written} "
                  f"samples) and {rec.wav_path} ({rec.frames} frames) keep everything written before",
                  file=sys.stderr)
            return 1
    if report.problem:
        print(f"hapticgraph: stopped after {report.seconds:.3f} s: {report.problem}; the force sent was "
              f"zeroed in that block and the audio muted with a {1e3 * args.fade:g} ms fade", file=sys.stderr)
        return 1
    if report.interrupted:
        print(f"hapticgraph: interrupted after {report.seconds:.3f} s; faded out and stopped", file=sys.stderr)
    return 0


def _audio_channels(patch):
    for inst in patch.blocks.values():
        if getattr(inst.cls, "audio_sink", False):
            return len(inst.inputs)
    return 0


def _cmd_devices(args):
    """Sound cards (PortAudio) and HID devices (hidapi)."""
    from .devices import audio
    print("Sound cards (PortAudio):")
    try:
        cards = audio.sound_cards()
    except audio.AudioError as exc:
        cards = None
        print(f"  unavailable: {exc}")
    if cards is not None and not cards:
        print("  none found")
    for c in cards or ():
        marks = [m for m, on in (("default output", c["default_out"]), ("default input", c["default_in"])) if on]
        print(f"  {c['index']:3d}  {c['name']}  [{c['hostapi']}]  in {c['inputs']}, out {c['outputs']}, "
              f"{c['rate']:g} Hz{'  (' + ', '.join(marks) + ')' if marks else ''}")
    from .devices.midi import port_lines
    print(*port_lines(), sep="\n")
    print("HID devices (hidapi):")
    try:
        from .devices.hid import list_hid_devices
        hids = list_hid_devices()
    except (ImportError, AttributeError) as exc:
        print(f"  unavailable: {exc}")
        return 0
    except Exception as exc:  # noqa: BLE001 - the listing must not crash on a busy device
        print(f"  unavailable: {type(exc).__name__}: {exc}")
        return 0
    if not hids:
        print("  none found")
    for h in hids:
        if isinstance(h, dict):
            vid, pid = h.get("vendor_id", 0), h.get("product_id", 0)
            name = " ".join(x for x in (h.get("manufacturer_string"), h.get("product_string")) if x) or "?"
            extra = f"  profile {h['profile']}" if h.get("profile") else ""
            print(f"  {vid:04x}:{pid:04x}  {name}  {h.get('path', b'')!s}{extra}")
        else:
            print(f"  {h}")
    return 0


def _cmd_plot(args):
    from . import plot
    try:
        plot.pyplot()                 # before any work: without matplotlib, one line and exit 1
    except plot.MatplotlibMissing as exc:
        print(f"hapticgraph: {exc}", file=sys.stderr)
        return 1
    if args.mode is not None and args.mode < 1:
        raise UsageError(f"--mode {args.mode}: modes are numbered from 1 (the lowest), as "
                         f"`hapticgraph modes` lists them")
    patch = load(args.patch, overrides=args.overrides)
    if args.mode is not None or args.lattice:
        from .graph.modes import mode_shape
        lattices = [n for n, b in patch.blocks.items() if b.cls.type_name in ("lattice", "cell")]
        name = args.lattice or (lattices[0] if lattices else None)
        if name is None:
            raise UsageError("--mode: the patch has no lattice or cell block")
        mode = args.mode or 1
        try:
            freq, shape = mode_shape(patch, name, mode)
        except ValueError as exc:
            raise UsageError(f"--mode: {exc}") from None
        plot.plot_mode(freq, shape, args.out, title=args.title or f"{patch.name}: {name}, mode {mode}:")
        print(f"{args.patch}: {name} mode {mode} at {freq:.2f} Hz -> {args.out}")
        return 0
    from . import render
    spec = None if args.spectrogram == "none" else args.spectrogram
    probes = list(args.probe)
    if spec not in (None, "audio") and spec not in probes:
        probes.append(spec)
    try:
        result = render(patch, args.seconds, probes=probes, progress=False)
    except PlanError as exc:
        raise UsageError(str(exc)) from None
    if spec == "audio" and not result.audio.shape[1]:
        spec = probes[0] if probes else None
    if not probes and spec is None:
        raise UsageError("nothing to draw: give --probe or a patch with audio_out")
    plot.plot_render(result, list(args.probe), args.out, title=args.title or patch.name,
                     window=tuple(args.window) if args.window else None, spectrogram=spec, patch=patch)
    print(f"{args.patch}: {len(args.probe)} trace(s){' and a spectrogram' if spec else ''} -> {args.out}")
    return 0


def _cmd_modes(args):
    """The lowest modes of each network: K φ = ω² M φ (locked cells removed, damping ignored),
    sounding at f = (fs/π)·asin(ω/(2 fs)) under the half-step scheme; rigid modes print as 0 Hz."""
    from .graph.modes import network_modes
    if args.count < 1:
        raise UsageError("--count must be at least 1")
    patch = load(args.patch, overrides=args.overrides)
    nets = network_modes(patch, args.count)
    if args.json:
        print(json.dumps({"patch": args.patch, "rate": patch.rate, "networks": [m.as_dict() for m in nets]},
                         indent=2))
        return 0
    if not nets:
        print(f"{args.patch}: no mass-spring network")
        return 0
    for m in nets:
        print(f"{m.name}: {m.cells} moving cells, {m.locked} locked ({m.method}); half-step scheme at "
              f"{patch.rate:g} Hz, damping ignored")
        print(f"  {'mode':>4}  {'f [Hz]':>14}  {'continuous [Hz]':>15}  {'f/f1':>8}")
        first = next((f for f in m.frequencies if f > 0), None)
        for i, (f, fc) in enumerate(zip(m.frequencies, m.continuous), 1):
            ratio = f"{f / first:8.4f}" if first and f > 0 else f"{'rigid' if f == 0 else '-':>8}"
            print(f"  {i:4d}  {f:14.6f}  {fc:15.6f}  {ratio}")
        for note in m.notes:
            print(f"  note: {note}")
    return 0


def _cmd_graph(args):
    from .graph.export import to_dot, to_mermaid
    patch = load(args.patch)
    text = (to_dot if args.format == "dot" else to_mermaid)(patch)
    if args.out:
        with open(args.out, "w", encoding="utf-8") as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    return 0


def _compile_notice(text):
    print(f"hapticgraph: {text}", file=sys.stderr, flush=True)


def main(argv=None):
    args = _parser().parse_args(argv)
    _import_engine()
    told = args.command in ("run", "play", "plot", "check") and not getattr(args, "quiet", False)
    if told:
        from .graph import kernel
        kernel.notice = _compile_notice     # a cold compile says so at once; a cache hit says nothing
    try:
        if args.command == "schema":
            print(json.dumps(patch_schema(Registry()), indent=2))
            return 0
        return {"run": _cmd_run, "check": _cmd_check, "blocks": _cmd_blocks,
                "plot": _cmd_plot, "graph": _cmd_graph, "modes": _cmd_modes, "play": _cmd_play,
                "devices": _cmd_devices}[args.command](args)
    except PatchError as exc:
        for problem in exc.problems:
            print(problem, file=sys.stderr)
        return 2
    except UsageError as exc:
        print(f"hapticgraph: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("hapticgraph: interrupted", file=sys.stderr)
        return 1
    except BrokenPipeError:          # e.g. `hapticgraph modes P | head`: the reader has gone
        sys.stderr.close()
        return 0
    except Exception as exc:  # noqa: BLE001 - the CLI never shows a traceback unless asked
        if os.environ.get("HAPTICGRAPH_DEBUG"):
            raise
        print(f"hapticgraph: error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    finally:
        if told:
            kernel.notice = None
