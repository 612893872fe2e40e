"""Serial haptic devices (`driver: serial`) through pyserial, described by a wire-protocol profile
(hapticgraph.devices.serial_profiles).

    devices:
      fader: {driver: serial, profile: fader_1dof, port: /dev/ttyACM0, max_force: 1.0}

A reader thread reads the line, finds frames by their sync bytes, checks each frame's checksum and
decodes it into SI values (the velocity estimated as for HID devices: hapticgraph.devices.hid's
Decoder). Values are held: at each block boundary the newest frame's values fill the whole block
(interpolating would add a frame of latency to the haptic loop). `send` takes the block's last
force, makes NaN/±inf 0, clamps it to max_force (the profile's, or the entry's if lower) and a
writer thread writes one frame (a serial write must not block the audio callback). `stop` always
writes a zero force last.

The device is lost — the session then sends zero force and stops, and what was rendered and
recorded so far is kept — when the line fails (unplugged), when no valid frame came for longer
than the profile's `timeout` (silence), or when more than one frame's worth of bytes in a row do
not make a valid frame (garbage: a wrong baud rate, a wrong profile, a crashed firmware).
"""
import threading

import numpy as np

from ..graph.engine import Driver
from .errors import DeviceError
from .hid_reports import Decoder
from .limits import block_force

READ_TIMEOUT = 0.005        # s: the longest a read waits, so the thread notices a stop


class FrameReader:
    """Splits a byte stream into checked payloads; counts bytes that make no valid frame."""

    def __init__(self, framing):
        self.framing, self.buf, self.junk = framing, bytearray(), 0

    def feed(self, data):
        """The payloads completed by `data`, in order."""
        f, buf, out = self.framing, self.buf, []
        buf += data
        while True:
            at = buf.find(f.sync)
            if at < 0:
                keep = len(f.sync) - 1
                self.junk += max(0, len(buf) - keep)
                del buf[:max(0, len(buf) - keep)]
                return out
            self.junk += at
            del buf[:at]
            if len(buf) < f.size:
                return out
            payload = f.check(bytes(buf[:f.size]))
            if payload is None:
                self.junk += 1
                del buf[:1]
                continue
            out.append(payload)
            self.junk = 0
            del buf[:f.size]


class SerialDriver(Driver):
    """The Driver of one `driver: serial` device entry (see the module's doc)."""

    def __init__(self, name, spec, profile):
        self.name, self.profile = name, profile
        self.port, self.baudrate = spec.get("port"), int(spec.get("baudrate", profile.baudrate))
        self.max_force = float(profile.max_force)
        if spec.get("max_force") is not None:
            self.max_force = min(self.max_force, float(spec["max_force"]))
        self.decoder = Decoder(profile)
        self.columns = ("sensor_x", "sensor_v") + tuple(profile.ports)
        self.row = np.zeros(self.decoder.width)
        self.held = np.zeros(self.decoder.width)
        self.lock, self.posted = threading.Lock(), threading.Event()
        self.line = self.reader = self.writer = None
        self.pending, self.running, self.lost = None, False, None
        self.frames = 0
        self.last_force = 0.0

    def start(self, rate):
        import serial
        try:
            self.line = serial.Serial(self.port, self.baudrate, timeout=READ_TIMEOUT, write_timeout=0.1)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise DeviceError(f"device {self.name!r}: cannot open the serial port {self.port!r} "
                         f"(profile {self.profile.name!r}): {exc}") from None
        self.decoder.reset()
        self.held[:] = 0.0
        self.lost, self.running, self.frames = None, True, 0
        self.reader = threading.Thread(target=self._read_loop, name=f"serial-{self.name}-reader", daemon=True)
        self.writer = threading.Thread(target=self._write_loop, name=f"serial-{self.name}-writer", daemon=True)
        self.reader.start()
        self.writer.start()

    def _read_loop(self):
        import time

        import serial
        frames = FrameReader(self.profile.input.framing)
        limit, timeout = self.profile.input.framing.size, self.profile.input.timeout
        last = time.monotonic()
        try:
            while self.running:
                data = self.line.read(max(1, self.line.in_waiting))
                now = time.monotonic()
                for payload in frames.feed(data):
                    self.decoder.decode(payload, self.row)
                    with self.lock:
                        self.held[:] = self.row
                        self.frames += 1
                    last = now
                if frames.junk > limit:
                    self.lost = f"garbage on the line ({frames.junk} bytes that make no valid frame)"
                elif now - last > timeout:
                    self.lost = f"no frame for more than {timeout:g} s"
                if self.lost:
                    return
        except (serial.SerialException, OSError) as exc:
            if self.running:
                self.lost = f"the serial line failed ({exc})"

    def _write_loop(self):
        import serial
        while self.running:
            self.posted.wait(0.05)
            self.posted.clear()
            force, self.pending = self.pending, None
            if force is None or not self.running:
                continue
            try:
                self.line.write(self.profile.output.encode(force))
            except (serial.SerialException, OSError) as exc:
                self.lost = self.lost or f"the serial line failed ({exc})"
                return

    def fill(self, t0, ext):
        with self.lock:
            ext[:] = self.held

    def send(self, t0, force):
        f = block_force(force, self.max_force)
        self.last_force = f
        self.pending = f
        self.posted.set()

    def stop(self):
        if self.line is None:
            return
        self.running = False
        self.posted.set()
        for thread in (self.reader, self.writer):
            if thread is not None:
                thread.join(timeout=2.0)
        try:                                    # the last word to a device is always "no force"
            self.last_force = 0.0
            self.line.write(self.profile.output.encode(0.0))
            self.line.flush()
        except Exception:  # noqa: BLE001, S110 - the line may be gone (that is why we stop)
            pass
        try:
            self.line.close()
        except Exception:  # noqa: BLE001, S110
            pass
        self.line = None


__all__ = ["FrameReader", "SerialDriver"]
