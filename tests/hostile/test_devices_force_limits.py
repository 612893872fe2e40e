"""The hand stays safe: every device's max_force has an upper bound its profile states (a HID
profile's max_force; the simulated device's 50 N), a device entry above it is refused at load
naming the device, and no NaN, infinity or out-of-range force reaches a device."""
import json

import pytest
from hostile_env import assert_patch_error, run_hg, run_py


HID_PATCH = """\
hapticgraph: 1
devices:
  paddle: {driver: hid, profile: haptic_1dof, max_force: MAXF}
blocks:
  h: {type: haptic, device: paddle}
"""

SIM_PATCH = """\
hapticgraph: 1
devices:
  finger: {driver: simulated, max_force: MAXF, script: [{t: 0.0, x: 0.0}]}
blocks:
  h: {type: haptic, device: finger}
"""


def test_a_hid_entry_above_its_profile_bound_is_refused_at_load(tmp_path):
    p = tmp_path / "p.yaml"
    p.write_text(HID_PATCH.replace("MAXF", "5.0"))
    proc = run_hg("check", p)
    assert_patch_error(proc, "p.yaml:3: device 'paddle': max_force 5 N is above the bound its profile "
                             "'haptic_1dof' states, 4 N")
    p.write_text(HID_PATCH.replace("MAXF", "4.0"))
    assert run_hg("check", p).returncode == 0


def test_a_simulated_entry_above_its_bound_is_refused_at_load(tmp_path):
    p = tmp_path / "p.yaml"
    p.write_text(SIM_PATCH.replace("MAXF", "60"))
    assert_patch_error(run_hg("check", p), "p.yaml:3: device 'finger': max_force 60 N is above the simulated "
                                           "device's bound, 50 N")


@pytest.mark.parametrize("value", [".nan", ".inf", "-1", "0", "1e400"])
def test_max_force_must_be_finite_and_positive(tmp_path, value):
    p = tmp_path / "p.yaml"
    p.write_text(SIM_PATCH.replace("MAXF", value))
    proc = run_hg("check", p)
    assert_patch_error(proc, "p.yaml:3:")
    assert "max_force" in proc.stderr or "finite" in proc.stderr


@pytest.mark.parametrize("value, message", [
    ("40.0", "max_force 40 N does not fit the output's force field"),
    ("1.0e9", "is above 1000 N, the most any device may state"),
    (".inf", "mine.yaml:19: '.inf': numbers must be finite"),
    (".nan", "mine.yaml:19: '.nan': numbers must be finite"),
])
def test_a_profile_states_a_finite_bound(tmp_path, value, message):
    from hapticgraph.devices.hid_profiles import find_profile
    text = open(find_profile("haptic_1dof"), encoding="utf-8").read()
    (tmp_path / "mine.yaml").write_text(text.replace("max_force: 4.0 ", f"max_force: {value} "))
    p = tmp_path / "p.yaml"
    p.write_text(HID_PATCH.replace("haptic_1dof", "mine.yaml").replace("MAXF", "1.0"))
    assert_patch_error(run_hg("check", p), message)


def test_a_command_line_max_force_above_the_profile_is_refused(tmp_path):
    p = tmp_path / "p.yaml"
    p.write_text(SIM_PATCH.replace("MAXF", "3.0"))
    proc = run_hg("run", p, "--seconds", "0.01", "--quiet", "--out", tmp_path / "o.wav",
                  "--device", "finger=hid,profile=haptic_1dof,max_force=5")
    assert_patch_error(proc, "device 'finger' (hid): max_force 5 N is above the bound of its profile "
                             "'haptic_1dof', 4 N")
    assert not (tmp_path / "o.wav").exists()


SEND = r"""
import json, math
import numpy as np
from hapticgraph.devices.hid import HidDriver, ReplayTransport
from hapticgraph.devices.simulated import SimulatedDevice

out = {}
t = ReplayTransport([(0.0, bytes([1]) + bytes(12))])
d = HidDriver("paddle", {"profile": "haptic_1dof", "max_force": 2.0}, transport=t)
d.start(1000.0)
for f in (float("nan"), float("inf"), -float("inf"), 1e300, -7.0, 1.5):
    d.send(0, np.array([0.1, f]))
d.stop()
out["hid"] = t.forces(d.profile)
s = SimulatedDevice("finger", {"max_force": 2.0})
s.start(1000.0)
s.send(0, np.array([float("nan"), float("inf"), -float("inf"), 1e300, -7.0, 1.5]))
out["simulated"] = s.force_sent().tolist()
print(json.dumps(out))
"""


def test_no_nan_or_out_of_range_force_reaches_a_device():
    proc = run_py(SEND)
    assert proc.returncode == 0, proc.stderr
    got = json.loads(proc.stdout)
    # NaN and infinities become 0; the rest is clamped to ±max_force; stop() writes 0 last
    assert got["hid"] == [0.0, 0.0, 0.0, 2.0, -2.0, 1.5, 0.0]
    assert got["simulated"] == [0.0, 0.0, 0.0, 2.0, -2.0, 1.5]
