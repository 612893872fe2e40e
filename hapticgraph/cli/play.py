"""`hapticgraph play` (real time through the sound card, with --record, --replay, --watch and
--console) and `hapticgraph devices` (the sound cards and HID devices this machine sees).

Ctrl-C (or SIGTERM) while loading or compiling ends play at once (`hapticgraph: interrupted`);
from the moment the session is open — its devices started — it is a request: the sound fades out,
the take (--record) is finished and every device stops within its deadline, then one line says
so, exit status 130 (143 for SIGTERM)."""
import signal
import sys

from .common import UsageError, audio_channels, check_output, device_choices, input_files
from .sizes import size_take
from ..devices import DeviceError, audio, check_choices
from ..devices.table import driver_origins, input_kind
from ..devices.record import Recorder
from ..devices.replay import replay_drivers
from ..graph.patch import load
from ..graph.program import PlanError
from ..session import Session


def cmd_play(args):
    """Real-time play: the sound card's clock drives the kernel block by block."""
    latency = _check_options(args)
    if args.replay and args.device:
        raise UsageError("--replay feeds every device from the take; it takes no --device")
    choices = device_choices(args.device)
    if args.replay and args.watch:
        raise UsageError("--replay and --watch do not go together")
    patch = load(args.patch, overrides=args.overrides)
    if args.record:
        _check_record(args, patch)
    try:
        check_choices(patch, choices)
    except DeviceError as exc:
        raise UsageError(str(exc)) from None
    try:
        audio.sounddevice()
    except audio.AudioError as exc:
        print(f"hapticgraph: error: {exc}", file=sys.stderr)
        return 1
    args.interrupt.take(signal.SIGTERM)           # a kill stops it as Ctrl-C does
    session, live, out_dev, in_dev = _open_session(args, patch, choices)
    recorder = _open_recorder(args, patch, choices, session, live) if args.record else None
    try:
        player = audio.Player(session, device=out_dev, blocksize=args.blocksize, latency=latency,
                              input_device=in_dev, seconds=args.seconds, fade=args.fade, recorder=recorder,
                              probe_out=_probe_out(args))
    except audio.AudioError as exc:
        if recorder is not None:
            recorder.close()
        session.close()
        raise UsageError(str(exc)) from None
    watcher = _start_watcher(args, player) if args.watch else None
    report = _run(args, patch, player, watcher)
    return _report(args, player, report)


def _check_record(args, patch):
    """--record TAKE writes TAKE.hgrec and TAKE.wav: neither may be a file this play reads (the
    patch, a plugin, an audio_in file, the take --replay plays), and with --seconds the WAV must
    fit its format and the disk (cli/sizes.py), checked before any device opens."""
    from ..devices.take import take_paths
    inputs = input_files(patch, args.replay)
    for path in take_paths(args.record):
        check_output("--record", path, inputs, "play")
    if args.seconds is not None:
        size_take(take_paths(args.record)[1], round(args.seconds * patch.rate), patch.rate, audio_channels(patch))


def _check_options(args):
    """Check the numbers play takes; the latency PortAudio is asked for."""
    if args.blocksize < 1 or args.blocksize > 1 << 15:
        raise UsageError(f"--blocksize {args.blocksize}: expected a number of frames from 1 to 32768")
    if args.seconds is not None and args.seconds <= 0:
        raise UsageError("--seconds must be positive")
    if not 0 < args.fade <= 1:
        raise UsageError("--fade must be in (0, 1] seconds")
    if args.probe and not args.osc_out:
        raise UsageError("--probe in play names what --osc-out sends; give --osc-out [HOST:]PORT too "
                         "(to keep probes in a file, render with `hapticgraph run --probe`)")
    if args.osc_out and not args.probe:
        raise UsageError("--osc-out sends probes: name at least one with --probe BLOCK.PORT")
    if not 0 < args.osc_rate <= 1000:
        raise UsageError(f"--osc-rate {args.osc_rate:g}: expected messages per second in (0, 1000]")
    if args.osc_out:
        from ..devices.osc import parse_target
        try:
            args.osc_target = parse_target(args.osc_out)
        except ValueError as exc:
            raise UsageError(str(exc)) from None
    return _parse_latency(args.latency)


def _probe_out(args):
    """--osc-out's ProbeSender (sending on a thread of its own), or None."""
    if not args.osc_out:
        return None
    from ..devices.osc import ProbeSender
    host, port = args.osc_target
    try:
        return ProbeSender(None, host, port, rate=args.osc_rate)
    except OSError as exc:
        raise UsageError(f"--osc-out {args.osc_out!r}: {exc.strerror or exc}") from None


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


def _open_session(args, patch, choices):
    """The play session (hapticgraph.Session; its drivers the take's with --replay): (session,
    live inputs, output device, input device). With --replay, --seconds defaults to the take's
    length. Safety is on, as in `run`: a runaway at 1e3 stops the play."""
    session = None
    try:
        out_dev = audio.find_device(args.audio_device, "output", max(1, audio_channels(patch)))
        drivers = None
        if args.replay:
            take, drivers = replay_drivers(patch, args.replay)
            if args.seconds is None and take.frames:
                args.seconds = take.seconds
        session = Session.open(patch, probes=args.probe, devices=choices, drivers=drivers, blocksize=args.blocksize,
                               editable=args.console, live_input=audio.LiveInput.for_block, runaway=1e3)
        args.interrupt.rendering = True     # the devices are open: a signal is now a request (Player.run)
        live = [d for d in session.drivers.values() if isinstance(d, audio.LiveInput)]
        in_dev = audio.find_device(args.input_device, "input", 1 + max(d.channel for d in live)) if live else None
    except (PlanError, DeviceError, audio.AudioError) as exc:
        if session is not None:
            session.close()
        raise UsageError(str(exc)) from None
    return session, live, out_dev, in_dev


def _open_recorder(args, patch, choices, session, live):
    """The Recorder of --record, each device's driver kind named in the take's header (a block
    played by a controller, midi_note, midi_cc, osc_in: its device's, e.g. midi; an audio_in
    block: live audio input or audio input); a take names no code."""
    kinds = {name: (choices[name].driver if name in choices else spec.get("driver", "simulated"))
             for name, spec in patch.devices.items()}
    kinds.update({d.name: "live audio input" for d in live})
    for inst in patch.blocks.values():      # a block fed from outside: its device's kind, else its own
        feeder = input_kind(inst.cls)
        if feeder is not None and inst.name not in kinds:
            kinds[inst.name] = kinds.get(inst.values.get("device"), feeder.name)
    try:
        return Recorder(args.record, session.program, max(1, session.channels), args.blocksize, kinds=kinds)
    except OSError as exc:
        session.close()
        raise UsageError(f"--record {args.record!r}: {exc.strerror or exc}") from None
    except DeviceError as exc:
        session.close()
        raise UsageError(str(exc)) from None


def _start_watcher(args, player):
    """--watch: reload the patch when its files change (Session.swap keeps the drivers of the
    devices that did not change, and the state of the blocks that did not)."""
    return audio.Watcher(player, args.patch, lambda: load(args.patch, overrides=args.overrides)).start()


def _run(args, patch, player, watcher):
    """Play until the end or a signal (args.interrupt); the player's Report."""
    if args.console:
        from ..console import HELP, Console
        Console(lambda: player.session).start()
        print(f"hapticgraph: {HELP}", file=sys.stderr)
    until = f"for {args.seconds:g} s" if args.seconds else "until Ctrl-C"
    print(f"hapticgraph: playing {patch.name!r} {until} on {player.device_name}", file=sys.stderr)
    try:
        return player.run(stop=args.interrupt)
    finally:
        if watcher is not None:
            watcher.stop()


def _report(args, player, report):
    """Print what was played and recorded, and why it stopped; the exit status."""
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
        return args.interrupt.status()
    return 0


def cmd_devices(args):
    """The drivers a patch may name (the table), sound cards (PortAudio), MIDI ports and HID
    devices (hidapi)."""
    print("Drivers (entry points hapticgraph.drivers):")
    for name, origin in sorted(driver_origins().items()):
        print(f"  {name:10s} {origin}")
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
    from ..devices.midi import port_lines
    print(*port_lines(), sep="\n")
    print("HID devices (hidapi; inputs named from each device's report descriptor):")
    try:
        from ..devices.hid_match import connected, device_lines
        hids = connected()
    except (ImportError, AttributeError) as exc:
        print(f"  unavailable: {exc}")
        return 0
    except Exception as exc:  # noqa: BLE001 - the listing must not crash on a busy device
        print(f"  unavailable: {type(exc).__name__}: {exc}")
        return 0
    for line in device_lines(hids) or ["  none found"]:
        print(line)
    print("Input devices (driver: evdev; the kernel's force feedback):")
    from ..devices import evdev_layout
    found = evdev_layout.connected()
    for line in (evdev_layout.device_lines(found) + evdev_layout.no_kernel_driver(hids, found)) or ["  none found"]:
        print(line)
    return 0
