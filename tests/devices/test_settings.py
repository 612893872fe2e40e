"""`--device NAME=DRIVER[,KEY=VALUE...]` in-process: settings parsed as YAML scalars and checked
by the driver's schema; a file's profile (relative to the patch) is kept when a setting changes
something else; keys of another driver are left out with a note."""
import pytest

from hapticgraph import load
from hapticgraph.devices import Choice, DeviceError, open_drivers, parse_choice
from hapticgraph.devices.hid_profiles import find_profile


def test_values_are_yaml_scalars_checked_by_the_schema():
    name, choice = parse_choice("paddle=hid,profile=haptic_1dof,max_force=2,vendor_id=0x1209,serial=007")
    assert name == "paddle" and choice.driver == "hid"
    assert choice.settings == {"profile": "haptic_1dof", "max_force": 2, "vendor_id": 0x1209, "serial": "007"}
    with pytest.raises(DeviceError, match="hold=maybe: 'maybe' is not of type 'boolean'"):
        parse_choice("f=simulated,hold=maybe")


def test_a_file_profile_is_kept_and_other_drivers_keys_noted(tmp_path, monkeypatch):
    text = open(find_profile("haptic_1dof"), encoding="utf-8").read().replace("name: haptic_1dof", "name: mine")
    (tmp_path / "mine.yaml").write_text(text)
    (tmp_path / "p.yaml").write_text("hapticgraph: 1\ndevices:\n  paddle: {driver: hid, profile: mine.yaml}\n"
                                     "blocks:\n  h: {type: haptic, device: paddle}\n")
    patch = load(tmp_path / "p.yaml")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)               # the profile is found beside the patch, not here
    notes = []
    with pytest.raises(DeviceError, match=r"cannot open the HID device 1209:0001 \(profile 'mine'\)"):
        open_drivers(patch, {"paddle": Choice("hid", {"max_force": 1.0})}, notes=notes)
    assert notes == []
    drivers = open_drivers(patch, {"paddle": Choice("simulated", {"mass": 0.1})}, notes=notes)
    assert notes == ["device 'paddle' (simulated): ignoring profile of the patch's hid entry "
                     "(the simulated driver does not read them)"]
    # the simulated stand-in still supplies the profile's axes (as zeros) the patch's block has
    assert drivers["paddle"].columns == ("hand_x", "hand_v", "pos", "vel", "current", "button", "endstop")
    assert drivers["paddle"].values["mass"] == 0.1
