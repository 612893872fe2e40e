"""How the HID driver talks to a device: a Transport reads and writes reports. HidapiTransport
is a real device through hidapi (imported when a device opens); ReplayTransport plays recorded
reports with their timing, in virtual time (deterministic, for tests and offline re-rendering)
or in real time. `list_hid_devices` is what `hapticgraph devices` shows.
"""
import os
import time

from ..graph.errors import PatchError
from .errors import DeviceError
from .hid_profiles import find_profile, load_profile, shipped_profiles


def hid_module():
    try:
        import hid
    except ImportError:
        raise DeviceError("the HID driver needs the hidapi package: pip install 'hapticgraph[hid]'") from None
    if not hasattr(hid, "device"):
        raise DeviceError("the `hid` module found is not hidapi's (PyPI `hid` and `hidapi` share the name): "
                     "pip uninstall hid, then pip install hidapi")
    return hid


class Transport:
    """How the driver talks to a device. `read(size, timeout_ms)` returns one report (bytes;
    b"" when nothing came within the timeout) and raises OSError when the device is gone;
    `write(data)` sends a report (first byte the report id, 0 if unnumbered). `clock()` is the
    time the transport's reports are stamped with [s]; `virtual` says it is not the wall clock
    (stamped timing, see hapticgraph.devices.hid)."""

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

    def describe(self):
        """What the device is, for a message; None: the profile's ids say it."""
        return None


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
        hid = hid_module()
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
        if isinstance(reports, (str, bytes)) or isinstance(reports, os.PathLike):
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
    hid = hid_module()
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


__all__ = ["HidapiTransport", "ReplayTransport", "Transport", "hid_module", "list_hid_devices"]
