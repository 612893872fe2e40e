"""`hapticgraph hid profile DEVICE_OR_FILE`: a commented profile written from each descriptor of the
corpus loads without a problem and decodes reports as the descriptor-read device does; written
from a connected device (hidapi stand-in) it carries the device's ids; edited (a name changed) it
overrides the descriptor's names in a patch; a bad file or an absent device is exit 2."""
import pathlib

import numpy as np
import pytest

import hapticgraph
from hapticgraph import load
from hapticgraph.cli import main
from hapticgraph.devices import hid_transports
from hapticgraph.devices.hid import HidDriver, ReplayTransport
from hapticgraph.devices.hid_layout import DescribedDevice
from hapticgraph.devices.hid_profile_text import profile_text
from hapticgraph.devices.hid_profiles import load_profile
from hapticgraph.devices.hid_recording import load_recording
from hapticgraph.devices.hid_sources import descriptor_source
from hidapi_standin import FakeDevice, FakeHidapi

CORPUS = pathlib.Path(__file__).resolve().parent.parent / "data" / "hid"
FILES = sorted(p for p in CORPUS.iterdir() if p.suffix in (".rdesc", ".hid"))


def written(tmp_path, source):
    desc, title, ids, name = descriptor_source(str(source))
    path = tmp_path / "p.yaml"
    path.write_text(profile_text(desc, str(source), title, ids, name or None), encoding="utf-8")
    return desc, path


@pytest.mark.parametrize("source", FILES, ids=[p.name for p in FILES])
def test_a_written_profile_loads_and_decodes_as_the_descriptor(tmp_path, source):
    desc, path = written(tmp_path, source)
    if not any(i.array_value is None for i in desc.inputs):
        assert "no input a profile can read" in path.read_text(encoding="utf-8")
        return
    profile = load_profile(str(path))
    inp = profile.input
    assert inp.length == desc.report_sizes[inp.report_id]
    device = DescribedDevice(desc)
    by_name = {("x_axis" if i.name == "x" else i.name): i for i in device.inputs}
    rng = np.random.default_rng(7)
    for _ in range(20):
        data = bytes(rng.integers(0, 256, inp.length, dtype=np.uint8))
        report = (bytes([inp.report_id]) if inp.report_id else b"") + data
        a, b = profile.decoder(), device.decoder()
        ra, rb = np.zeros(a.width), np.zeros(b.width)
        assert a.decode(report, ra) and b.decode(report, rb)
        got = dict(zip(("x", "v") + profile.ports, ra))
        want = dict(zip(("x", "v") + device.ports, rb))
        for f in inp.axes + inp.buttons:
            i = by_name[f.name]
            if i.kind == "hat" or not i.logical_min <= f.counts(data) <= i.logical_max:
                continue
            assert got[f.name] == pytest.approx(want[i.name], abs=1e-12), (source.name, f.name)
        if "x_axis" in got:
            assert got["x"] == got["x_axis"]          # the profile's position is the X axis


def test_the_profile_text_says_what_it_leaves_out(tmp_path):
    _, path = written(tmp_path, CORPUS / "saitek_joystick_pid_06a3_ff0d.rdesc")
    text = path.read_text(encoding="utf-8")
    assert "name: saitek_joystick_pid_06a3_ff0d" in text and "vendor_id: 0x0000" in text
    assert "position: x_axis" in text and "throttle: {byte: 3, size: 8, scale: 0.00392156862745098}" in text
    assert "# Not in this profile (a profile reads one report and has no arrays): actuators_enabled" in text
    assert "# Force feedback: the device has HID PID output reports (11, 12, 13, 14, 67, 80, 81, 82)" in text


def test_a_profile_of_a_connected_device(monkeypatch, capsys):
    fake = FakeHidapi([FakeDevice(b"/dev/hidraw4", 0x044F, 0x0409,
                                  bytes.fromhex((CORPUS / "thrustmaster_tca_yoke_boeing_044f_0409.rdesc").read_text()),
                                  product="TCA Yoke Boeing", manufacturer="Thrustmaster")])
    monkeypatch.setattr(hid_transports, "hid_module", lambda: fake)
    for ref in ("044f:0409", "/dev/hidraw4"):
        assert main(["hid", "profile", ref]) == 0
        out = capsys.readouterr().out
        assert "vendor_id: 0x044f\nproduct_id: 0x0409\n" in out and "name: thrustmaster_tca_yoke_boeing" in out
        assert "    y: {byte: 3, size: 16, offset: 32767.5," in out
    assert main(["hid", "profile", "044f:0410"]) == 2
    assert capsys.readouterr().err.startswith("044f:0410: no connected HID device matches {vendor: 0x044f, product: 0x0410}")


def test_bad_sources(tmp_path, capsys):
    assert main(["hid", "profile", str(tmp_path / "none.hid")]) == 2
    assert "neither a file nor a connected HID device" in capsys.readouterr().err
    bad = tmp_path / "bad.rdesc"
    bad.write_text("05 01 zz\n", encoding="utf-8")
    assert main(["hid", "profile", str(bad)]) == 2
    assert capsys.readouterr().err.strip() == f"{bad}:1: 'zz' is not a byte in hex"


def test_an_edited_profile_overrides_the_descriptors_names(tmp_path, write_patch):
    source = CORPUS / "sony_ps3_controller_054c_0268.hid"
    _, path = written(tmp_path, source)
    text = path.read_text(encoding="utf-8").replace("    z: {", "    pedal: {")
    (tmp_path / "pad.yaml").write_text(text, encoding="utf-8")
    patch = load(write_patch("""
    hapticgraph: 1
    rate: 1000
    devices:
      pad: {driver: hid, profile: pad.yaml}
    blocks:
      stick: {type: haptic, device: pad}
    connect: []
    """))
    assert "pedal" in [p.name for p in patch.blocks["stick"].outputs]
    driver = HidDriver("pad", patch.devices["pad"], transport=ReplayTransport(load_recording(source).events))
    r = hapticgraph.render(patch, 2.5, probes=["stick.pedal", "stick.x"], drivers={"pad": driver})
    assert r.probes["stick.pedal"][0] == pytest.approx(2 * 0x81 / 255 - 1)
    assert r.probes["stick.pedal"][-1] == pytest.approx(2 * 0x7C / 255 - 1)
    np.testing.assert_allclose(r.probes["stick.x"], 2 * 0x8D / 255 - 1)
