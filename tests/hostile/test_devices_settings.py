"""`--device NAME=DRIVER[,KEY=VALUE...]`: errors that teach (an unknown setting says what the
driver accepts, an unknown driver lists the drivers, an unknown device lists the patch's), values
checked like the file's, and a patch written for the simulated device plays on a HID device
without editing (its script is ignored with a note) up to the clean "no device" exit."""

import pytest

from audio_env import alsa_file_env

from hostile_env import assert_patch_error, run_hg

SIM_PATCH = """\
hapticgraph: 1
name: simulated finger
devices:
  finger: {driver: simulated, max_force: 3.0, mass: 0.05, script: [{t: 0.0, x: 0.0}, {t: 0.1, x: 0.002}]}
blocks:
  h: {type: haptic, device: finger}
  k: {type: spring_damper, k: 100.0, R: 0.1}
  out: {type: audio_out, channels: 1}
connect:
  - h.x -> k.x1
  - h.v -> k.v1
  - k.reaction -> h.force
  - h.x -> out.ch0
"""


@pytest.fixture
def patch(tmp_path):
    p = tmp_path / "p.yaml"
    p.write_text(SIM_PATCH)
    return p


@pytest.mark.parametrize("device, message", [
    ("finger=hid,profle=haptic_1dof",
     "device 'finger' (hid): unknown setting 'profle' (did you mean 'profile'?); the hid driver accepts: "
     "max_force, profile, recording, vendor_id, product_id, serial, path"),
    ("finger=simulated,scrpt=1", "unknown setting 'scrpt'; the simulated driver accepts: max_force, mass, "
                                 "hand_stiffness, hand_damping, hold"),
    ("finger=hdi", "unknown driver 'hdi' (did you mean 'hid'?); the drivers are: evdev, hid, midi, osc, replay, serial, simulated"),
    ("finger=simulated,max_force=.nan", "device 'finger' (simulated): max_force=.nan: '.nan': numbers must be finite"),
    ("finger=simulated,max_force=1e999", "numbers must be finite"),
    ("finger=simulated,max_force=soft", "max_force=soft: 'soft' is not of type 'number'"),
    ("finger=simulated,max_force=-2", "max_force=-2: -2 is less than or equal to the minimum of 0"),
    ("finger=simulated,max_force=60", "max_force 60 N is above the simulated device's bound, 50 N"),
    ("finger=hid,profile=haptic_1dof,vendor_id=70000", "vendor_id=70000: 70000 is greater than the maximum"),
    ("finger=hid,profile=no_such_profile", "no HID profile 'no_such_profile' (shipped: gamepad, haptic_1dof, mouse)"),
    ("finger=hid", "driver hid needs one of 'profile' (a profile's name or file), 'recording'"),
    ("nobody=hid,profile=gamepad", "the patch declares no device named nobody (its devices: finger)"),
    ("finger=simulated,max_force", "'max_force' is not a setting KEY=VALUE"),
])
def test_a_bad_device_setting_says_what_is_accepted(patch, tmp_path, device, message):
    proc = run_hg("run", patch, "--seconds", "0.01", "--quiet", "--out", tmp_path / "o.wav", "--device", device)
    assert_patch_error(proc, message)
    assert not (tmp_path / "o.wav").exists()


def test_settings_override_the_entry(patch, tmp_path):
    """A setting changes what plays: a heavier simulated device moves less under the same script."""
    import soundfile
    outs = []
    for mass in ("0.05", "5"):
        out = tmp_path / f"m{mass}.wav"
        proc = run_hg("run", patch, "--seconds", "0.05", "--quiet", "--out", out,
                      "--device", f"finger=simulated,mass={mass}")
        assert proc.returncode == 0, proc.stderr
        outs.append(abs(soundfile.read(out)[0]).max())
    assert outs[1] < 0.5 * outs[0]


def test_a_simulated_patch_plays_on_a_hid_device_without_editing(patch, tmp_path):
    """`--device finger=hid,profile=haptic_1dof`: the script and mass are ignored with a one-line
    note, and both run and play reach the clean "no device" exit (no such device is connected)."""
    proc = run_hg("run", patch, "--seconds", "0.01", "--quiet", "--out", tmp_path / "o.wav",
                  "--device", "finger=hid,profile=haptic_1dof")
    for p in (proc,):
        assert_patch_error(p, "device 'finger': cannot open the HID device 1209:0001 (profile 'haptic_1dof')")
        assert "hapticgraph: note: device 'finger' (hid): ignoring mass, script of the patch's simulated entry" \
            in p.stderr
        assert "unknown" not in p.stderr and "additional properties" not in p.stderr.lower()
    env, raw = alsa_file_env(tmp_path)
    play = run_hg("play", patch, "--seconds", "0.1", "--device", "finger=hid,profile=haptic_1dof", env=env)
    assert_patch_error(play, "cannot open the HID device 1209:0001")
    assert "ignoring mass, script" in play.stderr
    assert not (tmp_path / "out.raw").exists() or (tmp_path / "out.raw").stat().st_size == 0
