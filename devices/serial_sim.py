"""A firmware simulator for serial haptic devices on a pseudo-terminal (os.openpty), for tests and
demos: it speaks a serial profile's wire protocol like the device's firmware would.

    with SerialSim("fader_1dof", motion=lambda t: {"pos": 0.01 * math.sin(6 * t)}) as sim:
        ...  # a device entry {driver: serial, profile: fader_1dof, port: sim.path}

It sends a frame every `interval` of the profile with the axes `motion(t)` gives (SI units; t in
seconds since start; buttons too), and records every force frame it receives in `forces` as
(t, newtons). Faults, for the driver's safety paths: `silence()` stops sending, `garbage(n)`
sends n random bytes instead of frames, `unplug()` closes the line.
"""
import os
import random
import select
import threading
import time
import tty

from .serial_port import FrameReader
from .serial_profiles import find_profile, load_profile


class SerialSim:
    def __init__(self, profile, motion=None):
        if isinstance(profile, str):
            profile = load_profile(find_profile(profile))
        self.profile, self.motion = profile, motion or (lambda t: {})
        self.forces, self.mode = [], "frames"
        self.master, slave = os.openpty()
        tty.setraw(slave)
        self.path = os.ttyname(slave)
        self._slave = slave         # held open so the line does not hang up before the driver opens it
        self.running, self.thread, self.t0 = False, None, None

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc):
        self.close()

    def start(self):
        self.running, self.t0 = True, time.monotonic()
        self.thread = threading.Thread(target=self._loop, name="serial-sim", daemon=True)
        self.thread.start()

    def frame(self, values):
        """The input frame carrying `values` (axis/button name -> SI value)."""
        inp = self.profile.input
        buf = bytearray(inp.framing.length)
        for f in inp.axes:
            f.put(buf, 0, round(values.get(f.name, 0.0) / f.scale + f.offset))
        for f in inp.buttons:
            f.put(buf, 0, int(values.get(f.name, 0)))
        return inp.framing.frame(buf)

    def _loop(self):
        interval, reader = self.profile.input.interval, FrameReader(self.profile.output.framing)
        at = self.t0
        while self.running:
            t = time.monotonic() - self.t0
            try:
                if self.mode == "frames":
                    os.write(self.master, self.frame(self.motion(t)))
                elif isinstance(self.mode, int):
                    os.write(self.master, bytes(random.randrange(256) for _ in range(self.mode)))
                    self.mode = "silent"
                while select.select([self.master], [], [], 0)[0]:
                    for payload in reader.feed(os.read(self.master, 4096)):
                        frame = self.profile.output.framing.frame(payload)
                        self.forces.append((t, self.profile.output.decode(frame)))
            except OSError:
                return
            at += interval
            time.sleep(max(0.0, at - time.monotonic()))

    def silence(self):
        self.mode = "silent"

    def garbage(self, n=64):
        self.mode = int(n)

    def unplug(self):
        self.running = False
        if self.thread is not None:
            self.thread.join(timeout=2.0)
        for fd in (self.master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        self.master = self._slave = -1

    def close(self):
        if self.master >= 0:
            self.unplug()


__all__ = ["SerialSim"]
