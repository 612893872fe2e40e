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

The velocity estimate and the decoding of reports: hapticgraph.devices.hid_reports; the
transports (hidapi, replayed reports): hapticgraph.devices.hid_transports.

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

import numpy as np

from ..graph.engine import Driver
from ..graph.errors import PatchError
from .driver_kind import attached
from .errors import DeviceError
from .hid_profiles import find_profile, load_profile, shipped_profiles
from .hid_reports import Decoder
from .hid_transports import HidapiTransport, ReplayTransport, Transport, list_hid_devices
from .limits import FORCE_CEILING, block_force, force_limit

RING = 512                  # reports held between the reader thread and the kernel
MAX_READ_MS = 20            # the longest a read waits, so the thread always notices a stop
LOOKAHEAD = 0.25            # s: how far a stamped reader may read ahead of the render
_REPORT, _LOSS = 0, 1


def _entry_profile(name, spec, base):
    """The Profile a device entry's `profile:` names (a shipped name or a .yaml file)."""
    ref = spec.get("profile")
    if not ref:
        raise DeviceError(f"device {name!r}: driver hid needs a `profile:` (shipped: "
                     f"{', '.join(shipped_profiles())}; or a .yaml file)")
    path = find_profile(ref, base)
    if path is None:
        raise DeviceError(f"device {name!r}: no HID profile {ref!r} (shipped: {', '.join(shipped_profiles())})")
    try:
        return load_profile(path)
    except PatchError as exc:
        raise DeviceError(f"device {name!r}: HID profile {ref!r}:\n{exc}") from None


def _max_force(name, spec, profile):
    """The profile's max_force is the device's bound; an entry may only lower it."""
    if spec.get("max_force") is None:
        return float(profile.max_force)
    bound = float(profile.max_force) if profile.output else FORCE_CEILING
    return force_limit(name, "hid", spec["max_force"], bound,
                       f"the bound of its profile {profile.name!r}" if profile.output
                       else "the bound of any device")


# -- the driver --------------------------------------------------------------------------------

class HidDriver(Driver):
    """The Driver of one `driver: hid` device entry (see the module's doc).

    `transport` (a Transport) replaces hidapi — a ReplayTransport in the tests and for a
    recording; `profile` the device's layout (hapticgraph.devices.hid_reports.Layout: a Profile,
    or a DescribedDevice read from its report descriptor) instead of the entry's profile; `base`
    the folder a relative profile path is read from.
    """

    block_type = None

    def __init__(self, name, spec, transport=None, profile=None, base=None):
        self.name = name
        spec = spec if spec is not None else {}
        if profile is None:
            profile = attached(spec, "hid_profile") or _entry_profile(name, spec, base)
        self.profile = profile
        inp = profile.input
        self.decoder = profile.decoder()
        self.axes = list(profile.ports)
        self.columns = ("sensor_x", "sensor_v") + tuple(self.axes)
        self.max_force = _max_force(name, spec, profile)
        vid = spec.get("vendor_id", profile.vendor_id)
        pid = spec.get("product_id", profile.product_id)
        self.transport = transport if transport is not None else HidapiTransport(
            vid, pid, serial=spec.get("serial"), path=spec.get("path"))
        self.stamped = bool(self.transport.virtual)
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
        return (self.transport.describe()
                or f"HID device {self.profile.vendor_id:04x}:{self.profile.product_id:04x}")

    def _open(self):
        try:
            self.transport.open()
        except OSError as exc:
            raise DeviceError(f"device {self.name!r}: cannot open the {self._describe()} (profile "
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
        f = block_force(force, self.max_force)
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
