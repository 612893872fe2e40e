"""`hapticgraph run`: render a patch offline into an audio file and a probes file. Every output
is checked before any work (it must not overwrite a file the run reads, and its size, known from
the length, the rate, the channels and the format, must fit the format, the disk and the process's
file-size limit: cli/sizes.py); what was rendered is written whatever stops the render (a signal, a
safety stop, a full disk). The render streams block by block: memory is flat in the duration.

An output is whole or absent, never cut: each is written to a temporary file beside it and renamed
into place finished. Ctrl-C (SIGINT), SIGTERM or SIGHUP during the render ends it at the next block
and keeps everything rendered: the files are finished (true sizes in the WAV's header), renamed
into place — shorter than asked — and one line says so (`hapticgraph: interrupted (SIGINT) after
1.234 s; 54419 samples written to w.wav`), exit status 128 + the signal (130 for Ctrl-C). Before
the render began (loading, compiling) nothing is written and no temporary file is left; once it
has ended, a signal changes nothing. `--quiet` prints nothing on success."""
import math
import os
import signal
import sys

from .common import UsageError, audio_channels, check_output, device_choices, input_files, same_file
from .sizes import size_outputs
from ..devices import DeviceError, open_drivers
from ..devices.files import FileSink, OutputError
from ..devices.wav import AudioFileError
from ..graph.engine import SafetyStop, stream
from ..graph.errors import PatchError
from ..graph.patch import load
from ..graph.program import PlanError


def cmd_run(args):
    choices = device_choices(args.device)
    _check_options(args, choices)
    patch = load(args.patch, overrides=args.overrides)
    replayed = _replayed(patch, args) if args.replay else None
    if args.seconds is None:
        args.seconds = 2.0
    if round(args.seconds * patch.rate) < 1:
        raise UsageError(f"--seconds {args.seconds:g} is less than one sample at {patch.rate:g} Hz")
    interrupt = args.interrupt
    interrupt.take(signal.SIGTERM, signal.SIGHUP)      # a kill or a hang-up stops it as Ctrl-C does
    sink = None
    try:
        with interrupt.held():         # the temporary files are never made without their owner
            sink = _open_sink(patch, args)
        outcome = _render_to(sink, patch, args, choices, replayed, interrupt)
    except KeyboardInterrupt:
        if sink is not None:
            sink.discard()
        outcome = None
    if outcome is None:
        print("hapticgraph: interrupted before rendering began; nothing written", file=sys.stderr)
        return interrupt.status()
    written, errors = sink.close()     # rendering: a signal now is only noted; the files go in place
    return _report(args, sink, *outcome, written, errors)


def _check_options(args, choices):
    if args.seconds is not None and not (math.isfinite(args.seconds) and args.seconds > 0):
        raise UsageError(f"--seconds {args.seconds:g}: expected a positive, finite number of seconds")
    if args.replay and choices:
        raise UsageError("--replay feeds every device from the take; it takes no --device")
    if args.probes and not args.probes.lower().endswith(".npz"):
        raise UsageError(f"--probes {args.probes!r}: the probes are written as .npz; name a FILE.npz")


def _replayed(patch, args):
    """The drivers of the take `--replay` names (checked against the patch); `--seconds` defaults
    to the take's length."""
    from ..devices.replay import replay_drivers     # takes (jsonschema, headers) only when replayed
    try:
        take, replayed = replay_drivers(patch, args.replay)
    except DeviceError as exc:
        raise UsageError(str(exc)) from None
    if args.seconds is None and take.frames:
        args.seconds = take.seconds
    return replayed


def _open_sink(patch, args):
    """The FileSink of `--out` and `--probes`, both checked first."""
    stem = os.path.splitext(os.path.basename(args.patch))[0]
    out = args.out or f"{stem}.wav"
    channels = audio_channels(patch)
    inputs = input_files(patch, args.replay)
    audio_path = check_output("--out", out, inputs) if channels or args.out else None
    probes_path = None
    if args.probe:
        probes_path = check_output("--probes", args.probes or os.path.splitext(out)[0] + ".npz", inputs)
        if audio_path and channels and same_file(os.path.abspath(probes_path), os.path.abspath(audio_path)):
            raise UsageError(f"--probes {probes_path!r} and --out name the same file")
    if not channels and not args.probe:
        print(f"hapticgraph: {args.patch} has no audio_out block and no --probe was given; nothing written",
              file=sys.stderr)
    frames = round(args.seconds * patch.rate)
    try:               # every size known before the first sample: refused, or RF64 for a WAV past 4 GB
        plan = size_outputs(audio_path if channels else None, probes_path, frames, patch.rate, channels,
                            len(args.probe), args.subtype)
        for note in plan.notes:
            print(f"hapticgraph: {note}", file=sys.stderr)
        return FileSink(audio_path if channels else None, probes_path, patch.rate, channels, args.probe,
                        subtype=args.subtype, container=plan.container)
    except AudioFileError as exc:
        raise UsageError(f"--out {out!r}: {exc}") from None
    except OSError as exc:
        raise UsageError(f"cannot write beside {out!r}: {exc.strerror or exc}") from None


def _report(args, sink, streamed, problem, failure, written, errors):
    """Print what was rendered and written (nothing with --quiet), and why it stopped; the exit
    status."""
    rate = streamed.rate
    seconds = streamed.samples / rate
    where = ", ".join(path for path, _ in written) or "-"
    if not args.quiet:
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
        return 128 + streamed.stopped
    if problem:
        print(f"hapticgraph: stopped after {seconds:.3f} s: {problem}; the force sent was zeroed first, "
              f"what was rendered is written ({held})", file=sys.stderr)
        return 1
    return 1 if errors else 0


def _render_to(sink, patch, args, choices, replayed, stop):
    """Stream the render into the sink; (Streamed, safety problem, output failure), or None when
    interrupted before rendering began (the sink discarded). `stop`: the process's Interrupt,
    rendering from the first block on."""
    try:
        drivers = replayed if replayed is not None else open_drivers(patch, choices)
        streamed = stream(patch, args.seconds, sink, probes=args.probe, engine=args.engine,
                          progress=False if args.quiet else None, drivers=drivers, safety=True, stop=stop)
    except (PlanError, DeviceError) as exc:
        sink.discard()
        raise UsageError(str(exc)) from None
    except PatchError:                     # found while compiling (a plugin numba cannot compile)
        sink.discard()
        raise
    except KeyboardInterrupt:              # raised only before rendering began (Interrupt)
        sink.discard()
        return None
    except SafetyStop as exc:
        return exc.streamed, str(exc), None
    except OutputError as exc:
        return exc.streamed, None, str(exc)
    except BaseException:                  # a bug: keep what was made, then let main report it
        sink.close()
        raise
    try:
        sink.drain()        # the sink's thread writes the last blocks: a failure there is told as any other
    except OutputError as exc:
        return streamed, None, str(exc)
    return streamed, None, None
