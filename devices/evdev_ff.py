"""Force-feedback joysticks and wheels through the Linux kernel (`driver: evdev`): the kernel's
own drivers (hid-pidff for HID PID joysticks such as the SideWinder Force Feedback 2, hid-lg4ff
for Logitech wheels, ...) drive the device; python-evdev talks to them.

    wheel: {driver: evdev, match: {name: "G29"}, max_force: 0.4}
    stick: {driver: evdev, match: {vendor: 0x045e, product: 0x001b}, axis: y}

How force reaches the device
    One constant-force effect (FF_CONSTANT) is uploaded when the device starts, with FF_GAIN at
    full and FF_AUTOCENTER off (the patch is the only force), and played. At each block `send`
    takes the block's LAST force sample (the newest), makes NaN/±inf 0, clamps it to
    `max_force` — for these devices a fraction of the device's full scale (0 … 1, default 0.5),
    so the level is at most max_force × 0x7fff — slew-limits it (its size may rise by at most
    `slew` × full scale per second; it may always fall at once, and a change of side goes
    through zero), and uploads the effect again with that level and the direction of the force's
    sign along `axis` (x: positive is right, 0xC000; y: positive is down, 0x0000; linux/input.h's
    directions). Levels are written at the block rate, at most MAX_RATE (1 kHz): a block that
    comes sooner is skipped unless its level is zero (a zero is never held back).

    The effect lasts `watchdog` seconds (default 0.25; its replay length) and is played again
    every quarter of that while the patch runs, so a process that stalls — hung, stopped, its
    audio thread dead — leaves no force on the hand for longer: the kernel ends the effect
    (`watchdog: 0`: an effect that lasts until stopped).

Stopping, whatever ends the run
    `stop` sets the level to zero before anything else, then stops and erases the effect, puts
    autocentring back (`autocenter`, 0 … 1 of full, default 1.0: the kernel drivers' own
    default) and closes the device. A blow-up or a lost device reaches `send` as zeros (the
    engine's guard) and a zero is written at once. SIGTERM and SIGINT: the handler this module
    installs (main thread, once) zeroes every open device first and latches it (no force until
    it starts again), then hands the signal on to the handler that was there before (the
    command line's stops the run, which erases the effect); with none, it erases every effect
    and ends the process as the signal would. atexit does the same for a process that ends
    without stopping its devices. A device that is lost (a read or a write fails: unplugged)
    zeroes every other open evdev device at once, before the engine stops the run. SIGKILL runs nothing: what erases the effect then is the
    kernel — effects belong to the file descriptor they were uploaded through and are erased
    when it is closed (drivers/input/ff-core.c, input_ff_flush, called when an evdev client's
    fd is flushed), which the kernel does for every fd of a process that dies.

Inputs
    A reader thread waits on the device's fd (select, at most READ_SECONDS, so it notices a stop)
    and reads events as they come: each ABS or key event sets its value in a row
    (hapticgraph.devices.evdev_layout names and normalises them). Values are held over a block.
    `x` is the haptic block's x; its velocity is estimated at each block from the change of x
    (smoothed at VELOCITY_CUTOFF). A read that fails (unplugged) makes the device lost.
"""
import atexit
import math
import os
import select
import signal
import threading

import numpy as np

from ..graph.engine import Driver
from .errors import DeviceError
from .evdev_layout import EV_ABS, EV_KEY
from .limits import block_force, force_limit
from .velocity import VelocityEstimate

FULL = 0x7FFF                   # an FF level's full scale (linux/input.h: __s16)
GAIN_FULL = 0xFFFF
MAX_RATE = 1000.0               # Hz: levels written at most this often
SLEW = 20.0                     # full scale per second: a level may rise from 0 to full in 50 ms
DEFAULT_MAX_FORCE = 0.5         # of full scale
WATCHDOG = 0.25                 # s: the effect's length; played again every quarter of it
READ_SECONDS = 0.02
VELOCITY_CUTOFF = 20.0          # Hz
DIRECTIONS = {"x": (0xC000, 0x4000), "y": (0x0000, 0x8000)}   # (positive, negative) force along the axis


def slew(current, target, step):
    """The level after one block: `target`, except that its size may rise by at most `step`;
    a fall is at once, and a change of side goes through zero."""
    if target * current < 0:
        current = 0.0
    if abs(target) <= abs(current):
        return target
    return current + math.copysign(min(abs(target) - abs(current), step), target)


# -- every device with an effect on it, zeroed whatever ends the process ------------------------

_live = set()
_previous = {}                  # signal number -> the handler there before ours
_exit_hook = []                 # [True] once _at_exit is registered
_lock = threading.Lock()


def _on_signal(signum, frame):
    for driver in list(_live):
        driver.halt()
    previous = _previous.get(signum)
    if callable(previous):
        return previous(signum, frame)
    if previous == signal.SIG_IGN:
        return None
    for driver in list(_live):        # nothing else will stop the run: end as the signal would
        driver.release()
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)
    return None


def _at_exit():
    for driver in list(_live):
        driver.halt()
        driver.release()


def _guard():
    """atexit, once; the SIGTERM and SIGINT handlers, from the main thread (a driver is opened
    there; it may start on the audio thread, where no handler can be set), set again if another
    handler was put in their place since (the command line gives back the handlers it found)."""
    with _lock:
        if not _exit_hook:
            atexit.register(_at_exit)
            _exit_hook.append(True)
        if threading.current_thread() is not threading.main_thread():
            return
        for signum in (signal.SIGTERM, signal.SIGINT):
            current = signal.getsignal(signum)
            if current is not _on_signal and current is not signal.SIG_IGN:   # ours again if put back since
                _previous[signum] = current
                signal.signal(signum, _on_signal)


def _lost(driver):
    """A device is gone: every other device's force is zeroed at once, before the run stops."""
    for other in list(_live):
        if other is not driver:
            other.halt()


class EvdevDriver(Driver):
    """The Driver of one `driver: evdev` entry (see the module's doc). `device`: an opened
    python-evdev InputDevice (or a stand-in of its interface), `layout` its EvdevLayout,
    `module` python-evdev (its `ff` and `ecodes`)."""

    block_type = None

    def __init__(self, name, spec, device, layout, module):
        self.name, self.device, self.layout, self.module = name, device, layout, module
        self.max_force = force_limit(name, "evdev", spec.get("max_force", DEFAULT_MAX_FORCE), 1.0,
                                     "the device's full scale")
        self.slew_rate = float(spec.get("slew", SLEW))
        self.watchdog_ms = int(round(1000 * float(spec.get("watchdog", WATCHDOG))))
        self.autocenter = float(spec.get("autocenter", 1.0))
        axis = spec.get("axis", "x")
        if axis not in DIRECTIONS:
            raise DeviceError(f"device {name!r} (evdev): axis {axis!r} must be one of {', '.join(DIRECTIONS)}")
        self.directions = DIRECTIONS[axis]
        self.forces = layout.constant_force
        if not self.forces and spec.get("max_force") is not None:
            raise DeviceError(f"device {name!r} (evdev): {layout.name!r} at {layout.path} has no constant-force "
                              f"effect (FF_CONSTANT) in the kernel; leave out max_force to use its inputs only")
        self.axes = list(layout.ports)
        self.columns = ("sensor_x", "sensor_v") + tuple(self.axes)
        self.slots = {(EV_ABS, a.code): (2 + self.axes.index(a.name) if a is not layout.position else 0, a)
                      for a in layout.axes}
        base = 2 + len(layout.ports) - len(layout.keys)
        self.slots.update({(EV_KEY, code): (base + k, None) for k, code in enumerate(layout.keys)})
        self.row = np.zeros(len(self.columns))
        for k, axis in self.slots.values():
            if axis is not None:
                self.row[k] = axis.value(axis.initial)
        self.lock = threading.RLock()
        self.effect = None
        self.level = 0.0                # the level last written, of full scale, signed
        self.last_force = 0.0
        self.written_at = None          # the sample its level was written at
        self.halted = False
        self.running = False
        self.reader = None
        self.lost = None
        self.rate = 44100.0
        self.is_open = True
        _guard()

    # -- starting and stopping
    def start(self, rate):
        if self.running:
            self.stop()
        if not self.is_open:                 # started again after a stop: the node opened again
            try:
                self.device = self.module.InputDevice(self.layout.path)
            except OSError as exc:
                raise DeviceError(f"device {self.name!r} (evdev): cannot open {self.layout.path}: {exc}") from None
            self.is_open = True
        self.rate = float(rate)
        self.lost, self.halted, self.level, self.written_at, self.played_at = None, False, 0.0, None, 0
        self.velocity = VelocityEstimate(VELOCITY_CUTOFF)
        if self.forces:
            try:
                self._start_effect()
            except OSError as exc:
                self.stop()
                raise DeviceError(f"device {self.name!r} (evdev): {self.layout.name!r} at {self.layout.path}: "
                                  f"cannot start its force feedback: {exc}") from None
        self.running = True
        self.reader = threading.Thread(target=self._read_loop, name=f"evdev-{self.name}-reader", daemon=True)
        self.reader.start()

    def _start_effect(self):
        ff, codes = self.module.ff, self.module.ecodes
        with self.lock:
            self.device.write(codes.EV_FF, codes.FF_GAIN, GAIN_FULL)
            self.device.write(codes.EV_FF, codes.FF_AUTOCENTER, 0)
            constant = ff.Constant(0, ff.Envelope(0, 0, 0, 0))
            self.effect = ff.Effect(codes.FF_CONSTANT, -1, self.directions[0], ff.Trigger(0, 0),
                                    ff.Replay(self.watchdog_ms, 0), ff.EffectType(ff_constant_effect=constant))
            self.effect_id = self.device.upload_effect(self.effect)
            _guard()
            _live.add(self)
            self.device.write(codes.EV_FF, self.effect_id, 1)

    def _write_level(self, level):
        """Upload the effect with `level` (of full scale, signed). False if the device failed."""
        e = self.effect
        e.u.ff_constant_effect.level = int(round(abs(level) * FULL))
        if level:
            e.direction = self.directions[0] if level > 0 else self.directions[1]
        try:
            self.device.upload_effect(e)
        except OSError as exc:
            self._lose(f"force write failed ({exc or 'device gone'})")
            return False
        self.level = level
        return True

    def _lose(self, why):
        first = self.lost is None
        self.lost = why
        if first:                         # once: two lost devices must not halt each other for ever
            _lost(self)

    def halt(self):
        """Zero the force now and write none until the device starts again (the signal and
        atexit path; safe to call from a signal handler or any thread)."""
        with self.lock:
            self.halted = True
            if self.effect is not None and self.is_open:
                self._write_level(0.0)

    def release(self):
        """Stop and erase the effect and put autocentring back: the device is left as found."""
        with self.lock:
            _live.discard(self)
            if self.effect is None or not self.is_open:
                return
            codes = self.module.ecodes
            effect_id, self.effect = self.effect_id, None
            for call in (lambda: self.device.write(codes.EV_FF, effect_id, 0),
                         lambda: self.device.erase_effect(effect_id),
                         lambda: self.device.write(codes.EV_FF, codes.FF_AUTOCENTER,
                                                   int(round(min(max(self.autocenter, 0.0), 1.0) * GAIN_FULL)))):
                try:
                    call()
                except OSError:
                    pass                  # unplugged: the kernel dropped the effect with the device

    def stop(self):
        self.halt()                       # zero before anything else
        self.running = False
        if self.reader is not None:
            self.reader.join(timeout=2.0)
            self.reader = None
        self.release()
        with self.lock:
            if self.is_open:
                self.is_open = False
                try:
                    self.device.close()
                except OSError:
                    pass

    # -- the reader thread
    def _read_loop(self):
        dev, slots, row = self.device, self.slots, self.row
        try:
            while self.running:
                ready, _, _ = select.select([dev.fd], [], [], READ_SECONDS)
                if not ready:
                    continue
                while self.running:
                    event = dev.read_one()
                    if event is None:
                        break
                    slot = slots.get((event.type, event.code))
                    if slot is not None:
                        k, axis = slot
                        row[k] = axis.value(event.value) if axis is not None else float(event.value != 0)
        except (OSError, ValueError) as exc:
            self._lose(f"read failed ({exc or 'device gone'})")

    # -- the block exchange
    def fill(self, t0, ext):
        n = ext.shape[0]
        if n:
            self.velocity.step(self.row[0], n / self.rate)
        else:
            self.velocity.x_prev = self.row[0]
        ext[:] = self.row
        ext[:, 1] = self.velocity.v

    def send(self, t0, force):
        f = block_force(force, self.max_force)
        self.last_force = f
        if not self.forces or self.lost:
            return
        n = len(force)
        with self.lock:
            if self.halted or self.effect is None:
                return
            level = slew(self.level, f, self.slew_rate * max(n, 1) / self.rate)
            due = self.written_at is None or t0 + n - self.written_at >= self.rate / MAX_RATE - 1e-9
            if level != self.level and (due or level == 0.0):
                if self._write_level(level):
                    self.written_at = t0 + n
            if self.watchdog_ms and t0 + n - self.played_at >= self.rate * self.watchdog_ms / 4000.0:
                self.played_at = t0 + n           # played again: the kernel's stop time moves on
                try:
                    self.device.write(self.module.ecodes.EV_FF, self.effect_id, 1)
                except OSError as exc:
                    self._lose(f"force write failed ({exc or 'device gone'})")


__all__ = ["DEFAULT_MAX_FORCE", "EvdevDriver", "FULL", "MAX_RATE", "SLEW", "WATCHDOG", "slew"]
