"""HID devices (`driver: hid`): gesture devices (gamepads, mice) and force-feedback devices
read and driven through hidapi, described by a profile (hapticgraph.devices.hid_profiles).

    devices:
      paddle: {driver: hid, profile: haptic_1dof, max_force: 2.0}
      pad:    {driver: hid, profile: gamepad, vendor_id: 0x054c, product_id: 0x05c4}
      m:      {driver: hid, profile: my_mouse.yaml, path: "/dev/hidraw3"}

How values reach the kernel
    A reader thread reads reports with `read(size, timeout_ms)` — never without a timeout, so it
    notices a stop or a silent device within one read timeout (2 report intervals, at most
    20 ms) — decodes each into SI values (the velocity estimated if the device does not report
    it) and writes them into a preallocated ring of rows. At each block boundary `fill` copies
    them into the kernel's input buffer. Values are HELD, not interpolated: interpolating needs
    the next report, which adds a report interval of latency to the haptic loop, and latency is
    what limits the stiffness a haptic coupling can render stably; a held value adds none.
    The velocity comes from the estimator (smoothed), never from differencing the steps.

    Two ways of timing, chosen by the transport:
    * live (hidapi): the newest report at the block boundary is held over the whole block;
    * stamped (ReplayTransport in virtual time, for tests and offline re-rendering): every report
      carries its time stamp and each sample gets the newest report stamped at or before it;
      `fill` waits for the reader to have read past the block, so the render does not depend on
      the machine's speed nor on the block size.

Velocity estimate (profile `velocity: estimate`)
    v_raw = (x_k − x_{k−1}) / interval, the backward difference over the report interval, then
    v_k = v_{k−1} + a·(v_raw − v_{k−1}) with a = 1 − exp(−2π·velocity_cutoff·interval). Devices
    that report only on change (mice, gamepads) send nothing when still: after two intervals
    without a report the estimator takes a step with no motion (v_raw = 0), and again every
    two intervals, so v decays to 0 (exactly 0 below 1 nm/s). The first report gives v_raw = 0.

How forces reach the device
    `send` takes the LAST sample of the block's force (the most recent: the least delay; a block
    mean would add half a block of delay), makes NaN/±inf 0 and clamps it to max_force (the
    profile's, or the device entry's if lower), and builds one output report. Live, a writer
    thread writes it (hidapi's write blocks for a USB frame; it must not block the audio
    callback): if blocks come faster than the device takes reports, only the newest is written.
    Stamped, it is written at once (deterministic). `stop` always writes a zero force last.

A device is lost (the driver's `lost` says why; the session sends zero force and stops) when a
read or a write fails (unplugged), or, for a profile with `input.timeout`, when no report came
for longer than that. Devices that report only on change have no timeout: silence is stillness.
"""
import math
import threading
import time

import numpy as np

from ..graph.engine import Driver
from ..graph.errors import PatchError
from .hid_profiles import MAX_FORCE, find_profile, load_profile, shipped_profiles
from .kinds import HidKind
from .simulated import force_limit

RING = 512                  # reports held between the reader thread and the kernel
MAX_READ_MS = 20            # the longest a read waits, so the thread always notices a stop
LOOKAHEAD = 0.25            # s: how far a stamped reader may read ahead of the render
_REPORT, _LOSS = 0, 1


def _error(message):
    from . import DeviceError    # imported late: this module is imported by the package's __init__
    return DeviceError(message)


def _hid_module():
    try:
        import hid
    except ImportError:
        raise _error("the HID driver needs the hidapi package: pip install 'hapticgraph[hid]'") from None
    if not hasattr(hid, "device"):
        raise _error("the `hid` module found is not hidapi's (PyPI `hid` and `hidapi` share the name): "
                     "pip uninstall hid, then pip install hidapi")
    return hid


# -- transports ------------------------------------------------------------------------------------

class Transport:
    """How the driver talks to a device. `read(size, timeout_ms)` returns one report (bytes;
    b"" when nothing came within the timeout) and raises OSError when the device is gone;
    `write(data)` sends a report (first byte the report id, 0 if unnumbered). `clock()` is the
    time the transport's reports are stamped with [s]; `virtual` says it is not the wall clock
    (stamped timing, see the module's doc)."""

    virtual = False

    def open(self):
        pass

    def read(self, size, timeout_ms):
        raise NotImplementedError

    def write(self, data):
        raise NotImplementedError

    def close(self):
        pass

    def clock(self):
        return time.monotonic()


class HidapiTransport(Transport):
    """A real device through hidapi (PyPI `hidapi`), opened by path, or vendor/product id and serial."""

    def __init__(self, vendor_id, product_id, serial=None, path=None):
        self.vendor_id, self.product_id, self.serial, self.path = vendor_id, product_id, serial, path
        self.dev = None

    def describe(self):
        if self.path:
            return f"HID device at {self.path}"
        return f"HID device {self.vendor_id:04x}:{self.product_id:04x}" + (
            f" with serial {self.serial!r}" if self.serial else "")

    def open(self):
        hid = _hid_module()
        dev = hid.device()
        if self.path:
            dev.open_path(self.path.encode() if isinstance(self.path, str) else self.path)
        elif self.serial:
            dev.open(self.vendor_id, self.product_id, self.serial)
        else:
            dev.open(self.vendor_id, self.product_id)
        self.dev = dev

    def read(self, size, timeout_ms):
        timeout_ms = max(1, int(timeout_ms))   # 0 would mean "wait for ever" to hidapi
        try:
            return bytes(self.dev.read(size, timeout_ms))
        except (ValueError, AttributeError) as exc:
            raise OSError(str(exc)) from None

    def write(self, data):
        try:
            n = self.dev.write(bytes(data))
        except (ValueError, AttributeError) as exc:
            raise OSError(str(exc)) from None
        if n is None or n < 0:
            raise OSError("write failed")
        return n

    def close(self):
        dev, self.dev = self.dev, None
        if dev is not None:
            dev.close()


class ReplayTransport(Transport):
    """Plays recorded reports with their timing and records what is written.

    `reports`: a list of (t [s], bytes) in time order — bytes None (or the text "disconnect")
    makes the device disappear at t: every later read raises OSError. Or a file, one report a
    line: `T HEX HEX ...` (`0.004 01 10 27 00 00`), `T disconnect`, `#` comments.
    `end`: after the last report the device is silent ("silent": reads time out) or gone
    ("disconnect"). `virtual` (default): time is the recording's, not the wall clock — a read
    returns the next report at once and the clock jumps to its stamp (or by the timeout if
    none comes within it); the driver then gives every sample the report stamped at or before
    it, deterministic whatever the machine's speed. `virtual=False` plays in real time (reads
    block until the report's time), for a live run without the device. `written` lists the
    reports written, as (clock, bytes). In virtual time writes are not tied to the read clock
    (the reader runs ahead of the render), so a virtual disconnect fails reads only; in real
    time a write after the disconnect raises OSError like a vanished device. `fail_open`
    simulates a device that is not there.
    """

    def __init__(self, reports, end="silent", virtual=True, fail_open=False):
        if isinstance(reports, (str, bytes)) or hasattr(reports, "__fspath__"):
            reports = self.read_file(reports)
        events = []
        for t, data in reports:
            gone = data is None or (isinstance(data, str) and data.strip() == "disconnect")
            events.append((float(t), None if gone else bytes(data)))
        if any(b[0] < a[0] for a, b in zip(events, events[1:])):
            raise ValueError("replayed reports must be in time order")
        if end not in ("silent", "disconnect"):
            raise ValueError("end is 'silent' or 'disconnect'")
        self.events, self.end, self.virtual, self.fail_open = events, end, bool(virtual), fail_open
        self.written = []
        self.reads = []          # the timeouts every read asked for [ms]
        self.opened = 0
        self.is_open = False
        self._at = 0
        self._now = 0.0
        self._t0 = 0.0

    @staticmethod
    def read_file(path):
        out = []
        with open(path, encoding="utf-8") as f:
            for number, line in enumerate(f, 1):
                line = line.split("#", 1)[0].strip()
                if not line:
                    continue
                t, _, rest = line.partition(" ")
                rest = rest.strip()
                try:
                    out.append((float(t), None if rest == "disconnect" else bytes.fromhex(rest)))
                except ValueError:
                    raise ValueError(f"{path}:{number}: expected `T HEX HEX ...` or `T disconnect`") from None
        return out

    def open(self):
        if self.fail_open:
            raise OSError("open failed")
        self.opened += 1
        self.is_open = True
        self._at, self._now, self._t0 = 0, 0.0, time.monotonic()
        self.written = []

    def clock(self):
        return self._now if self.virtual else time.monotonic() - self._t0

    def _gone_at(self):
        if self._at < len(self.events):
            t, data = self.events[self._at]
            return t if data is None else None
        return None

    def read(self, size, timeout_ms):
        if not self.is_open:
            raise OSError("not open")
        self.reads.append(timeout_ms)
        timeout = max(1, int(timeout_ms)) / 1000.0
        now = self.clock()
        if self._at >= len(self.events):
            if self.end == "disconnect":
                raise OSError("device disconnected (end of the recording)")
            self._advance(now + timeout)
            return b""
        t, data = self.events[self._at]
        if t > now + timeout:
            self._advance(now + timeout)
            return b""
        self._advance(max(now, t))
        if data is None:
            raise OSError("device disconnected")
        self._at += 1
        return data[:size]

    def _advance(self, t):
        if self.virtual:
            self._now = t
        else:
            wait = t - self.clock()
            if wait > 0:
                time.sleep(wait)

    def write(self, data):
        if not self.is_open:
            raise OSError("not open")
        if not self.virtual:
            gone = [t for t, d in self.events if d is None]
            if gone and self.clock() >= gone[0]:
                raise OSError("device disconnected")
        self.written.append((self.clock(), bytes(data)))
        return len(data)

    def close(self):
        self.is_open = False

    def forces(self, profile):
        """The forces [N] carried by the written reports, in order."""
        return [profile.output.decode(d) for _, d in self.written]


def list_hid_devices():
    """Every HID device hidapi sees (its real enumerate()), as dicts: vendor_id, product_id,
    path, serial_number, manufacturer_string, product_string, usage_page, usage,
    interface_number, release_number, and `profile`, the shipped profile with the same ids or None."""
    hid = _hid_module()
    shipped = {}
    for name in shipped_profiles():
        try:
            p = load_profile(find_profile(name))
        except PatchError:
            continue
        shipped.setdefault((p.vendor_id, p.product_id), name)
    out = []
    for info in hid.enumerate():
        entry = {}
        for key, value in dict(info).items():
            entry[key] = value.decode("utf-8", "replace") if isinstance(value, bytes) else value
        entry["profile"] = shipped.get((entry.get("vendor_id"), entry.get("product_id")))
        out.append(entry)
    return out


# -- decoding ----------------------------------------------------------------------------------

class Decoder:
    """Turns one report into a row [x, v, axis…, button…] (SI), keeping what spans reports:
    the running sums of relative axes and the velocity estimate."""

    def __init__(self, profile):
        self.profile = profile
        inp = profile.input
        self.axes, self.buttons = inp.axes, inp.buttons
        names = [f.name for f in inp.axes]
        self.pos = names.index(inp.position) if inp.position else None
        self.vel = names.index(inp.velocity) if inp.velocity not in (None, "estimate") else None
        self.estimate = self.pos is not None and self.vel is None
        fc = inp.velocity_cutoff or 0.0
        self.alpha = 1.0 - math.exp(-2.0 * math.pi * fc * inp.interval) if fc > 0 else 1.0
        self.interval = inp.interval
        self.width = 2 + len(inp.axes) + len(inp.buttons)
        self.reset()

    def reset(self):
        self.values = np.zeros(len(self.axes))
        self.x_prev = None
        self.v = 0.0
        self.row = np.zeros(self.width)

    def decode(self, report, out):
        """Decode a report (with its id byte if numbered) into `out`; False if it is not ours."""
        data = self.profile.input.data(report)
        if data is None:
            return False
        values = self.values
        for k, f in enumerate(self.axes):
            value = f.value(data)
            values[k] = values[k] + value if f.relative else value
        x = values[self.pos] if self.pos is not None else 0.0
        if self.vel is not None:
            self.v = values[self.vel]
        elif self.estimate:
            raw = 0.0 if self.x_prev is None else (x - self.x_prev) / self.interval
            self.v += self.alpha * (raw - self.v)
        self.x_prev = x
        row = self.row
        row[0], row[1] = x, self.v
        row[2:2 + len(values)] = values
        base = 2 + len(values)
        for k, f in enumerate(self.buttons):
            row[base + k] = f.counts(data)
        out[:] = row
        return True

    def still(self, out):
        """A step with no motion (for report-on-change devices that went quiet); False if the
        velocity is not estimated (nothing changes then)."""
        if not self.estimate or self.x_prev is None or self.v == 0.0:
            return False
        self.v += self.alpha * (0.0 - self.v)
        if abs(self.v) < 1e-9:          # m/s: at rest (and no more steps until it moves)
            self.v = 0.0
        self.row[1] = self.v
        out[:] = self.row
        return True


# -- the driver --------------------------------------------------------------------------------

class HidDriver(Driver):
    """The Driver of one `driver: hid` device entry (see the module's doc).

    `transport` (a Transport) replaces hidapi — a ReplayTransport in the tests; `profile` a
    Profile instead of the entry's; `base` the folder a relative profile path is read from.
    """

    block_type = None

    def __init__(self, name, spec, transport=None, profile=None, base=None):
        self.name = name
        spec = spec if spec is not None else {}
        if profile is None:
            profile = getattr(spec, "hid_profile", None)
        if profile is None:
            ref = spec.get("profile")
            if not ref:
                raise _error(f"device {name!r}: driver hid needs a `profile:` (shipped: "
                             f"{', '.join(shipped_profiles())}; or a .yaml file)")
            path = find_profile(ref, base)
            if path is None:
                raise _error(f"device {name!r}: no HID profile {ref!r} (shipped: {', '.join(shipped_profiles())})")
            try:
                profile = load_profile(path)
            except PatchError as exc:
                raise _error(f"device {name!r}: HID profile {ref!r}:\n{exc}") from None
        self.profile = profile
        inp = profile.input
        self.decoder = Decoder(profile)
        self.axes = list(profile.ports)
        self.columns = ("sensor_x", "sensor_v") + tuple(self.axes)
        # the profile's max_force is the device's bound; an entry may only lower it
        self.max_force = float(profile.max_force)
        if spec.get("max_force") is not None:
            bound = self.max_force if profile.output else MAX_FORCE
            self.max_force = force_limit(name, HidKind.name, spec["max_force"], bound,
                                         f"the bound of its profile {profile.name!r}" if profile.output
                                         else "the bound of any device")
        vid = spec.get("vendor_id", profile.vendor_id)
        pid = spec.get("product_id", profile.product_id)
        self.transport = transport if transport is not None else HidapiTransport(
            vid, pid, serial=spec.get("serial"), path=spec.get("path"))
        self.stamped = bool(getattr(self.transport, "virtual", False))
        self.read_ms = max(1, min(MAX_READ_MS, int(math.ceil(2000 * inp.interval))))
        self.timeout = inp.timeout
        # preallocated: the ring the reader fills, the row held across blocks, the output report
        self.ring = np.zeros((RING, self.decoder.width))
        self.stamps = np.zeros(RING)
        self.kinds = np.zeros(RING, dtype=np.int8)
        self.held = np.zeros(self.decoder.width)
        self.out_buf = profile.output.buffer() if profile.output else None
        self.cond = threading.Condition()
        self.reader = self.writer = None
        self.posted = threading.Event()
        self.pending = None
        self.running = False
        self.lost = None
        self.rate = 44100.0
        self.last_force = 0.0
        self.blocks_sent = 0
        self._open()

    # -- opening and closing
    def _describe(self):
        describe = getattr(self.transport, "describe", None)
        return describe() if describe else f"HID device {self.profile.vendor_id:04x}:{self.profile.product_id:04x}"

    def _open(self):
        try:
            self.transport.open()
        except OSError as exc:
            raise _error(f"device {self.name!r}: cannot open the {self._describe()} (profile "
                         f"{self.profile.name!r}): {exc}; `hapticgraph devices` lists the HID devices "
                         f"connected") from None
        self.is_open = True

    def start(self, rate):
        if self.running:
            self.stop()
        if not self.is_open:
            self._open()
        self.rate = float(rate)
        self.decoder.reset()
        self.held[:] = 0.0
        self.w = self.r = 0                 # reports written by the reader, consumed by fill
        self.horizon = -1.0                 # stamped: the reader has read everything up to here
        self.want = 0.0                     # stamped: the render needs reports up to here
        self.finished = False
        self.lost = None
        self._loss = None
        self.pending = None
        self.posted = threading.Event()
        self.t_start = self.transport.clock()
        self.running = True
        self.reader = threading.Thread(target=self._read_loop, name=f"hid-{self.name}-reader", daemon=True)
        self.reader.start()
        if self.profile.output and not self.stamped:
            self.writer = threading.Thread(target=self._write_loop, name=f"hid-{self.name}-writer", daemon=True)
            self.writer.start()

    def stop(self):
        if not self.running and self.reader is None and not self.is_open:
            return
        self.running = False
        with self.cond:
            self.cond.notify_all()
        if getattr(self, "posted", None) is not None:
            self.posted.set()
        for thread in (self.reader, self.writer):
            if thread is not None:
                thread.join(timeout=2.0 + self.read_ms / 1000.0)
        self.reader = self.writer = None
        if self.profile.output and self.is_open:
            try:                                    # the last word to a device is always "no force"
                self.last_force = 0.0
                self.transport.write(self.profile.output.encode(0.0, self.out_buf))
            except OSError:
                pass
        try:
            self.transport.close()
        except OSError:
            pass
        self.is_open = False

    # -- the reader thread
    def _push(self, kind, stamp, message=None):
        """Publish the row in the ring's next slot (already written by the decoder)."""
        with self.cond:
            k = self.w % RING
            self.stamps[k], self.kinds[k] = stamp, kind
            if kind == _LOSS:
                self.ring[k] = self.ring[(k - 1) % RING] if self.w else 0.0    # the values hold
                self._loss = message
                if not self.stamped:
                    self.lost = message
            self.w += 1
            self.horizon = max(self.horizon, stamp)
            self.cond.notify_all()

    def _wait_for_room(self):
        """Stamped: do not run more than the ring or LOOKAHEAD ahead of the render. False: stop."""
        if not self.stamped:
            return self.running
        with self.cond:
            while self.running and (self.w - self.r >= RING - 1 or self.horizon > self.want + LOOKAHEAD):
                self.cond.wait(0.05)
        return self.running

    def _read_loop(self):
        size = self.profile.input.read_size
        decoder, transport = self.decoder, self.transport
        last = None                      # stamp of the last report (or of the start)
        quiet_since = 0.0                # stamp of the last report or still step
        try:
            while self._wait_for_room():
                try:
                    data = transport.read(size, self.read_ms)
                except OSError as exc:
                    now = transport.clock() - self.t_start
                    self._push(_LOSS, now, f"read failed ({exc or 'device gone'})")
                    return
                now = transport.clock() - self.t_start
                if data:
                    if decoder.decode(data, self.ring[self.w % RING]):
                        self._push(_REPORT, now)
                        last = quiet_since = now
                        continue
                if self.timeout is not None and now - (last if last is not None else 0.0) > self.timeout:
                    self._push(_LOSS, now, f"no report for more than {self.timeout:g} s")
                    return
                if last is not None and now - quiet_since >= 2 * decoder.interval - 1e-9:
                    if decoder.still(self.ring[self.w % RING]):
                        self._push(_REPORT, now)
                    quiet_since = now
                with self.cond:
                    self.horizon = max(self.horizon, now)
                    self.cond.notify_all()
        except Exception as exc:  # noqa: BLE001 - a dying thread must stop the run, not hang it
            self._push(_LOSS, max(self.horizon, 0.0), f"reader failed: {exc!r}")
        finally:
            with self.cond:
                self.finished = True
                self.cond.notify_all()

    # -- the writer thread (live)
    def _write_loop(self):
        while self.running:
            self.posted.wait(0.05)
            self.posted.clear()
            force = self.pending
            if not self.running or force is None:
                continue
            self.pending = None
            try:
                self.transport.write(self.profile.output.encode(force, self.out_buf))
            except OSError as exc:
                self._loss = self.lost = f"write failed ({exc or 'device gone'})"
                return

    # -- the block exchange
    def fill(self, t0, ext):
        n = ext.shape[0]
        if not self.stamped:
            w = self.w
            if w:
                self.held[:] = self.ring[(w - 1) % RING]
            ext[:] = self.held
            return
        # a report stamped s reaches sample ceil(s·rate) on: this block needs those stamped up to `end`
        rate, last = self.rate, t0 + n - 1
        end = (last + 1e-6) / rate
        ext[:] = self.held
        with self.cond:
            self.want = end
            self.cond.notify_all()
        while True:
            with self.cond:
                while self.r == self.w and self.horizon < end and not self.finished:
                    self.cond.wait(0.05)
                w, horizon, finished = self.w, self.horizon, self.finished
            beyond = False
            while self.r < w:
                k = self.r % RING
                i = int(math.ceil(self.stamps[k] * rate - 1e-6))
                if i > last:
                    beyond = True
                    break
                if self.kinds[k] == _LOSS:
                    self.lost = self._loss
                    self.r = w
                    break
                i = max(0, i - t0)
                ext[i:] = self.ring[k]
                self.held[:] = self.ring[k]
                self.r += 1
            with self.cond:
                self.cond.notify_all()
            if beyond or self.lost or (self.r == w and (horizon >= end or finished)):
                return

    def send(self, t0, force):
        f = float(force[-1]) if len(force) else 0.0
        if not math.isfinite(f):
            f = 0.0
        f = min(max(f, -self.max_force), self.max_force)
        self.last_force = f
        self.blocks_sent += 1
        if self.profile.output is None or not self.is_open:
            return
        if self.stamped:
            try:
                self.transport.write(self.profile.output.encode(f, self.out_buf))
            except OSError as exc:
                self.lost = f"write failed ({exc or 'device gone'})"
        else:
            self.pending = f
            self.posted.set()


__all__ = ["Decoder", "HidDriver", "HidapiTransport", "ReplayTransport", "Transport", "list_hid_devices"]
