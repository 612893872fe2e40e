"""Real-time play through the sound card (sounddevice / PortAudio): `hapticgraph play`.

The sound card's clock drives the patch: PortAudio calls `Player._callback` every block of
`blocksize` frames, and the callback only runs `session.process(frames)` (the drivers exchange
inputs and forces, the compiled kernel — which releases the GIL — runs the block, the output is
checked) and copies the audio columns into PortAudio's buffer, converting float64 to float32 in
place. Everything it touches is preallocated; a recording is copied into ring buffers that a
writer thread empties; a reload (`--watch`) is compiled on another thread and swapped in at a
block boundary.

Counted and reported at the end: callbacks, xruns (PortAudio's status flags: output underflow
and overflow, input underflow and overflow, priming), the callback load (time spent in the
callback / the block's period: mean, 99th percentile, maximum) and callbacks over their period.

Stopping: `--seconds` ends exactly after that many samples, like `run` (no fade); Ctrl-C (or
SIGTERM) fades the output out over `fade` seconds (5 ms) while the patch keeps running, then
stops; a SafetyStop (NaN, infinity, runaway, lost device) has already sent zero force for the
faulty block — the audio then fades from its last good sample to silence over `fade` seconds, and
the run stops with the reason.
"""
import copy
import os
import sys
import threading
import time

import numpy as np

from ..graph.engine import Driver, SafetyStop, Session
from .kinds import same as _same

PLAY, FADE_RUN, FADE_HOLD, DONE = 0, 1, 2, 3
FLAGS = ("output_underflow", "output_overflow", "input_underflow", "input_overflow", "priming_output")


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


class LiveInput(Driver):
    """A live input channel of the sound card feeding an audio_in block (no `file`): the callback
    hands it the block's input frames, `fill` copies its channel into the kernel's input column."""

    columns = ("sample",)

    def __init__(self, name, channel=0):
        self.name, self.channel = name, int(channel)
        self.block = None

    @classmethod
    def for_block(cls, inst):
        return cls(inst.name, inst.values["channel"])

    def fill(self, t0, ext):
        block = self.block
        if block is None:
            ext[:, 0] = 0.0
        else:
            np.copyto(ext[:, 0], block[:ext.shape[0], self.channel], casting="same_kind")


class Bound:
    """A session prepared for the callback: its block size, column ranges and live inputs."""

    def __init__(self, session, out_channels):
        self.session = session
        prog = session.prog
        self.bs = session.blocksize
        self.ch = min(prog.channels, out_channels)
        self.f0 = prog.device_records[0][1] if prog.device_records else len(prog.records)
        self.live = [d for d in prog.drivers.values() if isinstance(d, LiveInput)]
        self.carry = []          # (dst, src) array pairs copied at the swap (state kept by --watch)
        self.kept = []


class Report:
    """What a play did: frames, duration, callbacks, xruns by flag, load, why it stopped."""

    def __init__(self, player):
        p = player
        self.rate, self.frames, self.callbacks = p.rate, p.frames_done, p.calls
        self.seconds = p.frames_done / p.rate
        self.flags = dict(p.flag_counts)
        self.xruns = sum(v for k, v in self.flags.items() if k != "priming_output")
        n = min(p.calls, len(p.loads))
        loads = np.sort(p.loads[:n]) if n else np.zeros(1)
        self.load_mean = p.busy / max(p.period_total, 1e-12)
        self.load_p99 = float(loads[min(len(loads) - 1, int(0.99 * len(loads)))])
        self.load_max = float(p.load_max)
        self.late = p.late
        self.problem, self.interrupted = p.problem, p.interrupted
        self.swaps, self.reload_errors = p.swaps, p.reload_errors
        self.latency, self.blocksize, self.device = p.latency, p.blocksize, p.device_name
        self.wall = p.wall
        self.xrun_at = [int(i) for i in p.xrun_at[:p.nxrun]]
        startup = max(1, int(0.1 * p.rate / max(1, p.blocksize)))     # the first 0.1 s
        self.xruns_startup = sum(1 for i in self.xrun_at if i < startup)

    def lines(self, name):
        flags = ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in self.flags.items())
        out = [f"{name}: played {self.seconds:.3f} s (wall {self.wall:.3f} s) at {self.rate:g} Hz on {self.device} in blocks of "
               f"{self.blocksize} ({1e3 * self.blocksize / self.rate:.2f} ms; output latency "
               f"{1e3 * self.latency:.1f} ms)",
               f"  callbacks {self.callbacks}; xruns {self.xruns} ({flags}"
               f"{'; first at callback ' + ', '.join(map(str, self.xrun_at[:5])) if self.xrun_at else ''}); "
               f"callback load mean "
               f"{100 * self.load_mean:.1f}%, p99 {100 * self.load_p99:.1f}%, max {100 * self.load_max:.1f}%; "
               f"{self.late} callback(s) over their period"]
        if self.swaps or self.reload_errors:
            out.append(f"  reloads: {self.swaps} swapped in, {self.reload_errors} refused")
        return out


class Player:
    """Plays a Session through a PortAudio stream; `run()` blocks until the end and returns a Report.

    `device`/`input_device`: PortAudio indices (None: default); `latency`: 'low', 'high' or
    seconds; `seconds`: stop after exactly that many samples (None: until Ctrl-C or a stop);
    `recorder`: a hapticgraph.devices.record.Recorder; `fade`: the mute ramp in seconds.
    """

    def __init__(self, session, device=None, blocksize=128, latency="low", input_device=None,
                 seconds=None, recorder=None, fade=0.005, out_channels=None):
        self.sd = sounddevice()
        self.rate = session.rate
        self.blocksize = int(blocksize)
        if session.blocksize < self.blocksize:
            raise ValueError("the session's block size is smaller than the stream's")
        self.out_channels = max(1, out_channels or session.prog.channels)
        self.bound = Bound(session, self.out_channels)
        self.pending = None
        self.swapped = threading.Event()
        self.recorder = recorder
        self.remaining = None if seconds is None else int(round(seconds * self.rate))
        self.nfade = max(1, int(round(fade * self.rate)))
        self.ramp = 1.0 - np.arange(1, self.nfade + 1) / self.nfade      # ends at exactly 0
        self.last = np.zeros(self.out_channels, dtype=np.float32)
        self.mode, self.fade_pos = PLAY, 0
        self.stop_requested = False
        self.done = threading.Event()
        self.problem, self.interrupted, self.error = None, False, None
        self.frames_done = self.calls = self.late = 0
        self.busy = self.period_total = self.load_max = 0.0
        self.loads = np.zeros(1 << 16)
        self.flag_counts = dict.fromkeys(FLAGS, 0)
        self.xrun_at = np.full(64, -1, dtype=np.int64)    # callback index of the first xruns
        self.nxrun = 0
        self.swaps = self.reload_errors = 0
        self.wall = 0.0
        sd = self.sd
        live = bool(self.bound.live)
        try:
            if live:
                in_ch = 1 + max(d.channel for d in self.bound.live)
                self.stream = sd.Stream(samplerate=self.rate, blocksize=self.blocksize, device=(input_device, device),
                                        channels=(in_ch, self.out_channels), dtype="float32", latency=latency,
                                        callback=self._duplex, finished_callback=self.done.set)
            else:
                self.stream = sd.OutputStream(samplerate=self.rate, blocksize=self.blocksize, device=device,
                                              channels=self.out_channels, dtype="float32", latency=latency,
                                              callback=self._output, finished_callback=self.done.set)
        except (sd.PortAudioError, ValueError) as exc:
            raise AudioError(f"cannot open the sound card at {self.rate:g} Hz, {self.out_channels} channel(s), "
                             f"blocks of {self.blocksize}: {exc}") from None
        lat = self.stream.latency
        self.latency = float(lat[1] if isinstance(lat, (tuple, list)) else lat)
        dev = self.stream.device
        index = dev[1] if isinstance(dev, (tuple, list)) else dev
        try:
            info = sd.query_devices(index)
            self.device_name = f"{info['name']!r} ({sd.query_hostapis(info['hostapi'])['name']})"
        except Exception:  # noqa: BLE001
            self.device_name = f"device {index}"

    # -- the audio thread ------------------------------------------------------------------------
    def _output(self, outdata, frames, time_info, status):
        self._callback(None, outdata, frames, status)

    def _duplex(self, indata, outdata, frames, time_info, status):
        self._callback(indata, outdata, frames, status)

    def _callback(self, indata, outdata, frames, status):
        start = time.perf_counter()
        try:
            if status:
                for name in FLAGS:
                    if getattr(status, name):
                        self.flag_counts[name] += 1
                if self.nxrun < len(self.xrun_at) and (status.output_underflow or status.output_overflow
                                                       or status.input_underflow or status.input_overflow):
                    self.xrun_at[self.nxrun] = self.calls
                    self.nxrun += 1
            if self.pending is not None:
                self._swap()
            self._fill(indata, outdata, frames)
        except Exception as exc:  # noqa: BLE001 - never let an error kill the audio thread silently
            outdata.fill(0.0)
            if self.error is None:
                self.error = exc
            self.mode = DONE
            self.done.set()
        busy = time.perf_counter() - start
        period = frames / self.rate
        load = busy / period
        self.loads[self.calls & 0xFFFF] = load
        self.calls += 1
        self.busy += busy
        self.period_total += period
        if load > self.load_max:
            self.load_max = load
        if load > 1.0:
            self.late += 1

    def _fill(self, indata, outdata, frames):
        b, rec_ = self.bound, self.recorder
        mode, pos = self.mode, 0
        if mode == PLAY and self.stop_requested:
            mode, self.fade_pos = FADE_RUN, 0
        while pos < frames:
            n = frames - pos
            if mode == PLAY or mode == FADE_RUN:
                if self.remaining is not None:
                    if self.remaining == 0:
                        mode = DONE
                        continue
                    n = min(n, self.remaining)
                if n > b.bs:
                    n = b.bs
                if indata is not None:
                    block = indata if (pos == 0 and n == frames) else indata[pos:pos + n]
                    for d in b.live:
                        d.block = block
                session = b.session
                try:
                    rec = session.process(n)
                except SafetyStop as exc:
                    self.problem = str(exc)
                    if rec_ is not None:
                        rec_.push_inputs(session.ext[:n], None)
                    if mode == PLAY:
                        self.fade_pos = 0
                    mode = FADE_HOLD
                    continue
                out = outdata if (pos == 0 and n == frames) else outdata[pos:pos + n]
                ch = b.ch
                if ch == outdata.shape[1]:
                    np.copyto(out, rec[:, :ch], casting="same_kind")
                else:
                    out.fill(0.0)
                    if ch:
                        np.copyto(out[:, :ch], rec[:, :ch], casting="same_kind")
                if mode == FADE_RUN:
                    k = min(n, self.nfade - self.fade_pos)
                    out[:k] *= self.ramp[self.fade_pos:self.fade_pos + k, None]
                    out[k:] = 0.0
                    self.fade_pos += k
                    if self.fade_pos >= self.nfade:
                        mode = DONE
                np.copyto(self.last, out[n - 1])
                if rec_ is not None:
                    rec_.push_inputs(session.ext[:n], rec[:, b.f0:])
                    rec_.push_audio(out)
                self.frames_done += n
                if self.remaining is not None:
                    self.remaining -= n
            elif mode == FADE_HOLD:
                n = min(n, self.nfade - self.fade_pos)
                out = outdata[pos:pos + n]
                np.multiply(self.ramp[self.fade_pos:self.fade_pos + n, None], self.last, out=out)
                self.fade_pos += n
                if self.fade_pos >= self.nfade:
                    mode = DONE
                if rec_ is not None:
                    rec_.push_audio(out)
            else:
                outdata[pos:].fill(0.0)
                self.done.set()
                n = frames - pos
            pos += n
        self.mode = mode

    def _swap(self):
        new, old = self.pending, self.bound
        for dst, src in new.carry:
            np.copyto(dst, src)
        new.session.t = old.session.t
        new.session.started = True
        self.bound = new
        self.pending = None
        if self.recorder is not None:
            self.recorder.session_changed(new.session)
        self.swaps += 1
        self.swapped.set()

    # -- the control side ------------------------------------------------------------------------
    def offer(self, bound, timeout=5.0):
        """Swap `bound` in at the next block boundary; True once it plays."""
        self.swapped.clear()
        self.pending = bound
        if not self.swapped.wait(timeout):
            if self.pending is bound:
                self.pending = None
                return False
        return True

    def request_stop(self):
        """Fade out and stop (what Ctrl-C does)."""
        self.stop_requested = True

    def run(self, on_tick=None):
        """Start the stream and block until the end; Ctrl-C fades out. Returns a Report."""
        session = self.bound.session
        session.start()          # drivers start here, before the first callback
        try:
            self.stream.start()
            began = time.perf_counter()
            try:
                while not self.done.wait(0.05):
                    if on_tick is not None:
                        on_tick()
            except KeyboardInterrupt:
                self.interrupted = True
                self.request_stop()
                self.done.wait(0.5 + 4 * self.blocksize / self.rate + self.nfade / self.rate)
            self.wall = time.perf_counter() - began
        finally:
            try:
                self.stream.stop()
            except Exception:  # noqa: BLE001 - a stream already finished
                pass
            self.stream.close()
            self.bound.session.stop()
            if self.recorder is not None:
                self.recorder.close()
        if self.error is not None:
            raise self.error
        return Report(self)


# -- --watch: reload the patch, keep the state of unchanged blocks -------------------------------------
def _incoming(patch):
    into = {}
    for c in patch.connections:
        into.setdefault(c.dst.block, []).append(str(c))
    return {k: sorted(v) for k, v in into.items()}


def carry_state(old, new):
    """(dst, src) array pairs that give `new` (a Program) the current state of every block of
    `old` whose type, parameters and incoming connections did not change: its State slots, its
    buffers (ring buffers stay valid because the shared sample counter carries over) and its
    cells' positions and velocities (Program.state_views). Also returns the names kept."""
    if old.rate != new.rate:
        return [], []
    into_old, into_new = _incoming(old.patch), _incoming(new.patch)
    pairs, kept = [], []
    for name in new.patch.order:
        was = old.patch.blocks.get(name)
        if was is None or was.cls is not new.patch.blocks[name].cls:
            continue
        if not _same(old.block_values(name), new.block_values(name)):
            continue
        if into_old.get(name, []) != into_new.get(name, []):
            continue
        views_old, views_new = old.state_views(name), new.state_views(name)
        if len(views_old) != len(views_new):
            continue
        same_shape = [(vn, vo) for vo, vn in zip(views_old, views_new) if vo.shape == vn.shape]
        pairs += same_shape
        if len(same_shape) == len(views_new):
            kept.append(name)
    return pairs, kept


def reload_drivers(old_patch, new_patch, old_drivers, choices=None, live_input=None):
    """Drivers for `new_patch`: the running ones of devices (and audio inputs) whose driver kind
    keeps them (by default: the entry did not change); the others are opened. Returns (drivers,
    opened, unused old ones)."""
    from ..graph.patch import driver_of
    from . import open_drivers
    from .kinds import input_kind, kinds_of
    kinds, old_kinds = kinds_of(new_patch), kinds_of(old_patch)
    keep, changed_devices, changed_inputs = {}, {}, {}
    for name, spec in new_patch.devices.items():
        old = old_patch.devices.get(name)
        kind = driver_of(spec, kinds)
        if (old is not None and name in old_drivers and kind is not None
                and driver_of(old, old_kinds) is kind and kind.kept(old, spec)):
            keep[name] = old_drivers[name]
        else:
            changed_devices[name] = spec
    for inst in new_patch.blocks.values():
        feeder = input_kind(inst.cls)
        if feeder is None:
            continue
        old = old_patch.blocks.get(inst.name)
        if old is not None and inst.name in old_drivers and feeder.kept(old, inst):
            keep[inst.name] = old_drivers[inst.name]
        else:
            changed_inputs[inst.name] = inst
    view = copy.copy(new_patch)
    view.devices = changed_devices
    view.blocks = changed_inputs
    opened = open_drivers(view, {k: v for k, v in (choices or {}).items() if k in changed_devices}, live_input)
    drivers = dict(keep)
    drivers.update(opened)
    unused = [d for name, d in old_drivers.items() if drivers.get(name) is not d]
    return drivers, opened, unused


def plugin_files(patch):
    """The source files of the plugin block types a patch loaded (its `plugins:`)."""
    files = set()
    registry = getattr(patch, "registry", None)
    for name, cls in (registry.types.items() if registry is not None else ()):
        if not str(registry.origin.get(name, "")).startswith("plugin"):
            continue
        module = sys.modules.get(cls.__module__)
        path = getattr(module, "__file__", None)
        if path:
            files.add(os.path.realpath(path))
    return sorted(files)


class Watcher:
    """Polls the modification times of a patch file and of its plugin files; on a change, loads
    and compiles the new patch on its own thread (an edited plugin is imported again) and hands it
    to the player, keeping the state of every unchanged block. A patch with errors, or a patch or
    plugin file that was deleted, is reported in one line and the old patch keeps playing."""

    def __init__(self, player, path, make_session, interval=0.25, stream=None):
        self.player, self.path, self.make_session = player, path, make_session
        self.interval, self.stream = interval, stream or sys.stderr
        self.files = [os.fspath(path)] + plugin_files(player.bound.session.prog.patch)
        self.stamps = {f: self._mtime(f) for f in self.files}
        self.missing = set()
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._loop, name="hapticgraph-watch", daemon=True)

    @staticmethod
    def _mtime(path):
        try:
            st = os.stat(path)
            return (st.st_mtime_ns, st.st_size, st.st_ino)
        except OSError:
            return None

    def start(self):
        self.thread.start()
        return self

    def stop(self):
        self._stop.set()

    def _loop(self):
        while not self._stop.wait(self.interval):
            try:
                self.poll()
            except Exception as exc:  # noqa: BLE001 - the watcher must not die silently
                print(f"hapticgraph: --watch: {type(exc).__name__}: {exc}; still playing", file=self.stream)

    def poll(self):
        """Look at the files once; reload if one changed. True if a reload was swapped in."""
        changed, gone = [], []
        for f in self.files:
            m = self._mtime(f)
            if m == self.stamps.get(f):
                continue
            self.stamps[f] = m
            (gone if m is None else changed).append(f)
        for f in gone:
            if f not in self.missing:
                self.missing.add(f)
                what = "patch" if f == self.files[0] else "plugin"
                print(f"hapticgraph: the {what} file {os.path.basename(f)} was deleted; still playing the "
                      "previous version", file=self.stream)
        self.missing -= set(changed)
        if not changed or self.missing:
            return False
        for f in changed:
            if f != self.files[0]:
                _forget_module(f)
        ok = self.reload()
        if ok:
            self.files = [self.files[0]] + plugin_files(self.player.bound.session.prog.patch)
            for f in self.files:
                self.stamps.setdefault(f, self._mtime(f))
        return ok

    def reload(self):
        from ..graph.errors import PatchError
        player = self.player
        old = player.bound.session
        switch = sys.getswitchinterval()
        sys.setswitchinterval(min(switch, 0.0002))   # let the audio callback in while compiling
        try:
            session, opened, unused = self.make_session(old)
            bound = Bound(session, player.out_channels)
            bound.carry, bound.kept = carry_state(old.prog, session.prog)
            for d in opened.values():
                d.start(session.rate)
        except PatchError as exc:
            player.reload_errors += 1
            print(f"hapticgraph: {os.path.basename(self.path)} changed but has errors; still playing the "
                  "previous version:", file=self.stream)
            for p in exc.problems:
                print(f"  {p}", file=self.stream)
            return False
        except Exception as exc:  # noqa: BLE001 - a bad reload never stops the music
            player.reload_errors += 1
            print(f"hapticgraph: cannot reload {os.path.basename(self.path)}: {exc}; still playing the "
                  "previous version", file=self.stream)
            return False
        finally:
            sys.setswitchinterval(switch)
        if not player.offer(bound):
            print("hapticgraph: reload not swapped in (the stream stopped)", file=self.stream)
            return False
        for d in unused:
            d.stop()
        kept = sorted(bound.kept)
        print(f"hapticgraph: reloaded {os.path.basename(self.path)} at {old.t / old.rate:.3f} s; kept the "
              f"state of {len(kept)} block(s){': ' + ', '.join(kept) if kept else ''}", file=self.stream)
        return True


def _forget_module(path):
    """Drop the imported module of an edited plugin file, so the reload imports it afresh (the
    playing kernel keeps the functions it was compiled from)."""
    for name, module in list(sys.modules.items()):
        file = getattr(module, "__file__", None)
        if file and os.path.realpath(file) == path:
            del sys.modules[name]


def play_session(patch, drivers, blocksize, probes=(), editable=False):
    """The Session play runs (safety on: runaway at 1e3, as `run`); `editable`: cells can be
    locked, unlocked and cut while playing (lattices on the CSR path)."""
    return Session(patch, probes, drivers, "compiled", blocksize=blocksize, runaway=1e3, editable=editable)
