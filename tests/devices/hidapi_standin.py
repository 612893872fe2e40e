"""A stand-in for hidapi's `hid` module (PyPI `hidapi`, 0.14) for machines with no HID device:
the same interface — `enumerate()`, and `device()` with `open`, `open_path`,
`get_report_descriptor`, `read`, `write`, `set_nonblocking`, `close` — fed by recorded
descriptors and reports (a hid-recorder recording's, from tests/data/hid).

    fake = FakeHidapi([FakeDevice.from_recording(path, b"/dev/hidraw3"), ...])
    monkeypatch.setattr(hid_transports, "hid_module", lambda: fake)

Reads play the recording's reports in real time from the moment the device is opened, as a
device would send them; hidapi's conventions are kept: paths are bytes, `read` returns a list
of ints (empty when nothing came within the timeout), a missing device raises OSError on open,
and a closed one ValueError on use."""
import threading
import time

from hapticgraph.devices.hid_recording import load_recording


class FakeDevice:
    """One device the stand-in enumerates: its hidapi entry, descriptor and recorded reports."""

    def __init__(self, path, vendor_id, product_id, descriptor, reports=(), product="", manufacturer="",
                 serial="", usage_page=0, usage=0):
        self.info = {"path": path, "vendor_id": vendor_id, "product_id": product_id, "serial_number": serial,
                     "release_number": 0x0100, "manufacturer_string": manufacturer, "product_string": product,
                     "usage_page": usage_page, "usage": usage, "interface_number": 0}
        self.descriptor = bytes(descriptor)
        self.reports = list(reports)
        self.written = []

    @classmethod
    def from_recording(cls, path, hid_path, **kwargs):
        rec = load_recording(path)
        maker, _, product = rec.name.partition(" ")
        return cls(hid_path, rec.vendor_id, rec.product_id, rec.descriptor, rec.events,
                   product=kwargs.pop("product", product), manufacturer=kwargs.pop("manufacturer", maker), **kwargs)


class FakeHidapi:
    """The `hid` module's face: enumerate() and device()."""

    def __init__(self, devices):
        self.devices = list(devices)
        self.opened = []

    def enumerate(self, vendor_id=0, product_id=0):
        return [dict(d.info) for d in self.devices
                if vendor_id in (0, d.info["vendor_id"]) and product_id in (0, d.info["product_id"])]

    def device(self):
        return _Handle(self)


class _Handle:
    """hid.device(): one open device."""

    def __init__(self, module):
        self.module, self.dev, self.t0, self.at = module, None, 0.0, 0
        self.lock = threading.Lock()

    def _open(self, dev):
        if dev is None:
            raise OSError("open failed")
        self.dev, self.t0, self.at = dev, time.monotonic(), 0
        self.module.opened.append(dev.info["path"])

    def open_path(self, path):
        self._open(next((d for d in self.module.devices if d.info["path"] == bytes(path)), None))

    def open(self, vendor_id, product_id, serial_number=None):
        self._open(next((d for d in self.module.devices if (d.info["vendor_id"], d.info["product_id"]) ==
                         (vendor_id, product_id) and serial_number in (None, d.info["serial_number"])), None))

    def _need(self):
        if self.dev is None:
            raise ValueError("not open")
        return self.dev

    def get_report_descriptor(self):
        return list(self._need().descriptor)

    def set_nonblocking(self, flag):
        return 0

    def read(self, size, timeout_ms=0):
        dev = self._need()
        deadline = time.monotonic() + max(timeout_ms, 1) / 1000.0
        while True:
            with self.lock:
                if self.at < len(dev.reports):
                    t, data = dev.reports[self.at]
                    if time.monotonic() - self.t0 >= t:
                        self.at += 1
                        return list(data[:size])
                    due = self.t0 + t
                else:
                    due = None
            now = time.monotonic()
            if now >= deadline:
                return []
            time.sleep(max(0.0, min(deadline, due if due is not None else deadline) - now))

    def write(self, data):
        self._need().written.append(bytes(data))
        return len(data)

    def close(self):
        self.dev = None


__all__ = ["FakeDevice", "FakeHidapi"]
