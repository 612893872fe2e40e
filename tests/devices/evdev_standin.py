"""A stand-in for python-evdev (PyPI `evdev`) for machines with no /dev/input: the interface the
evdev driver uses — `list_devices()`, `InputDevice(path)` with `name`, `path`, `info`, `uniq`,
`fd`, `capabilities(absinfo=True)`, `upload_effect`, `erase_effect`, `write`, `read_one`, `close`
— and python-evdev's own `ecodes` and `ff`.

    fake = FakeEvdev([FakeDevice.wheel("/dev/input/event3")])
    monkeypatch.setattr(evdev_layout, "evdev_module", lambda: fake)

Every call a device gets is recorded in `calls` (and, given `log=PATH`, appended to that file as
one JSON line, flushed, so a parent process reads what a child did): ("write", type, code,
value), ("upload", id, direction, level), ("erase", id), ("close",). Its `fd` is one end of a
socket pair (`feed` makes it readable, as an event would); a device made from a passed file
descriptor (`sock=`) holds that one, so the process at the other end sees EOF when the holder
dies. `unplug()` makes every later call raise OSError(ENODEV), as the kernel does.
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
    """One input device the stand-in lists."""

    def __init__(self, path, name, vendor, product, absinfo=(), keys=(), effects=(), uniq="", log=None, sock=None):
        self.path, self.name, self.uniq = path, name, uniq
        self.info = DeviceInfo(3, vendor, product, 0x0111)
        self.absinfo, self.keys, self.effects = dict(absinfo), list(keys), list(effects)
        self.calls, self.log = [], log
        self.events = deque()
        self.lock = threading.Lock()
        if sock is None:
            self.sock, self.peer = socket.socketpair()
        else:
            self.sock, self.peer = sock, None
        self.next_id, self.uploaded = 0, {}
        self.gone = self.closed = False
        self.opened = 0

    @classmethod
    def wheel(cls, path="/dev/input/event3", name="Logitech G29 Driving Force Racing Wheel", **kw):
        """A Logitech wheel as hid-lg4ff shows it: steering ABS_X 0…65535, pedals ABS_Y/Z/RZ
        0…255 (accelerator, brake, clutch here as y, z, rz), a hat, 25 buttons, constant force."""
        absinfo = {ecodes.ABS_X: AbsInfo(32768, 0, 65535, 0, 0, 0), ecodes.ABS_Y: AbsInfo(255, 0, 255, 0, 0, 0),
                   ecodes.ABS_Z: AbsInfo(255, 0, 255, 0, 0, 0), ecodes.ABS_RZ: AbsInfo(255, 0, 255, 0, 0, 0),
                   ecodes.ABS_HAT0X: AbsInfo(0, -1, 1, 0, 0, 0), ecodes.ABS_HAT0Y: AbsInfo(0, -1, 1, 0, 0, 0)}
        keys = [ecodes.BTN_TRIGGER + k for k in range(16)] + [ecodes.BTN_TRIGGER_HAPPY1 + k for k in range(9)]
        effects = [ecodes.FF_CONSTANT, ecodes.FF_GAIN, ecodes.FF_AUTOCENTER]
        return cls(path, name, kw.pop("vendor", 0x046D), kw.pop("product", 0xC24F), absinfo, keys, effects, **kw)

    @classmethod
    def stick(cls, path="/dev/input/event5", name="Microsoft SideWinder Force Feedback 2 Joystick", **kw):
        """A HID PID joystick as hid-pidff shows it: x, y, rz −512…511 / 0…63, a throttle 0…127, a hat, 8 buttons."""
        absinfo = {ecodes.ABS_X: AbsInfo(0, -512, 511, 0, 0, 0), ecodes.ABS_Y: AbsInfo(0, -512, 511, 0, 0, 0),
                   ecodes.ABS_RZ: AbsInfo(31, 0, 63, 0, 0, 0), ecodes.ABS_THROTTLE: AbsInfo(0, 0, 127, 0, 0, 0),
                   ecodes.ABS_HAT0X: AbsInfo(0, -1, 1, 0, 0, 0), ecodes.ABS_HAT0Y: AbsInfo(0, -1, 1, 0, 0, 0)}
        keys = [ecodes.BTN_TRIGGER + k for k in range(8)]
        effects = kw.pop("effects", [ecodes.FF_CONSTANT, ecodes.FF_PERIODIC, ecodes.FF_GAIN, ecodes.FF_AUTOCENTER])
        return cls(path, name, kw.pop("vendor", 0x045E), kw.pop("product", 0x001B), absinfo, keys, effects, **kw)

    # -- what a test does
    def feed(self, type_, code, value):
        with self.lock:
            self.events.append(InputEvent(0, 0, type_, code, value))
            self.events.append(InputEvent(0, 0, ecodes.EV_SYN, ecodes.SYN_REPORT, 0))
        self.peer.send(b"e")

    def unplug(self):
        self.gone = True
        if self.peer is not None:
            self.peer.send(b"!")

    def levels(self):
        """The signed levels uploaded, in order (direction 0xC000 or 0x0000: +; else −)."""
        return [c[3] * (1 if c[2] in (0xC000, 0x0000) else -1) for c in self.calls if c[0] == "upload"]

    # -- the InputDevice face
    def _record(self, *call):
        self.calls.append(call)
        if self.log is not None:
            with open(self.log, "a") as f:
                f.write(json.dumps(call) + "\n")
                f.flush()

    def _check(self):
        if self.gone:
            raise OSError(errno.ENODEV, "No such device")
        if self.closed:
            raise ValueError("the device is closed")

    @property
    def fd(self):
        return self.sock.fileno()

    def capabilities(self, verbose=False, absinfo=True):
        caps = {ecodes.EV_SYN: [0], ecodes.EV_KEY: list(self.keys),
                ecodes.EV_ABS: [(code, info) if absinfo else code for code, info in sorted(self.absinfo.items())]}
        if self.effects:
            caps[ecodes.EV_FF] = list(self.effects)
        return caps

    def upload_effect(self, effect, writeback_id=True):
        self._check()
        if effect.type != ecodes.FF_CONSTANT or ecodes.FF_CONSTANT not in self.effects:
            raise OSError(errno.EINVAL, "Invalid argument")
        eid = effect.id
        if eid == -1:
            eid, self.next_id = self.next_id, self.next_id + 1
        elif eid not in self.uploaded:
            raise OSError(errno.EINVAL, "Invalid argument")
        level = effect.u.ff_constant_effect.level
        self.uploaded[eid] = level
        self._record("upload", eid, effect.direction, level)
        if writeback_id:
            effect.id = eid
        return eid

    def erase_effect(self, ff_id):
        self._check()
        self.uploaded.pop(ff_id)
        self._record("erase", ff_id)

    def write(self, etype, code, value):
        self._check()
        self._record("write", etype, code, value)

    def read_one(self):
        self._check()
        with self.lock:
            if not self.events:
                return None
            event = self.events.popleft()
        if event.type == ecodes.EV_SYN:
            try:
                self.sock.recv(1)
            except BlockingIOError:
                pass
        return event

    def close(self):
        if not self.closed:
            self.closed = True
            self._record("close")
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
        if dev.closed:                  # opened again: a new fd on the same device
            dev.closed = False
            dev.sock, dev.peer = socket.socketpair()
        dev.opened += 1
        return dev
