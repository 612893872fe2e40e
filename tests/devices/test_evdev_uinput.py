"""`driver: evdev` against a real kernel device: a uinput device with EV_FF (python-evdev's UInput)
whose force-feedback requests this test serves — each upload and erase the driver makes reaches
the test's thread as a UI_FF_UPLOAD / UI_FF_ERASE request (begin_upload / end_upload), and gain,
autocentre, play and stop as EV_FF events — so what the kernel is asked is checked, not what a
stand-in records (tests/devices/test_evdev.py does that). Needs a writable /dev/uinput (and the
event node it makes readable); skipped where there is none."""
import os
import select
import textwrap
import threading
import time

import pytest
from evdev import AbsInfo, UInput, ecodes

import hapticgraph
from hapticgraph.devices.evdev_ff import FULL, SLEW
from hapticgraph.devices.evdev_kind import EvdevKind
from hapticgraph.devices.table import driver_kinds

UINPUT = "/dev/uinput"
RATE, BLOCK = 44100, 64
pytestmark = pytest.mark.skipif(not os.access(UINPUT, os.R_OK | os.W_OK),
                                reason=f"no writable {UINPUT} here: the uinput force-feedback test needs one "
                                       f"(load the uinput module, or run where the user may write it)")


class Served:
    """A uinput wheel (steering ABS_X, a button, FF_CONSTANT, FF_GAIN, FF_AUTOCENTER) and the thread
    that answers its force-feedback requests, recording them in order:
    ("ff", code, value) for an EV_FF event (gain, autocentre, play/stop of an effect id),
    ("upload", id, type, direction, level), ("erase", id)."""

    def __init__(self):
        events = {ecodes.EV_ABS: [(ecodes.ABS_X, AbsInfo(32768, 0, 65535, 0, 0, 0))],
                  ecodes.EV_KEY: [ecodes.BTN_TRIGGER],
                  ecodes.EV_FF: [ecodes.FF_CONSTANT, ecodes.FF_GAIN, ecodes.FF_AUTOCENTER]}
        self.ui = UInput(events, name="hapticgraph uinput wheel", vendor=0x1209, product=0x0001)
        self.calls, self.done = [], threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        ui = self.ui
        while not self.done.is_set():
            ready, _, _ = select.select([ui.fd], [], [], 0.05)
            if not ready:
                continue
            event = ui.read_one()
            while event is not None:
                self._answer(event)
                event = ui.read_one()

    def _answer(self, event):
        ui = self.ui
        if event.type == ecodes.EV_FF:
            self.calls.append(("ff", event.code, event.value))
        elif event.type == ecodes.EV_UINPUT and event.code == ecodes.UI_FF_UPLOAD:
            upload = ui.begin_upload(event.value)
            e = upload.effect
            self.calls.append(("upload", e.id, e.type, e.direction, e.u.ff_constant_effect.level))
            upload.retval = 0
            ui.end_upload(upload)
        elif event.type == ecodes.EV_UINPUT and event.code == ecodes.UI_FF_ERASE:
            erase = ui.begin_erase(event.value)
            self.calls.append(("erase", erase.effect_id))
            erase.retval = 0
            ui.end_erase(erase)

    def close(self):
        self.done.set()
        self.thread.join(timeout=2.0)
        self.ui.close()


@pytest.fixture
def wheel():
    try:
        served = Served()
    except OSError as exc:        # UInput opens the event node it made: PermissionError, FileNotFoundError
        pytest.skip(f"the event node {UINPUT} made cannot be opened by this user ({exc})")
    try:
        if served.ui.device is None:
            pytest.skip(f"the event node {UINPUT} made cannot be opened by this user")
        yield served
    finally:
        served.close()


def patch_file(tmp_path, path, force):
    out = tmp_path / "uinput_wheel.yaml"
    out.write_text(textwrap.dedent(f"""\
        hapticgraph: 1
        name: uinput wheel
        rate: {RATE}
        devices:
          wheel: {{driver: evdev, match: {{path: {path}}}, max_force: 0.4}}
        blocks:
          push: {{type: constant, value: {force}}}
          w: {{type: haptic, device: wheel}}
          out: {{type: audio_out, channels: 1}}
        connect:
          - push.out -> w.force
          - w.x -> out.ch0
        """))
    return out


def settle(calls, last, seconds=2.0):
    """Wait until the serving thread has read the call `last` (EV_FF writes arrive as events, after
    the write has returned)."""
    end = time.monotonic() + seconds
    while (not calls or calls[-1] != last) and time.monotonic() < end:
        time.sleep(0.01)


def test_the_kernel_is_asked_for_the_patch_force_clamped_then_zero_stop_erase(wheel, tmp_path):
    patch = hapticgraph.load(str(patch_file(tmp_path, wheel.ui.device.path, 1.0)),
                             drivers={**driver_kinds(), "evdev": EvdevKind()})
    with hapticgraph.Session.open(patch, blocksize=BLOCK) as s:
        for _ in range(60):
            s.process(BLOCK)
    settle(wheel.calls, ("ff", ecodes.FF_AUTOCENTER, 0xFFFF))
    calls = list(wheel.calls)
    assert calls[:2] == [("ff", ecodes.FF_GAIN, 0xFFFF), ("ff", ecodes.FF_AUTOCENTER, 0)]
    first = calls[2]
    assert first[0] == "upload" and first[2:] == (ecodes.FF_CONSTANT, 0xC000, 0)
    effect = first[1]                                     # the id the kernel gave the effect
    assert calls[3] == ("ff", effect, 1)                  # played
    uploads = [c for c in calls if c[0] == "upload"]
    assert {c[1] for c in uploads} == {effect} and {c[2] for c in uploads} == {ecodes.FF_CONSTANT}
    levels = [c[4] for c in uploads]
    top = round(0.4 * FULL)                               # max_force 0.4 of full scale: 1.0 N asked
    step = SLEW * BLOCK / RATE * FULL
    rising = levels[1:levels.index(top)]
    assert len(rising) >= 5 and all(0 < b - a <= step + 1 for a, b in zip([0] + rising, rising))
    assert max(levels) == top and levels[-2] == top
    # zero, stop, erase (which the kernel precedes with a stop of its own: ff-core.c, erase_effect),
    # autocentring back
    assert calls[-5:] == [("upload", effect, ecodes.FF_CONSTANT, 0xC000, 0), ("ff", effect, 0), ("ff", effect, 0),
                          ("erase", effect), ("ff", ecodes.FF_AUTOCENTER, 0xFFFF)]
