"""A stand-in for python-evdev (PyPI `evdev`) for machines with no /dev/input: the interface the
evdev driver uses — `list_devices()`, `InputDevice(path)` with `name`, `path`, `info`, `uniq`,
`fd`, `capabilities(absinfo=True)`, `upload_effect`, `erase_effect`, `write`, `read_one`, `close`
— and python-evdev's own `ecodes` and `ff`.

    fake = FakeEvdev([FakeDevice.wheel("/dev/input/event3")])
    monkeypatch.setattr(evdev_layout, "evdev_module", lambda: fake)

Every call a device gets is recorded in `calls` (and, given `log=PATH`, appended to that file as
one JSON line, flushed, so a parent process reads what a child did): ("write", type, code,
value), ("upload", id, direction, level), ("erase", id), ("close",). Each `InputDevice(path)`
is a handle of its own, as each open of a node is: its `fd` is one end of a socket pair (`feed`
makes it readable, as an event would); a device made from a passed file descriptor (`sock=`)
gives that one to its first handle, so the process at the other end sees EOF when the holder
dies. `unplug()` makes every later call raise OSError(ENODEV), as the kernel does; `fail_after=N`
unplugs it at its Nth upload (deterministic, for an offline run).
"""
import errno
import json
import socket
import threading
from collections import deque

from evdev import ecodes, ff
from evdev.device import AbsInfo, DeviceInfo
from evdev.events import InputEvent


class FakeDevice:
    """One input device the stand-in lists: what every handle of it shares."""

    def __init__(self, path, name, vendor, product, absinfo=(), keys=(), effects=(), uniq="", log=None, sock=None,
                 fail_after=None):
        self.path, self.name, self.uniq = path, name, uniq
        self.info = DeviceInfo(3, vendor, product, 0x0111)
        self.absinfo, self.keys, self.effects = dict(absinfo), list(keys), list(effects)
        self.calls, self.log = [], log
        self.sock = sock
        self.handles = []
        self.next_id, self.uploaded = 0, {}
        self.gone = False
        self.fail_after, self.uploads = fail_after, 0

    @classmethod
    def wheel(cls, path="/dev/input/event3", name="Logitech G29 Driving Force Racing Wheel", **kw):
        """A Logitech wheel as hid-lg4ff shows it: steering ABS_X 0…65535, pedals ABS_Y/Z/RZ
        0…255, a hat, 25 buttons, constant force."""
        absinfo = {ecodes.ABS_X: AbsInfo(32768, 0, 65535, 0, 0, 0), ecodes.ABS_Y: AbsInfo(255, 0, 255, 0, 0, 0),
                   ecodes.ABS_Z: AbsInfo(255, 0, 255, 0, 0, 0), ecodes.ABS_RZ: AbsInfo(255, 0, 255, 0, 0, 0),
                   ecodes.ABS_HAT0X: AbsInfo(0, -1, 1, 0, 0, 0), ecodes.ABS_HAT0Y: AbsInfo(0, -1, 1, 0, 0, 0)}
        keys = [ecodes.BTN_TRIGGER + k for k in range(16)] + [ecodes.BTN_TRIGGER_HAPPY1 + k for k in range(9)]
        effects = [ecodes.FF_CONSTANT, ecodes.FF_GAIN, ecodes.FF_AUTOCENTER]
        return cls(path, name, kw.pop("vendor", 0x046D), kw.pop("product", 0xC24F), absinfo, keys, effects, **kw)

    @classmethod
    def stick(cls, path="/dev/input/event5", name="Microsoft SideWinder Force Feedback 2 Joystick", **kw):
        """A HID PID joystick as hid-pidff shows it: x, y −512…511, rz 0…63, a throttle 0…127, a hat, 8 buttons."""
        absinfo = {ecodes.ABS_X: AbsInfo(0, -512, 511, 0, 0, 0), ecodes.ABS_Y: AbsInfo(0, -512, 511, 0, 0, 0),
                   ecodes.ABS_RZ: AbsInfo(31, 0, 63, 0, 0, 0), ecodes.ABS_THROTTLE: AbsInfo(0, 0, 127, 0, 0, 0),
                   ecodes.ABS_HAT0X: AbsInfo(0, -1, 1, 0, 0, 0), ecodes.ABS_HAT0Y: AbsInfo(0, -1, 1, 0, 0, 0)}
        keys = [ecodes.BTN_TRIGGER + k for k in range(8)]
        effects = kw.pop("effects", [ecodes.FF_CONSTANT, ecodes.FF_PERIODIC, ecodes.FF_GAIN, ecodes.FF_AUTOCENTER])
        return cls(path, name, kw.pop("vendor", 0x045E), kw.pop("product", 0x001B), absinfo, keys, effects, **kw)

    # -- what a test does
    def feed(self, type_, code, value):
        for handle in self.handles:
            handle.push(InputEvent(0, 0, type_, code, value))

    def unplug(self):
        self.gone = True
        for handle in self.handles:
            handle.wake()

    def levels(self):
        """The signed levels uploaded, in order (direction 0xC000 or 0x0000: +; else −)."""
        return [c[3] * (1 if c[2] in (0xC000, 0x0000) else -1) for c in self.calls if c[0] == "upload"]

    def ff_calls(self):
        """The calls but the closes of handles opened only to be read (a match looking)."""
        return [c for c in self.calls if c != ("close",)]

    def record(self, *call):
        self.calls.append(call)
        if self.log is not None:
            with open(self.log, "a") as f:
                f.write(json.dumps(call) + "\n")
                f.flush()


class InputDevice:
    """One open handle of a FakeDevice: python-evdev's InputDevice face."""

    def __init__(self, dev):
        self.dev, self.path, self.name, self.uniq, self.info = dev, dev.path, dev.name, dev.uniq, dev.info
        if dev.sock is not None:
            self.sock, self.peer, dev.sock = dev.sock, None, None
        else:
            self.sock, self.peer = socket.socketpair()
        self.events = deque()
        self.lock = threading.Lock()
        self.closed = False
        dev.handles.append(self)

    def push(self, event):
        with self.lock:
            self.events.append(event)
            self.events.append(InputEvent(0, 0, ecodes.EV_SYN, ecodes.SYN_REPORT, 0))
        self.wake()

    def wake(self):
        if self.peer is not None and not self.closed:
            self.peer.send(b"e")

    def _check(self):
        if self.dev.gone:
            raise OSError(errno.ENODEV, "No such device")
        if self.closed:
            raise ValueError("the device is closed")

    @property
    def fd(self):
        return self.sock.fileno()

    def capabilities(self, verbose=False, absinfo=True):
        dev = self.dev
        caps = {ecodes.EV_SYN: [0], ecodes.EV_KEY: list(dev.keys),
                ecodes.EV_ABS: [(code, info) if absinfo else code for code, info in sorted(dev.absinfo.items())]}
        if dev.effects:
            caps[ecodes.EV_FF] = list(dev.effects)
        return caps

    def upload_effect(self, effect, writeback_id=True):
        dev = self.dev
        dev.uploads += 1
        if dev.fail_after is not None and dev.uploads >= dev.fail_after:
            dev.gone = True
        self._check()
        if effect.type != ecodes.FF_CONSTANT or ecodes.FF_CONSTANT not in dev.effects:
            raise OSError(errno.EINVAL, "Invalid argument")
        eid = effect.id
        if eid == -1:
            eid, dev.next_id = dev.next_id, dev.next_id + 1
        elif eid not in dev.uploaded:
            raise OSError(errno.EINVAL, "Invalid argument")
        dev.uploaded[eid] = effect.u.ff_constant_effect.level
        dev.replay_length = effect.ff_replay.length
        dev.record("upload", eid, effect.direction, effect.u.ff_constant_effect.level)
        if writeback_id:
            effect.id = eid
        return eid

    def erase_effect(self, ff_id):
        self._check()
        self.dev.uploaded.pop(ff_id)
        self.dev.record("erase", ff_id)

    def write(self, etype, code, value):
        self._check()
        self.dev.record("write", etype, code, value)

    def read_one(self):
        self._check()
        with self.lock:
            if not self.events:
                return None
            event = self.events.popleft()
        if event.type == ecodes.EV_SYN and self.peer is not None:
            self.sock.recv(1)
        return event

    def close(self):
        if not self.closed:
            self.closed = True
            self.dev.record("close")
            self.dev.handles.remove(self)
            self.sock.close()


class FakeEvdev:
    """The `evdev` module's face: list_devices(), InputDevice(path), ecodes, ff."""

    ecodes, ff = ecodes, ff

    def __init__(self, devices):
        self.devices = {d.path: d for d in devices}

    def list_devices(self):
        return list(self.devices)

    def InputDevice(self, path):        # noqa: N802 - python-evdev's name
        dev = self.devices.get(str(path))
        if dev is None or dev.gone:
            raise OSError(errno.ENOENT, f"No such file or directory: {path!r}")
        return InputDevice(dev)
