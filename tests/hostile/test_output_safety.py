"""Issue 10 item 9 (engine): the runaway check watches the model — the audio and the forces sent to
devices — never the probe columns, so probing a thousand ports (some of them large, like a
tension in N/m) does not stop a healthy render; and a runaway keeps everything rendered up to the
sample where it was caught, audio and probes alike, not only the blocks before it."""
import numpy as np
import soundfile

import hapticgraph

MANY = """hapticgraph: 1
rate: 8000
blocks:
  str: {type: lattice, shape: [1000], mass: 0.001, tension: 2000.0}
  hit: {type: pluck, time: 0.0, force: 0.5, duration: 0.0005}
  mic: {type: mic}
  out: {type: audio_out, channels: 1}
connect:
  - hit.out -> str[5].force
  - str[12].velocity -> mic.in
  - mic.left -> out.ch0
"""


def test_a_thousand_probes_are_not_a_runaway(hg, tmp_path):
    (tmp_path / "many.yaml").write_text(MANY)
    probes = [f"str[{i}].position" for i in range(1000)] + ["str.tension"]
    args = [a for p in probes for a in ("--probe", p)]
    proc = hg("run", "many.yaml", "--seconds", 0.05, "--engine", "python", "--out", "m.wav", "--quiet", *args,
              cwd=tmp_path, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "runaway" not in proc.stderr
    z = np.load(tmp_path / "m.npz")
    assert len(z.files) == 1002 and np.all(z["str.tension"] == 2000.0)
    assert z["str[999].position"].shape == (400,) and np.abs(z["str[6].position"]).max() > 0


RUNAWAY = """hapticgraph: 1
rate: 8000
blocks:
  kick: {type: pluck, duration: 0.001}
  loop: {type: delay, length: 7}
  amp: {type: gain, gain: 1.5}
  out: {type: audio_out, channels: 1}
connect:
  - kick.out -> loop.in
  - amp.out -> loop.in
  - loop.out -> amp.in
  - amp.out -> out.ch0
"""


def test_a_runaway_keeps_every_sample_before_it(hg, tmp_path):
    (tmp_path / "p.yaml").write_text(RUNAWAY)
    free = hapticgraph.render(hapticgraph.load(tmp_path / "p.yaml"), 1.0, probes=["loop.out"])
    first = int(np.argmax(np.abs(free.audio[:, 0]) > 1e3))
    assert first > 16                        # caught inside a block, not at its edge
    proc = hg("run", "p.yaml", "--seconds", 1, "--out", "r.wav", "--probe", "loop.out", cwd=tmp_path)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    assert "runaway: out.ch0 reached" in proc.stderr and f"at {first / 8000:.4f} s" in proc.stderr
    assert "the force sent was zeroed first" in proc.stderr
    audio, rate = soundfile.read(tmp_path / "r.wav", dtype="float32")
    assert len(audio) == first
    np.testing.assert_array_equal(audio, free.audio[:first, 0].astype(np.float32))
    np.testing.assert_array_equal(np.load(tmp_path / "r.npz")["loop.out"], free.probes["loop.out"][:first])
