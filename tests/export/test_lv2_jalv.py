"""The LV2 export hosted for real: `jalv` (console) runs the karplus_strong plugin under a JACK
server of our own (`jackd -d dummy`, which paces real time, by a unique name) for a few seconds;
`jack_rec` records its left output, which is `hapticgraph render` at the server's rate rounded to
float32 (then to jack_rec's 32-bit PCM), from wherever the recording began; and the server never
reports the plugin's client late in a cycle the server itself started on time (an xrun it causes).
On a loaded machine the dummy driver's own timer may be late ("JackTimedDriver::Process XRun"): every
client of that cycle is then reported late, and a period or two around it may be lost; the
recording is allowed as many bad periods as twice such xruns, and no more."""
import re
import subprocess
import uuid

import numpy as np
import soundfile

import hapticgraph
from hapticgraph.cli.main import main
from hapticgraph.export.lv2 import URI
from hapticgraph.graph.patch import load
from jack_server import jack_server, stop, until, xruns
from project_env import ROOT

KS = ROOT / "patches" / "karplus_strong.yaml"
RATE = 48000
PERIOD = 256


def test_jalv_hosts_the_plugin_under_jack_without_an_xrun(tmp_path):
    assert main(["export", str(KS), "--to", "lv2", "--out", str(tmp_path / "lv2")]) == 0
    client = f"hgks{uuid.uuid4().hex[:6]}"
    with jack_server(tmp_path, RATE, PERIOD) as env, open(tmp_path / "jalv.log", "w") as jalv_log:
        env = dict(env, LV2_PATH=str(tmp_path / "lv2"))
        jalv = subprocess.Popen(["jalv", "-x", "-n", client, URI.format(name="karplus_strong")], env=env,
                                stdin=subprocess.PIPE, stdout=jalv_log, stderr=subprocess.STDOUT)
        try:
            ports = lambda: subprocess.run(["jack_lsp"], env=env, capture_output=True, text=True, timeout=10).stdout
            until(lambda: f"{client}:out_left" in ports(), 30, "jalv's ports did not appear")
            subprocess.run(["jack_rec", "-f", str(tmp_path / "rec.wav"), "-d", "2", "-b", "32", f"{client}:out_left"],
                           env=env, check=True, capture_output=True, timeout=60)
            assert jalv.poll() is None                 # still running after the recording's 2 s
            jalv.stdin.close()                         # end of input: the console host exits
            assert jalv.wait(timeout=20) == 0
        finally:
            stop(jalv)
    log = (tmp_path / "jackd.log").read_text(errors="replace")
    caused, late_timer = xruns(log, client)
    assert caused == 0, log
    assert f"Sample rate:  {RATE} Hz" in (tmp_path / "jalv.log").read_text()

    recorded, rate = soundfile.read(tmp_path / "rec.wav", dtype="float64")
    assert rate == RATE and len(recorded) >= RATE          # 2 s asked; at least one second arrived
    text = KS.read_text(encoding="utf-8")
    expected = hapticgraph.render(load(KS, text=re.sub(r"(?m)^rate: 44100$", f"rate: {RATE}", text)),
                                  seconds=12.0).audio[:, 0].astype(np.float32).astype(np.float64)
    start = np.flatnonzero(np.abs(recorded) > 1e-3)[0]      # the first loud sample, matched in the render
    head = recorded[start:start + 256]
    windows = np.lib.stride_tricks.sliding_window_view(expected, len(head))
    offsets = np.flatnonzero(np.abs(windows - head).max(axis=1) <= 2.0 ** -31)
    assert len(offsets) == 1, f"{len(offsets)} places in the render match the recording"
    at = offsets[0] - start
    n = (min(len(recorded), len(expected) - at) // PERIOD) * PERIOD
    assert n > RATE // 2
    wrong = np.abs(recorded[:n] - expected[at:at + n]) > 2.0 ** -31            # beyond PCM32's rounding
    assert np.count_nonzero(wrong.reshape(-1, PERIOD).any(axis=1)) <= 2 * late_timer, log
