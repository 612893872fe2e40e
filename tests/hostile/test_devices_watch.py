"""`play --watch` follows the patch's plugin files too: an edited plugin is imported again and
swapped in; a deleted plugin or patch file is reported in one line and the previous version keeps
playing (paced by a JACK dummy server, as the other --watch test)."""
import subprocess
import sys
import time

import numpy as np
import soundfile

from audio_env import jack_or_skip

PLUGIN = '''\
from hapticgraph.blocks import Block, Out, Param


class Tone(Block, name="tone"):
    """out[n] = level · SCALE."""

    y = Out(name="out")
    level = Param(1.0, live=False)

    @staticmethod
    def output(level):
        return level * SCALE
'''

PATCH = """\
hapticgraph: 1
name: watched plugin
plugins: [tone.py]
blocks:
  t: {type: tone}
  out: {type: audio_out, channels: 1}
connect:
  - t.out -> out.ch0
"""


def _wait_for(proc, wav, seconds):
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if wav.exists() and wav.stat().st_size > 58 + seconds * 44100 * 4:
            return
        time.sleep(0.05)


def test_watch_reloads_an_edited_plugin_and_reports_deleted_files(tmp_path):
    plugin, patch = tmp_path / "tone.py", tmp_path / "p.yaml"
    plugin.write_text(PLUGIN.replace("SCALE", "0.25"))
    patch.write_text(PATCH)
    jack = jack_or_skip(tmp_path)
    try:
        take = tmp_path / "w"
        proc = subprocess.Popen([sys.executable, "-m", "hapticgraph", "play", str(patch), "--watch", "--seconds", "4",
                                 "--blocksize", "64", "--audio-device", "system", "--record", str(take)],
                                env=jack.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        wav = tmp_path / "w.wav"
        _wait_for(proc, wav, 0.5)
        plugin.write_text(PLUGIN.replace("SCALE", "0.5"))
        _wait_for(proc, wav, 2.0)
        plugin.unlink()
        time.sleep(0.6)
        patch.unlink()
        out, err = proc.communicate(timeout=60)
    finally:
        jack.stop()
    assert proc.returncode == 0, err
    assert "Traceback" not in err
    assert "hapticgraph: reloaded p.yaml" in err, err
    assert "hapticgraph: the plugin file tone.py was deleted; still playing the previous version" in err
    assert "hapticgraph: the patch file p.yaml was deleted; still playing the previous version" in err
    assert "1 swapped in, 0 refused" in out
    heard, _ = soundfile.read(wav, dtype="float32")
    assert len(heard) == 4 * 44100
    levels = set(np.unique(heard).tolist())
    assert levels <= {0.0, 0.25, 0.5}, levels
    assert heard[0] == 0.25 and heard[-1] == 0.5        # the edited plugin was heard, to the end
