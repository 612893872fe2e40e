"""HID devices: profiles (parsing, every validation error as FILE:LINE), decoding recorded report
bytes of each shipped profile into hand-computed SI values, patches with `driver: hid` rendered
through a ReplayTransport (held values, force reports clamped to max_force, a device that
disappears or stops answering), the live reader/writer threads, and hidapi's real enumerate()."""
import math
import os
import struct
import time

import numpy as np
import pytest
from scipy.io import wavfile

import hapticgraph
from hapticgraph import load
from hapticgraph.cli import main
from hapticgraph.devices import DeviceError, driver_kinds, open_drivers
from hapticgraph.devices.hid_kind import HidKind
from hapticgraph.devices import hid as hidmod
from hapticgraph.devices.hid import Decoder, HidDriver, ReplayTransport, list_hid_devices
from hapticgraph.graph.engine import SafetyStop
from hapticgraph.graph.errors import PatchError
from hapticgraph.devices.hid_profiles import find_profile, load_profile, shipped_dir, shipped_profiles

INCH = 0.0254


def shipped(name):
    return load_profile(find_profile(name))


# -- profiles: the shipped ones ------------------------------------------------------------------

def test_shipped_profiles_are_package_data_and_parse():
    folder = shipped_dir()
    assert os.path.basename(folder) == "profiles" and os.path.basename(os.path.dirname(folder)) == "devices"
    assert {"gamepad", "mouse", "haptic_1dof"} <= set(shipped_profiles())
    pad, mouse, paddle = shipped("gamepad"), shipped("mouse"), shipped("haptic_1dof")
    assert (pad.vendor_id, pad.product_id) == (0x046D, 0xC216) and pad.output is None
    assert pad.ports[:5] == ("left_x", "left_y", "right_x", "right_y", "hat")
    assert pad.ports[5:] == tuple(f"button{i}" for i in range(1, 13))
    assert mouse.ports == ("pos_x", "pos_y", "wheel", "left", "right", "middle") and mouse.output is None
    assert paddle.ports == ("pos", "vel", "current", "button", "endstop")
    assert paddle.max_force == 4.0 and paddle.output.report_id == 2 and paddle.input.timeout == 0.05
    assert paddle.input.position == "pos" and paddle.input.velocity == "vel"


def test_graph_does_not_import_devices_code():
    import hapticgraph.graph as graph
    folder = os.path.dirname(graph.__file__)
    for name in os.listdir(folder):
        if name.endswith(".py"):
            text = open(os.path.join(folder, name), encoding="utf-8").read()
            assert "from ..devices" not in text and "import hapticgraph.devices" not in text, name


# -- profiles: every validation error, as FILE:LINE ----------------------------------------------

GOOD = """\
hid_profile: 1
vendor_id: 0x1209
product_id: 0x0001
max_force: 2.0
input:
  report_id: 1
  length: 8
  interval: 0.001
  timeout: 0.02
  position: pos
  axes:
    pos: {byte: 0, size: 32, signed: true, scale: 1.0e-6, unit: m}
    aux: {byte: 4, size: 8}
  buttons:
    b0: {byte: 5, bit: 0}
    b1: {byte: 5, bit: 1}
output:
  report_id: 2
  length: 2
  force: {byte: 0, size: 16, signed: true, scale: 1000}
"""


def write_profile(tmp_path, text, name="prof.yaml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def problems(tmp_path, text):
    path = write_profile(tmp_path, text)
    with pytest.raises(PatchError) as info:
        load_profile(str(path))
    return [str(p).replace(str(path), "F") for p in info.value.problems]


def test_good_profile_parses(tmp_path):
    p = load_profile(str(write_profile(tmp_path, GOOD)))
    assert p.name == "prof" and p.ports == ("pos", "aux", "b0", "b1")
    assert p.input.read_size == 9 and p.input.velocity == "estimate" and p.input.velocity_cutoff == 50.0


@pytest.mark.parametrize("old, new, expected", [
    # unknown keys, at every level
    ("max_force: 2.0\n", "max_force: 2.0\ncolour: red\n", ["F:5: profile: unknown key 'colour'"]),
    ("  timeout: 0.02\n", "  timeout: 0.02\n  rate: 1000\n", ["F:10: input: unknown key 'rate'"]),
    ("scale: 1.0e-6, unit: m}", "scale: 1.0e-6, unit: m, sgned: true}", ["F:12: input.axes.pos: unknown key 'sgned'"]),
    ("b1: {byte: 5, bit: 1}", "b1: {byte: 5, bit: 1, size: 2}", ["F:16: input.buttons.b1: unknown key 'size'"]),
    # overlapping fields: the later line is reported, naming the earlier
    ("aux: {byte: 4, size: 8}", "aux: {byte: 3, size: 8}",
     ["F:13: input: field 'aux' (bits 24…31) overlaps 'pos' (bits 0…31, line 12)"]),
    ("b1: {byte: 5, bit: 1}", "b1: {byte: 5, bit: 0}",
     ["F:16: input: field 'b1' (bits 40…40) overlaps 'b0' (bits 40…40, line 15)"]),
    # fields outside the report
    ("aux: {byte: 4, size: 8}", "aux: {byte: 7, bit: 4, size: 8}",
     ["F:13: input.axes.aux: bits 60…67 (byte 7, bit 4, size 8) lie outside the report of 8 byte(s)"]),
    ("force: {byte: 0, size: 16", "force: {byte: 1, size: 16",
     ["F:20: output.force: bits 8…23 (byte 1, bit 0, size 16) lie outside the report of 2 byte(s)"]),
    # bad sizes, bits and endianness
    ("aux: {byte: 4, size: 8}", "aux: {byte: 4, size: 0}", ["F:13: input.axes.aux.size: 0 is not a size in bits from 1 to 64"]),
    ("aux: {byte: 4, size: 8}", "aux: {byte: 4, size: 65}", ["F:13: input.axes.aux.size: 65 is not a size in bits from 1 to 64"]),
    ("aux: {byte: 4, size: 8}", "aux: {byte: 4, size: big}", ["F:13: input.axes.aux.size: 'big' is not a size in bits from 1 to 64"]),
    ("b0: {byte: 5, bit: 0}", "b0: {byte: 5, bit: 8}", ["F:15: input.buttons.b0.bit: 8 is outside 0 … 7"]),
    ("aux: {byte: 4, size: 8}", "aux: {byte: 4, size: 4, endian: big}",
     ["F:13: input.axes.aux: endian big needs whole bytes at bit 0 (bit 0, size 4); bit fields are packed little-endian"]),
    ("aux: {byte: 4, size: 8}", "aux: {byte: 4, size: 8, endian: middle}", ["F:13: input.axes.aux.endian: 'middle' is not little or big"]),
    ("aux: {byte: 4, size: 8}", "aux: {byte: 4, size: 1, signed: true}", ["F:13: input.axes.aux: a signed field needs at least 2 bits"]),
    ("aux: {byte: 4, size: 8}", "aux: {byte: 4, size: 8, scale: 0}", ["F:13: input.axes.aux.scale: must not be 0"]),
    ("aux: {byte: 4, size: 8}", "aux: {byte: four}", ["F:13: input.axes.aux.byte: 'four' is not a whole number"]),
    ("aux: {byte: 4, size: 8}", "aux: {size: 8}", ["F:13: input.axes.aux: missing 'byte'"]),
    ("aux: {byte: 4, size: 8}", "aux: 4", ["F:13: input.axes.aux: expected a mapping such as {byte: 0, size: 8}"]),
    # names
    ("aux: {byte: 4, size: 8}", "x: {byte: 4, size: 8}",
     ["F:13: input.axes.x: 'x' is reserved (the haptic block's own ports and settings: t, x, v, force, device, "
      "axes, sensor_x, sensor_v, estimate); choose another name"]),
    ("b1: {byte: 5, bit: 1}", "aux: {byte: 5, bit: 1}", ["F:16: input.buttons.aux: the name 'aux' is used twice (first at line 13)"]),
    ("position: pos", "position: poss", ["F:10: input.position: no axis named 'poss' (axes: pos, aux)"]),
    ("position: pos", "position: pos\n  velocity: speed",
     ["F:11: input.velocity: no axis named 'speed' (axes: pos, aux) or `estimate`"]),
    # reports, timing, ids, limits
    ("  timeout: 0.02\n", "  timeout: 0.001\n", ["F:9: input.timeout: 0.001 s must be longer than the report interval 0.001 s"]),
    ("  interval: 0.001\n", "  interval: 0\n", ["F:8: input.interval: 0 must be greater than 0"]),
    ("  length: 8\n", "  length: eight\n", ["F:7: input.length: 'eight' is not a whole number"]),
    ("  report_id: 1\n", "  report_id: 256\n", ["F:6: input.report_id: 256 is outside 0 … 255"]),
    ("vendor_id: 0x1209\n", "vendor_id: 0x12090\n", ["F:2: profile.vendor_id: 73872 is outside 0 … 65535"]),
    ("vendor_id: 0x1209\n", "", ["F:1: profile: missing 'vendor_id'"]),
    ("max_force: 2.0\n", "", ["F:16: profile: a device with a force output needs `max_force` [N], the limit every force is clamped to"]),
    ("max_force: 2.0\n", "max_force: 40.0\n",
     ["F:4: max_force 40 N does not fit the output's force field (at most 32.767 N with scale 1000)"]),
    ("max_force: 2.0\n", "max_force: -1\n", ["F:4: profile.max_force: -1 must be greater than 0"]),
    ("  force: {byte: 0, size: 16, signed: true, scale: 1000}\n", "",
     ["F:17: output: missing 'force' (the field that carries the force)"]),
    ("hid_profile: 1\n", "hid_profile: 2\n", ["F:1: unsupported HID profile version 2; this hapticgraph reads version 1"]),
    ("hid_profile: 1\n", "", ["F:1: the first key must be `hid_profile: 1` (the profile format version)"]),
    ("  axes:\n", "  axes: [\n", None),    # a YAML syntax error: FILE:LINE from the parser
])
def test_profile_validation_errors(tmp_path, old, new, expected):
    assert old in GOOD
    found = problems(tmp_path, GOOD.replace(old, new, 1))
    if expected is None:
        assert len(found) == 1 and found[0].startswith("F:") and "YAML syntax" in found[0]
        return
    assert [f.split("; allowed:")[0] for f in found] == expected


def test_several_problems_are_all_reported(tmp_path):
    text = GOOD.replace("aux: {byte: 4, size: 8}", "aux: {byte: 3, size: 8, unit: [m]}").replace(
        "colour", "").replace("b1: {byte: 5, bit: 1}", "b1: {byte: 9, bit: 1}")
    found = problems(tmp_path, text)
    assert found == ["F:13: input.axes.aux.unit: ['m'] is not text",
                     "F:16: input.buttons.b1: bits 73…73 (byte 9, bit 1, size 1) lie outside the report of 8 byte(s)"]


# -- decoding recorded report bytes of each shipped profile -----------------------------------------

def decode(profile, *reports):
    dec = Decoder(profile)
    row = np.zeros(dec.width)
    rows = []
    for r in reports:
        assert dec.decode(bytes(r), row)
        rows.append(dict(zip(("x", "v") + profile.ports, row.tolist())))
    return rows, dec


def test_decode_gamepad():
    pad = shipped("gamepad")
    #        LX  LY   RX   RY  hat 8 + buttons 1,2  buttons 5,12  unused
    (r,), _ = decode(pad, [0, 255, 128, 64, 0x38, 0x81, 0x00, 0xFF])
    assert r["left_x"] == pytest.approx(-1.0) and r["left_y"] == pytest.approx(1.0)
    assert r["right_x"] == pytest.approx(0.5 / 127.5) and r["right_y"] == pytest.approx(-63.5 / 127.5)
    assert r["hat"] == 8
    assert [r[f"button{i}"] for i in range(1, 13)] == [1, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1]
    assert r["x"] == r["left_x"] and r["v"] == 0.0           # position: left_x; first report: v = 0


def test_decode_mouse_relative_axes_and_estimated_velocity():
    mouse = shipped("mouse")
    count = INCH / 800
    rows, _ = decode(mouse, [0b101, 0x05, 0xFB, 0xFF], [0b000, 0x05, 0x00, 0x02], [0b010, 0xFE, 0x00, 0x00])
    assert rows[0]["left"] == 1 and rows[0]["middle"] == 1 and rows[0]["right"] == 0
    assert rows[0]["pos_x"] == pytest.approx(5 * count) and rows[0]["pos_y"] == pytest.approx(-5 * count)
    assert rows[0]["wheel"] == -1 and rows[1]["wheel"] == 1
    assert [r["pos_x"] for r in rows] == pytest.approx([5 * count, 10 * count, 8 * count])
    assert rows[2]["right"] == 1 and rows[2]["left"] == 0
    # v: backward difference over the 8 ms report interval, one-pole smoothing at 20 Hz
    a = 1 - math.exp(-2 * math.pi * 20 * 0.008)
    v1 = a * (5 * count / 0.008)
    v2 = v1 + a * (-2 * count / 0.008 - v1)
    assert [r["v"] for r in rows] == pytest.approx([0.0, v1, v2])


def test_decode_haptic_1dof():
    paddle = shipped("haptic_1dof")
    data = struct.pack("<ihB", -123456, -250, 0b10) + b"\x00" + struct.pack(">h", 500) + b"\x00\x00"
    (r,), dec = decode(paddle, b"\x01" + data)
    assert r["pos"] == pytest.approx(-0.123456) and r["x"] == pytest.approx(-0.123456)
    assert r["vel"] == pytest.approx(-0.025) and r["v"] == pytest.approx(-0.025)   # reported, not estimated
    assert r["current"] == pytest.approx(0.5)          # big-endian 0x01F4 = 500 mA
    assert r["button"] == 0 and r["endstop"] == 1
    row = np.zeros(dec.width)
    assert not dec.decode(b"\x03" + data, row)          # another report id: not ours
    assert not dec.decode(b"\x01" + data[:5], row)      # too short
    # the force report: id 2, int16 little-endian, 1 mN per count
    out = paddle.output
    assert bytes(out.encode(1.5)) == b"\x02\xdc\x05\x00\x00"
    assert bytes(out.encode(-4.0)) == b"\x02\x60\xf0\x00\x00"
    assert out.decode(out.encode(-4.0)) == -4.0
    assert bytes(out.encode(1e9)) == b"\x02\xff\x7f\x00\x00"     # limited to what the field holds


def test_bit_fields_across_bytes_and_big_endian_signed(tmp_path):
    text = GOOD.replace("aux: {byte: 4, size: 8}", "aux: {byte: 4, bit: 4, size: 12, signed: true, offset: 1, scale: 0.5}")
    text = text.replace("pos: {byte: 0, size: 32, signed: true, scale: 1.0e-6, unit: m}",
                        "pos: {byte: 0, size: 32, signed: true, endian: big, scale: 1.0e-6, unit: m}")
    text = text.replace("b0: {byte: 5, bit: 0}", "b0: {byte: 6, bit: 0}").replace("b1: {byte: 5, bit: 1}", "b1: {byte: 7, bit: 7}")
    p = load_profile(str(write_profile(tmp_path, text)))
    # aux: 12 bits from byte 4, bit 4: bytes 4-5 little-endian 0xFFA3 >> 4 = 0xFFA, 12-bit signed = −6
    report = b"\x01" + struct.pack(">i", -2) + bytes([0xA3, 0xFF, 0x01, 0x80])
    (r,), _ = decode(p, report)
    assert r["pos"] == pytest.approx(-2e-6)
    assert r["aux"] == pytest.approx((-6 - 1) * 0.5)
    assert r["b0"] == 1 and r["b1"] == 1


# -- patches with driver: hid, through a replayed device ----------------------------------------------

PADDLE_PATCH = """
hapticgraph: 1
rate: 4000
devices:
  paddle: {driver: hid, profile: haptic_1dof, max_force: 2.0}
blocks:
  pick: {type: haptic, device: paddle}
  push: {type: constant, value: 10.0}
  out: {type: audio_out, channels: 1}
connect:
  - push.out -> pick.force
  - pick.x -> out.ch0
"""


def paddle_report(pos_um, vel, buttons=0, current_ma=0):
    return b"\x01" + struct.pack("<ihB", pos_um, vel, buttons) + b"\x00" + struct.pack(">h", current_ma) + b"\x00\x00"


def paddle_reports(n=400, period=0.001):
    """Report k at k ms: pos = 10·k µm, vel = 5·k (×0.1 mm/s), button on odd k, current k mA."""
    return [(k * period, paddle_report(10 * k, 5 * k, k % 2, k)) for k in range(n)]


def paddle_render(write_patch, reports, seconds, chunk=64, end="silent", text=PADDLE_PATCH):
    patch = load(write_patch(text))
    transport = ReplayTransport(reports, end=end)
    driver = HidDriver("paddle", patch.devices["paddle"], transport=transport)
    probes = ["pick.x", "pick.v", "pick.button", "pick.current", "pick.endstop"]
    try:
        result = hapticgraph.render(patch, seconds, probes=probes, drivers={"paddle": driver}, chunk=chunk)
        stop = None
    except SafetyStop as exc:
        result, stop = exc.result, exc
    return result, driver, transport, stop


def test_patch_follows_the_replayed_reports_and_force_is_clamped(write_patch):
    r, driver, transport, stop = paddle_render(write_patch, paddle_reports(), 0.1)
    assert stop is None and r.audio.shape == (400, 1)
    n = np.arange(400)
    k = n // 4                     # 4 samples per 1 ms report: each sample holds the report stamped at or before it
    np.testing.assert_allclose(r.probes["pick.x"], 10e-6 * k, rtol=1e-12)
    np.testing.assert_allclose(r.probes["pick.v"], 5e-4 * k, rtol=1e-12)
    np.testing.assert_array_equal(r.probes["pick.button"], k % 2)
    np.testing.assert_allclose(r.probes["pick.current"], 1e-3 * k, rtol=1e-12)
    np.testing.assert_array_equal(r.probes["pick.endstop"], 0.0)
    np.testing.assert_allclose(r.audio[:, 0], r.probes["pick.x"])
    # one force report per block (the last sample's force, 10 N clamped to the entry's 2 N),
    # then the zero force that stop() always writes last
    forces = transport.forces(driver.profile)
    assert forces == [2.0] * (400 // 64 + 1) + [0.0]
    assert all(d[:1] == b"\x02" and len(d) == 5 for _, d in transport.written)
    assert not transport.is_open and driver.lost is None
    # hidapi's read never waits for ever: every read had a timeout of 1 … 20 ms
    assert transport.reads and all(1 <= t <= 20 for t in transport.reads)


def test_render_does_not_depend_on_the_block_size(write_patch):
    a, *_ = paddle_render(write_patch, paddle_reports(), 0.1, chunk=7)
    b, *_ = paddle_render(write_patch, paddle_reports(), 0.1, chunk=4096)
    for key in a.probes:
        np.testing.assert_array_equal(a.probes[key], b.probes[key])


def test_profile_max_force_applies_when_the_entry_gives_none(write_patch):
    text = PADDLE_PATCH.replace(", max_force: 2.0", "")
    r, driver, transport, _ = paddle_render(write_patch, paddle_reports(100), 0.02, text=text)
    assert driver.max_force == 4.0 and set(transport.forces(driver.profile)[:-1]) == {4.0}


def test_nan_force_sends_zero(write_patch):
    patch = load(write_patch(PADDLE_PATCH))
    transport = ReplayTransport(paddle_reports(10))
    driver = HidDriver("paddle", patch.devices["paddle"], transport=transport)
    driver.start(4000)
    for f in (math.nan, math.inf, -math.inf, -3.0, 1.25):
        driver.send(0, np.array([0.0, f]))
    driver.stop()
    assert transport.forces(driver.profile) == [0.0, 0.0, 0.0, -2.0, 1.25, 0.0]


def test_device_disappearing_mid_run_ends_cleanly(write_patch):
    reports = paddle_reports(101) + [(0.1005, None)]     # unplugged 0.5 ms after the report at 100 ms
    r, driver, transport, stop = paddle_render(write_patch, reports, 0.5)
    assert stop is not None and "stopped answering" in str(stop) and "device disconnected" in str(stop)
    assert driver.lost.startswith("read failed")
    # the block holding the loss (samples 384 … 447) sent zero force and is dropped; before it is kept
    assert r.audio.shape == (384, 1)
    np.testing.assert_allclose(r.probes["pick.x"], 10e-6 * (np.arange(384) // 4), rtol=1e-12)
    forces = transport.forces(driver.profile)
    assert forces == [2.0] * 6 + [0.0, 0.0] and forces[-1] == 0.0
    assert not transport.is_open


def test_device_that_stops_answering_ends_cleanly(write_patch):
    # reports stop after 50 ms; the profile's timeout is 50 ms: lost once 50 ms pass without one
    r, driver, transport, stop = paddle_render(write_patch, paddle_reports(51), 0.5)
    assert stop is not None and "no report for more than 0.05 s" in str(stop)
    assert r.audio.shape[0] == 384        # the loss (at 100 … 102 ms) is in the block of samples 384 … 447
    assert transport.forces(driver.profile)[-2:] == [0.0, 0.0]


MOUSE_PATCH = """
hapticgraph: 1
rate: 1000
devices:
  m: {driver: hid, profile: mouse}
blocks:
  pick: {type: haptic, device: m}
connect: []
"""


def test_mouse_patch_estimated_velocity_decays_when_still(write_patch):
    patch = load(write_patch(MOUSE_PATCH))
    assert [p.name for p in patch.blocks["pick"].outputs] == ["x", "v", "pos_x", "pos_y", "wheel", "left", "right", "middle"]
    reports = [(0.000, bytes([0, 0, 0, 0])), (0.008, bytes([0, 4, 0, 0])), (0.016, bytes([0, 4, 0, 0])),
               (0.100, bytes([1, 0xFE, 0, 0]))]
    transport = ReplayTransport(reports)
    driver = HidDriver("m", patch.devices["m"], transport=transport)
    r = hapticgraph.render(patch, 0.15, probes=["pick.x", "pick.v", "pick.left"], drivers={"m": driver}, chunk=50)
    c, a = INCH / 800, 1 - math.exp(-2 * math.pi * 20 * 0.008)
    x, v = r.probes["pick.x"], r.probes["pick.v"]
    np.testing.assert_allclose(x[[0, 7, 8, 15, 16, 99, 100, 149]], [0, 0, 4 * c, 4 * c, 8 * c, 8 * c, 6 * c, 6 * c])
    v1 = a * 4 * c / 0.008
    v2 = v1 + a * (4 * c / 0.008 - v1)
    # silent from 16 ms: a step with no motion every two intervals (16 ms: 32, 48, 64, 80, 96 ms)
    expect = {0: 0.0, 7: 0.0, 8: v1, 15: v1, 16: v2, 31: v2, 32: v2 * (1 - a), 48: v2 * (1 - a) ** 2,
              64: v2 * (1 - a) ** 3, 80: v2 * (1 - a) ** 4, 96: v2 * (1 - a) ** 5, 99: v2 * (1 - a) ** 5}
    for n, value in expect.items():
        assert v[n] == pytest.approx(value, rel=1e-12, abs=1e-15), n
    v6 = v2 * (1 - a) ** 5 + a * (-2 * c / 0.008 - v2 * (1 - a) ** 5)
    assert v[100] == pytest.approx(v6) and v[115] == pytest.approx(v6) and v[116] == pytest.approx(v6 * (1 - a))
    np.testing.assert_array_equal(r.probes["pick.left"][[99, 100]], [0, 1])
    assert transport.written == []                     # a mouse has no force output


def test_gamepad_axes_are_ports_and_drive_a_patch(write_patch):
    text = """
    hapticgraph: 1
    rate: 1000
    devices:
      pad: {driver: hid, profile: gamepad, vendor_id: 0x054c, product_id: 0x05c4}
    blocks:
      stick: {type: haptic, device: pad}
      tone: {type: gain, gain: 1.0}
      one: {type: constant, value: 1.0}
    connect:
      - one.out -> tone.in
      - stick.right_y -> tone.gain
    """
    patch = load(write_patch(text))
    driver = HidDriver("pad", patch.devices["pad"], transport=ReplayTransport(
        [(0.0, bytes([128, 128, 128, 255, 8, 0, 0, 0])), (0.01, bytes([128, 128, 128, 0, 0x18, 0, 0, 0]))]))
    assert driver.profile.name == "gamepad" and driver.transport.opened == 1
    r = hapticgraph.render(patch, 0.02, probes=["tone.out", "stick.button1", "stick.hat"], drivers={"pad": driver})
    np.testing.assert_allclose(r.probes["tone.out"][[0, 9, 10, 19]], [1.0, 1.0, -1.0, -1.0])
    np.testing.assert_array_equal(r.probes["stick.button1"][[9, 10]], [0, 1])
    np.testing.assert_array_equal(r.probes["stick.hat"][[9, 10]], [8, 8])


def test_profile_file_beside_the_patch(write_patch, tmp_path):
    write_profile(tmp_path, GOOD, "knob.yaml")
    text = """
    hapticgraph: 1
    rate: 1000
    devices:
      k: {driver: hid, profile: knob.yaml}
    blocks:
      pick: {type: haptic, device: k}
      g: {type: gain}
    connect:
      - pick.aux -> g.in
      - pick.b1 -> g.gain
    """
    patch = load(write_patch(text))
    assert patch.devices["k"].hid_profile.ports == ("pos", "aux", "b0", "b1")
    transport = ReplayTransport([(0.0, b"\x01" + bytes([0, 0, 0, 0, 7, 0b10, 0, 0]))])
    drivers = {"k": HidDriver("k", patch.devices["k"], transport=transport)}
    # the knob streams with a 20 ms timeout: one report, then silence, so it is lost after 20 ms
    with pytest.raises(SafetyStop, match="no report for more than 0.02 s") as info:
        hapticgraph.render(patch, 1.0, probes=["g.out"], drivers=drivers, chunk=10)
    np.testing.assert_array_equal(info.value.result.probes["g.out"], 7.0)
    assert transport.forces(drivers["k"].profile)[-1] == 0.0


# -- live timing: the reader and writer threads on the wall clock ----------------------------------

def test_live_reader_holds_the_newest_report_and_writer_clamps(write_patch):
    patch = load(write_patch(PADDLE_PATCH))
    transport = ReplayTransport(paddle_reports(30, period=0.002), virtual=False)
    driver = HidDriver("paddle", patch.devices["paddle"], transport=transport)
    assert not driver.stamped
    driver.start(4000)
    try:
        ext = np.zeros((64, len(driver.columns)))
        deadline = time.monotonic() + 5
        while driver.lost is None and time.monotonic() < deadline:
            time.sleep(0.01)
        driver.fill(0, ext)
        # the newest report (k = 29) held over the whole block
        np.testing.assert_allclose(ext[:, 0], 290e-6)
        np.testing.assert_allclose(ext[:, driver.columns.index("current")], 0.029)
        # 30 reports over 58 ms, then silence: lost after the 50 ms timeout
        assert driver.lost == "no report for more than 0.05 s"
        driver.send(0, np.array([0.0, 9.0]))
        deadline = time.monotonic() + 5
        while not transport.written and time.monotonic() < deadline:
            time.sleep(0.005)
        assert transport.forces(driver.profile) == [2.0]
    finally:
        t = time.monotonic()
        driver.stop()
        assert time.monotonic() - t < 1.0                 # reads time out: the thread stops at once
    assert transport.forces(driver.profile)[-1] == 0.0 and not transport.is_open
    assert all(1 <= t <= 20 for t in transport.reads)


def test_live_unplugged_device_is_lost(write_patch):
    patch = load(write_patch(MOUSE_PATCH))
    transport = ReplayTransport([(0.0, bytes(4)), (0.01, None)], virtual=False)
    driver = HidDriver("m", patch.devices["m"], transport=transport)
    driver.start(1000)
    deadline = time.monotonic() + 5
    while driver.lost is None and time.monotonic() < deadline:
        time.sleep(0.005)
    driver.stop()
    assert driver.lost == "read failed (device disconnected)"


# -- real hidapi ------------------------------------------------------------------------------------

def test_hidapi_enumerate_runs():
    devices = list_hid_devices()
    assert isinstance(devices, list)
    for d in devices:
        assert {"vendor_id", "product_id", "path", "profile"} <= set(d)
        assert isinstance(d["path"], str)


def test_opening_a_device_that_is_not_there(write_patch, capsys):
    if any((d["vendor_id"], d["product_id"]) == (0x1209, 0x0001) for d in list_hid_devices()):
        pytest.skip("a device with pid.codes' test ids is connected")
    patch = load(write_patch(PADDLE_PATCH))
    assert isinstance(driver_kinds()["hid"], HidKind)     # the kind that opens HidDriver
    with pytest.raises(DeviceError, match=r"cannot open the HID device 1209:0001 .*hapticgraph devices"):
        open_drivers(patch)
    code = main(["run", str(patch.file), "--seconds", "0.01", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "1209:0001" in err and "Traceback" not in err


# -- bad patches: exit 2, nothing sent to a device ----------------------------------------------------

class Spy:
    """Stands in for HidapiTransport: counts what would have reached a device."""
    made = []

    def __init__(self, *args, **kwargs):
        Spy.made.append(args)
        self.inner = ReplayTransport(paddle_reports(10))

    def __getattr__(self, name):
        return getattr(self.inner, name)


def test_unknown_profile_is_a_patch_error(write_patch, monkeypatch, capsys):
    Spy.made = []
    monkeypatch.setattr(hidmod, "HidapiTransport", Spy)
    path = write_patch(PADDLE_PATCH.replace("profile: haptic_1dof", "profile: haptic_1dfo"))
    assert main(["run", str(path), "--seconds", "0.01", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"{path}:4: device 'paddle': no HID profile 'haptic_1dfo' "
                   f"(shipped: {', '.join(shipped_profiles())}; or a .yaml file beside the patch)"]
    assert Spy.made == []


def test_profile_with_overlapping_fields_is_a_patch_error(write_patch, tmp_path, monkeypatch, capsys):
    Spy.made = []
    monkeypatch.setattr(hidmod, "HidapiTransport", Spy)
    prof = write_profile(tmp_path, GOOD.replace("aux: {byte: 4, size: 8}", "aux: {byte: 2, size: 16}"), "bad.yaml")
    path = write_patch(PADDLE_PATCH.replace("profile: haptic_1dof", "profile: bad.yaml"))
    assert main(["run", str(path), "--seconds", "0.01", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert sorted(err) == sorted([
        f"{path}:4: device 'paddle': HID profile 'bad.yaml' has 1 problem(s), listed at its own file and lines",
        f"{prof}:13: input: field 'aux' (bits 16…31) overlaps 'pos' (bits 0…31, line 12)"])
    assert Spy.made == []
    assert main(["check", str(path)]) == 2


def test_device_entry_schema(write_patch, capsys):
    path = write_patch("""
    hapticgraph: 1
    devices:
      a: {driver: hid}
      b: {driver: hid, profile: mouse, seral: "X1"}
      c: {driver: hid, profile: mouse, serial: "X1", path: "/dev/hidraw0", vendor_id: 0x1234, product_id: 70000}
    blocks: {}
    """)
    with pytest.raises(PatchError) as info:
        load(path)
    text = [str(p).replace(str(path), "F") for p in info.value.problems]
    assert any(t.startswith("F:3:") and "'profile'" in t for t in text)
    assert any(t.startswith("F:4:") and "'seral'" in t for t in text)
    assert any(t.startswith("F:5:") and "70000" in t for t in text)
    assert len(text) == 3


def test_run_with_a_device_that_disappears_writes_what_was_rendered(write_patch, tmp_path, monkeypatch, capsys):
    """Through the command line: the mouse is unplugged at 17 s, after the first 16384-sample block."""
    made = []

    def transport(*args, **kwargs):
        made.append(ReplayTransport([(0.0, bytes(4)), (1.0, bytes([0, 10, 0, 0])), (17.0, None)]))
        return made[-1]

    monkeypatch.setattr(hidmod, "HidapiTransport", transport)
    path = write_patch(MOUSE_PATCH.replace("connect: []", "  out: {type: audio_out, channels: 1}\nconnect:\n  - pick.pos_x -> out.ch0"))
    out = tmp_path / "m.wav"
    code = main(["run", str(path), "--seconds", "20", "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 1 and "stopped answering" in err and "device disconnected" in err and "Traceback" not in err
    rate, data = wavfile.read(out)
    assert rate == 1000 and data.shape[0] == 16384
    assert data[999] == 0 and data[1000] == pytest.approx(10 * INCH / 800)
    assert len(made) == 1 and not made[0].is_open
