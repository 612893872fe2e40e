"""Real-time play through the sound card (sounddevice / PortAudio): `hapticgraph play`.

The sound card's clock drives the patch: PortAudio calls `Player._callback` every block of
`blocksize` frames, and the callback only runs `session.process(frames)` — the session is a
hapticgraph.Session, the public door — (the drivers exchange
inputs and forces, the compiled kernel — which releases the GIL — runs the block, the output is
checked) and copies the audio columns into PortAudio's buffer, converting float64 to float32 in
place. Everything it touches is preallocated; a recording is copied into ring buffers that a
writer thread empties; a reload (`--watch`) is compiled on another thread (Session.swap) and
applied by the callback at a block boundary, like every queued edit (`--console`).

Counted and reported at the end: callbacks, xruns (PortAudio's status flags: output underflow
and overflow, input underflow and overflow, priming), the callback load (time spent in the
callback / the block's period: mean, 99th percentile, maximum) and callbacks over their period.

Stopping: `--seconds` ends exactly after that many samples, like `run` (no fade); Ctrl-C (or
SIGTERM) fades the output out over `fade` seconds (5 ms) while the patch keeps running, then
stops; a SafetyStop (NaN, infinity, runaway, lost device) has already sent zero force for the
faulty block — the audio then fades from its last good sample to silence over `fade` seconds, and
the run stops with the reason.
"""
import threading
import time

import numpy as np

from ..graph.engine import Driver, SafetyStop

# sound_cards' and watch's names are re-exported: the play command and the tests find them here
from .sound_cards import AudioError, find_device, rescan, sound_cards, sounddevice
from .watch import Watcher, carry_state, plugin_files, reload_drivers

PLAY, FADE_RUN, FADE_HOLD, DONE = 0, 1, 2, 3
FLAGS = ("output_underflow", "output_overflow", "input_underflow", "input_overflow", "priming_output")


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
    """What the callback reads of the session's current patch (a swap changes it): its block
    size, audio channels and live inputs."""

    def __init__(self, session, out_channels):
        self.swaps = session.swaps
        self.bs = session.blocksize
        self.ch = min(session.channels, out_channels)
        self.live = [d for d in session.drivers.values() if isinstance(d, LiveInput)]


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
    """Plays a hapticgraph.Session through a PortAudio stream; `run()` blocks until the end and
    returns a Report.

    `device`/`input_device`: PortAudio indices (None: default); `latency`: 'low', 'high' or
    seconds; `seconds`: stop after exactly that many samples (None: until Ctrl-C or a stop);
    `recorder`: a hapticgraph.devices.record.Recorder; `fade`: the mute ramp in seconds;
    `probe_out`: a hapticgraph.devices.osc.ProbeSender fed the session's probes after each block.
    """

    def __init__(self, session, device=None, blocksize=128, latency="low", input_device=None,
                 seconds=None, recorder=None, fade=0.005, out_channels=None, probe_out=None):
        self.sd = sounddevice()
        self.rate = session.rate
        self.blocksize = int(blocksize)
        if session.blocksize < self.blocksize:
            raise ValueError("the session's block size is smaller than the stream's")
        self.session = session
        self.out_channels = max(1, out_channels or session.channels)
        self.bound = Bound(session, self.out_channels)
        self.recorder = recorder
        self.probe_out = probe_out
        if probe_out is not None:
            probe_out.start(self.rate, session.channels, list(session.probes), None)
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
        self.stream = self._open_stream(device, input_device, latency)
        lat = self.stream.latency
        self.latency = float(lat[1] if isinstance(lat, (tuple, list)) else lat)
        self.device_name = self._device_name()

    def _open_stream(self, device, input_device, latency):
        """A duplex stream when the patch has live inputs, else an output stream."""
        sd = self.sd
        try:
            if self.bound.live:
                in_ch = 1 + max(d.channel for d in self.bound.live)
                return sd.Stream(samplerate=self.rate, blocksize=self.blocksize, device=(input_device, device),
                                 channels=(in_ch, self.out_channels), dtype="float32", latency=latency,
                                 callback=self._duplex, finished_callback=self.done.set)
            return sd.OutputStream(samplerate=self.rate, blocksize=self.blocksize, device=device,
                                   channels=self.out_channels, dtype="float32", latency=latency,
                                   callback=self._output, finished_callback=self.done.set)
        except (sd.PortAudioError, ValueError) as exc:
            raise AudioError(f"cannot open the sound card at {self.rate:g} Hz, {self.out_channels} channel(s), "
                             f"blocks of {self.blocksize}: {exc}") from None

    def _device_name(self):
        sd = self.sd
        dev = self.stream.device
        index = dev[1] if isinstance(dev, (tuple, list)) else dev
        try:
            info = sd.query_devices(index)
            return f"{info['name']!r} ({sd.query_hostapis(info['hostapi'])['name']})"
        except Exception:  # noqa: BLE001
            return f"device {index}"

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
            if self.session.pending:
                self._apply()
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
        mode, pos = self.mode, 0
        if mode == PLAY and self.stop_requested:
            mode, self.fade_pos = FADE_RUN, 0
        while pos < frames:
            if mode == PLAY or mode == FADE_RUN:
                n, mode = self._play(indata, outdata, pos, frames, mode)
            elif mode == FADE_HOLD:
                n, mode = self._hold(outdata, pos, frames - pos)
            else:
                outdata[pos:].fill(0.0)
                self.done.set()
                n = frames - pos
            pos += n
        self.mode = mode

    def _play(self, indata, outdata, pos, frames, mode):
        """Run the patch for the next frames (at most a session block) from `pos` on; (frames
        done, next mode). A SafetyStop or the end of `--seconds` does none and changes the mode."""
        b, rec_ = self.bound, self.recorder
        n = frames - pos
        if self.remaining is not None:
            if self.remaining == 0:
                return 0, DONE
            n = min(n, self.remaining)
        n = min(n, b.bs)
        if indata is not None:
            block = indata if (pos == 0 and n == frames) else indata[pos:pos + n]
            for d in b.live:
                d.block = block
        session = self.session
        try:
            rec = session.process(n)
        except SafetyStop as exc:
            self.problem = str(exc)
            if rec_ is not None:
                rec_.push_inputs(session.inputs, None)
            if mode == PLAY:
                self.fade_pos = 0
            return 0, FADE_HOLD
        out = outdata if (pos == 0 and n == frames) else outdata[pos:pos + n]
        ch = b.ch
        if ch == outdata.shape[1]:
            np.copyto(out, rec[:, :ch], casting="same_kind")
        else:
            out.fill(0.0)
            if ch:
                np.copyto(out[:, :ch], rec[:, :ch], casting="same_kind")
        if mode == FADE_RUN:
            mode = self._fade_out(out, n)
        np.copyto(self.last, out[n - 1])
        if rec_ is not None:
            rec_.push_inputs(session.inputs, session.forces)
            rec_.push_audio(out)
        if self.probe_out is not None:
            self.probe_out.write(rec)
        self.frames_done += n
        if self.remaining is not None:
            self.remaining -= n
        return n, mode

    def _fade_out(self, out, n):
        """Ramp the block just played down (Ctrl-C: the patch keeps running under the fade)."""
        k = min(n, self.nfade - self.fade_pos)
        out[:k] *= self.ramp[self.fade_pos:self.fade_pos + k, None]
        out[k:] = 0.0
        self.fade_pos += k
        return DONE if self.fade_pos >= self.nfade else FADE_RUN

    def _hold(self, outdata, pos, n):
        """After a SafetyStop: fade the last good sample to silence; (frames done, next mode)."""
        n = min(n, self.nfade - self.fade_pos)
        out = outdata[pos:pos + n]
        np.multiply(self.ramp[self.fade_pos:self.fade_pos + n, None], self.last, out=out)
        self.fade_pos += n
        mode = DONE if self.fade_pos >= self.nfade else FADE_HOLD
        if self.recorder is not None:
            self.recorder.push_audio(out)
        return n, mode

    def _apply(self):
        """The session's queued changes, now, before the live inputs are handed this block; a
        swapped-in patch is bound afresh."""
        session = self.session
        session.apply()
        if session.swaps != self.bound.swaps:
            self.bound = Bound(session, self.out_channels)
            if self.recorder is not None:
                self.recorder.session_changed(session.program)
            self.swaps += 1

    # -- the control side ------------------------------------------------------------------------
    def request_stop(self):
        """Fade out and stop (what Ctrl-C does)."""
        self.stop_requested = True

    def run(self, on_tick=None, stop=None):
        """Start the stream and block until the end; Ctrl-C (KeyboardInterrupt), or a signal
        noted by `stop` (its `signum` set, as graph.engine.StopRequest's: checked every 50 ms),
        fades out — asked before the stream started, no sound is made. Returns a Report."""
        session = self.session
        session.start()          # drivers start here, before the first callback

        def asked():
            return stop is not None and stop.signum is not None
        try:
            began = time.perf_counter()
            stopped = asked()
            try:
                if not stopped:
                    self.stream.start()
                    while not (self.done.wait(0.05) or stopped):
                        stopped = asked()
                        if on_tick is not None and not stopped:
                            on_tick()
            except KeyboardInterrupt:
                stopped = True
            if stopped:
                self.interrupted = True
                self.request_stop()
                if self.stream.active:
                    self.done.wait(0.5 + 4 * self.blocksize / self.rate + self.nfade / self.rate)
            self.wall = time.perf_counter() - began
        finally:
            try:
                self.stream.stop()
            except Exception:  # noqa: BLE001 - a stream already finished
                pass
            self.stream.close()
            if self.recorder is not None:      # the take and the WAV complete before any device closes
                self.recorder.close()
            self.session.close()               # each device within its deadline (graph.engine.stop_driver)
            if self.probe_out is not None:
                self.probe_out.close()
        if self.error is not None:
            raise self.error
        return Report(self)


__all__ = ["AudioError", "Bound", "LiveInput", "Player", "Report", "Watcher", "carry_state", "find_device",
           "plugin_files", "reload_drivers", "rescan", "sound_cards", "sounddevice"]
