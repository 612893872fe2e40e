"""`play --record` on a full disk: a file size limit (RLIMIT_FSIZE, SIGXFSZ ignored so writes fail
with EFBIG) stops the recording with one clear message; the music plays on to its end; both
files stay readable — the take holds whole rows (and replays), the WAV's header matches its data."""
import os

import numpy as np
import soundfile

from audio_env import ASOUNDRC, alsa_file_env
from hapticgraph.devices.record import Take
from hostile_env import run_hg, run_py

PATCH = """\
hapticgraph: 1
name: recorded on a full disk
rate: 44100
devices:
  finger: {driver: simulated, max_force: 4.0, script: [{t: 0.0, x: -0.002}, {t: 0.02, x: -0.002}, {t: 0.12, x: 0.012}]}
blocks:
  str: {type: lattice, shape: [40], mass: 0.001, tension: 200000.0, damping: 0.01}
  pick: {type: haptic, device: finger}
  pl: {type: plucker, k: 2000.0, release: 2.0}
  mic: {type: mic, gain: 2.0, pan: 0.3}
  out: {type: audio_out}
connect:
  - pick.x -> pl.x1
  - pick.v -> pl.v1
  - str[9].position -> pl.x2
  - str[9].velocity -> pl.v2
  - pl.reaction -> pick.force
  - pl.force -> str[9].force
  - str[30].velocity -> mic.in
  - mic.left -> out.left
  - mic.right -> out.right
"""

LIMIT = 150_000        # bytes any one file may grow to: the take (24 B a sample) fills first

CHILD = """
import resource, signal, sys
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)      # writes past the limit fail with EFBIG instead
resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, {limit}))
from hapticgraph.cli import main
sys.exit(main({args!r}))
"""


def test_record_on_a_full_disk_keeps_readable_partial_files(tmp_path):
    patch = tmp_path / "p.yaml"
    patch.write_text(PATCH)
    env, _ = alsa_file_env(tmp_path)
    with open(tmp_path / "alsa" / "asoundrc", "w", encoding="utf-8") as f:
        f.write(ASOUNDRC.format(raw=os.devnull, infile=""))     # the sound card's frames are not a file here
    take = tmp_path / "take"
    args = ["play", str(patch), "--seconds", "1", "--blocksize", "64", "--record", str(take)]
    warm = run_hg(*args, env=env)           # compiles the kernel into the cache, unlimited
    assert warm.returncode == 0, warm.stderr
    assert Take(f"{take}.hgrec").frames == 44100
    proc = run_py(CHILD.format(limit=LIMIT, args=args), env=env)
    assert proc.returncode == 1, (proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr
    assert "hapticgraph: recording stopped: take.hgrec: File too large" in proc.stderr
    assert "hapticgraph: error: recording stopped early: take.hgrec: File too large" in proc.stderr
    assert "played 1.000 s" in proc.stdout                      # the music went on
    # the take: whole rows only, within the limit, and it replays
    hg = f"{take}.hgrec"
    t = Take(hg)
    assert 0 < t.frames < 44100 and os.path.getsize(hg) <= LIMIT
    assert np.all(np.isfinite(t.data)) and np.any(t.inputs != 0)
    out = tmp_path / "again.wav"
    r = run_hg("run", patch, "--replay", hg, "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    # the WAV: a valid header that matches its data (it may have stopped too, at a whole frame)
    audio, rate = soundfile.read(f"{take}.wav", dtype="float32")
    assert rate == 44100 and audio.shape[1] == 2 and len(audio) > 0
    assert os.path.getsize(f"{take}.wav") == 58 + audio.nbytes
    again, _ = soundfile.read(out, dtype="float32")
    n = min(len(again), len(audio))
    assert np.array_equal(again[:n], audio[:n])                 # what was kept is what was heard
