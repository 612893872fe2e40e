"""Issue 33 item 2: Ctrl-C at any moment of a command gives one line on stderr, exit status 130,
no traceback, and an output file that is whole (renamed into place complete, holding everything
rendered before the stop) or absent (its temporary file removed) — never a partial file, never a
stray temporary. A SIGINT once the command has finished (the interpreter tearing down, joining
the file writer's thread) changes nothing: exit 0.

The children run the command line through a launcher that tells the test (one byte on a pipe)
once `hapticgraph.cli.main` has taken SIGINT, on its first line: the moments are drawn from there
on. Before it the interpreter is still starting (site, then `import hapticgraph.cli`: 0.05-0.1 s),
where Python's own handler reports a KeyboardInterrupt with a traceback and no code of the
command can run yet."""
import os
import random
import select
import signal
import struct
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import soundfile

from audio_env import alsa_file_env
from project_env import ROOT

KARPLUS = ROOT / "patches" / "karplus_strong.yaml"
INTERRUPTED = 128 + signal.SIGINT          # 130, as a shell reports a command ended by Ctrl-C

# `hapticgraph ARGS`, telling the test (a byte on the pipe FD) once main has taken SIGINT (its first line)
LAUNCH = """\
import os, sys
fd = int(sys.argv.pop(1))
sys.argv[0] = "hapticgraph"
from hapticgraph.cli import main
from hapticgraph.cli.common import Interrupt

def ready(frame, event, arg):
    if event == "return" and frame.f_code is Interrupt.take.__code__:
        sys.setprofile(None)
        os.write(fd, b".")
        os.close(fd)

sys.setprofile(ready)
sys.exit(main())
"""


def _launch(args, env, cwd=None, preamble=""):
    """Start `hapticgraph ARGS` through LAUNCH; (process, the moment main began: time.monotonic)."""
    r, w = os.pipe()
    try:
        proc = subprocess.Popen([sys.executable, "-c", preamble + LAUNCH, str(w), *map(str, args)], env=env,
                                cwd=cwd, pass_fds=(w,), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        os.close(w)
        w = None
        ready, _, _ = select.select([r], [], [], 120)
        assert ready and os.read(r, 1) == b".", "the command line never started"
        return proc, time.monotonic()
    finally:
        os.close(r)
        if w is not None:
            os.close(w)


def _env(cache):
    """The environment of a user's run (kernels built ahead of time: HAPTICGRAPH_AOT unset) with
    its own kernel cache."""
    env = dict(os.environ, HAPTICGRAPH_CACHE=str(cache))
    env.pop("HAPTICGRAPH_DEBUG", None)
    env.pop("HAPTICGRAPH_AOT", None)
    return env


def _riff_sizes_are_true(path):
    """The WAV's RIFF and data sizes match the file: it was finished, not cut."""
    with open(path, "rb") as f:
        head = f.read(12)
        size = os.path.getsize(path)
        assert head[:4] == b"RIFF" and head[8:12] == b"WAVE"
        assert struct.unpack("<I", head[4:8])[0] == size - 8
        while True:
            chunk = f.read(8)
            assert len(chunk) == 8, "no data chunk"
            kind, length = chunk[:4], struct.unpack("<I", chunk[4:])[0]
            if kind == b"data":
                assert f.tell() + length == size
                return length
            f.seek(length + (length & 1), 1)


SECONDS = 60.0                      # 2.6 M frames, 21 MB of WAV: a render and a rename long enough to be hit
FRAMES = round(SECONDS * 44100)


def _interrupt_run(folder, env, delay):
    """`run KARPLUS --seconds SECONDS --out FOLDER/w.wav -q`, SIGINT `delay` s after main began;
    (delay, exit status, stdout, stderr, files left, frames in w.wav or None)."""
    folder.mkdir()
    proc, began = _launch(["run", KARPLUS, "--seconds", SECONDS, "--out", folder / "w.wav", "-q"], env)
    try:
        time.sleep(max(0.0, began + delay - time.monotonic()))
        proc.send_signal(signal.SIGINT)        # nothing if it has ended already
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    files = sorted(os.listdir(folder))
    frames = None
    if "w.wav" in files:
        frames = soundfile.info(folder / "w.wav").frames
        assert _riff_sizes_are_true(folder / "w.wav") == 8 * frames, (delay, err)   # 2 channels of float32
        os.unlink(folder / "w.wav")           # 200 of them would fill a small disk
    return delay, proc.returncode, out, err, files, frames


def test_sigint_at_200_moments_of_a_run_never_prints_a_traceback(tmp_path):
    """200 moments over a run, two runs at a time: 120 spread evenly from main's start to a little
    past the run's end (parsing, loading the cached kernel, the render, the rename, the exit) and
    80 more over its second half, where the render, the rename and the exit are."""
    env = _env(tmp_path / "kernels")
    warm = ["run", KARPLUS, "--seconds", SECONDS, "--out", tmp_path / "warm.wav", "-q"]
    proc, _ = _launch(warm, env)                # compiles into the cache
    assert proc.communicate(timeout=300) == ("", "") and proc.returncode == 0
    assert soundfile.info(tmp_path / "warm.wav").frames == FRAMES

    def timed(k):                               # a warm run, two at a time as below
        proc, began = _launch([*warm[:-2], tmp_path / f"warm{k}.wav", "-q"], env)
        assert proc.communicate(timeout=300) == ("", "") and proc.returncode == 0
        return time.monotonic() - began
    with ThreadPoolExecutor(max_workers=2) as pool:
        duration = sorted(pool.map(timed, range(4)))[1]     # the second fastest of four
    span = 1.2 * duration
    rng = random.Random(33)
    delays = [span * (k + rng.random()) / 120 for k in range(120)]   # one moment in each 120th of the span
    delays += [span * (0.5 + 0.5 * (k + rng.random()) / 80) for k in range(80)]
    rng.shuffle(delays)
    began = time.monotonic()
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(lambda k: _interrupt_run(tmp_path / f"m{k}", env, delays[k]), range(200)))
    took = time.monotonic() - began
    outcomes = {}
    for result in sorted(results):
        kind = _outcome(*result, duration)
        outcomes.setdefault(kind, []).append(round(result[0], 3))
    print(f"\n200 moments over {span:.3f} s (a warm run: {duration:.3f} s) in {took:.1f} s:")
    for kind, moments in outcomes.items():
        print(f"  {len(moments)} {kind}, at {moments[0]}-{moments[-1]} s")
    assert "before the render" in outcomes and {"during the render", "finished"} & set(outcomes), outcomes


def _outcome(delay, code, out, err, files, frames, duration):
    """What a run interrupted `delay` s after main began did, checked: one line or none, no
    traceback, 130 or 0 (finished), the WAV whole or absent, no temporary file left."""
    lines = err.splitlines()
    said = f"SIGINT {delay:.3f} s after main began (a warm run: {duration:.3f} s): exit {code}, {files}\n{err}"
    assert "Traceback" not in err and "Exception ignored" not in err, said
    assert out == "", said                                      # -q: no summary, no bar
    assert code in (0, INTERRUPTED), said
    assert files in ([], ["w.wav"]), said                       # no temporary left behind
    if code == 0:                              # it had finished: the whole WAV, nothing said
        assert lines == [] and frames == FRAMES, said
        return "finished"
    assert len(lines) == 1 and lines[0].startswith("hapticgraph: interrupted"), said
    if frames is None:                         # before the render: nothing written
        assert "written to" not in err, said
        return "before the render"
    assert f"{frames} samples written to" in err, said     # the WAV holds every sample rendered
    return "during the render"


def test_sigint_during_a_render_keeps_the_wav_whole_and_exits_130(tmp_path):
    out = tmp_path / "take.wav"
    proc, _ = _launch(["run", KARPLUS, "--seconds", 3000, "--out", out, "-q"], _env(tmp_path / "kernels"))
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:      # the first MB of audio
            parts = [p for p in os.listdir(tmp_path) if p.startswith(".take.wav.")]
            if parts and os.path.getsize(tmp_path / parts[0]) > 1 << 20:
                break
            time.sleep(0.02)
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == INTERRUPTED, stderr
    assert stdout == "" and "Traceback" not in stderr
    frames = soundfile.info(out).frames
    assert 0 < frames < 3000 * 44100 and _riff_sizes_are_true(out) == 8 * frames
    assert stderr.splitlines() == [f"hapticgraph: interrupted (SIGINT) after {frames / 44100:.3f} s; "
                                   f"{frames} samples written to {out}"]
    assert sorted(os.listdir(tmp_path)) == ["kernels", "take.wav"]


def test_sigint_while_compiling_writes_nothing(tmp_path):
    """A cold compile (an empty kernel cache) says so; a SIGINT then ends it at once."""
    out = tmp_path / "w.wav"
    proc, _ = _launch(["run", KARPLUS, "--seconds", 1, "--out", out], _env(tmp_path / "empty"))
    try:
        notice = proc.stderr.readline()
        assert notice.startswith("hapticgraph: compiling"), notice
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == INTERRUPTED, stderr
    assert stdout == "" and stderr == "hapticgraph: interrupted before rendering began; nothing written\n"
    assert sorted(os.listdir(tmp_path)) == ["empty"]


# a thread that outlives the command, as a writer thread might: the interpreter joins it at exit
LINGER = """\
import threading, time
threading.Thread(target=time.sleep, args=(2.0,), name="lingering").start()
"""


def test_sigint_while_the_interpreter_joins_a_thread_at_exit_is_silent(tmp_path):
    """The issue's case: the command has finished and the interpreter, ending, waits for a thread
    (threading._shutdown); a SIGINT there printed `Exception ignored in: <module 'threading'>`
    and a traceback. Now: nothing printed, the command's exit status."""
    proc, _ = _launch(["check", KARPLUS], _env(tmp_path / "kernels"), preamble=LINGER)
    try:
        line = proc.stdout.readline()            # check has printed its verdict: main has returned
        time.sleep(0.3)
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert "ok" in line, line + stdout
    assert stderr == "" and proc.returncode == 0, stderr


def test_a_command_interrupted_before_it_began_says_one_line(tmp_path):
    """KeyboardInterrupt anywhere in a command: `hapticgraph: interrupted`, status 130."""
    code = ("import hapticgraph.cli.inspect as inspect\n"
            "def cmd_check(args):\n    raise KeyboardInterrupt\n"
            "inspect.cmd_check = cmd_check\n")
    proc, _ = _launch(["check", KARPLUS], _env(tmp_path / "kernels"), preamble=code)
    stdout, stderr = proc.communicate(timeout=60)
    assert (proc.returncode, stdout, stderr) == (INTERRUPTED, "", "hapticgraph: interrupted\n")


def test_a_sigint_the_moment_main_takes_it_says_one_line(tmp_path):
    """The signal handler in place and the signal at once (here raised as `take` returns, in the
    launcher's profile hook): caught by main like any other, not a traceback."""
    code = ("import signal\n"
            "from hapticgraph.cli.common import Interrupt\n"
            "def take(self, *signums, _take=Interrupt.take):\n"
            "    _take(self, *signums)\n"
            "    signal.raise_signal(signal.SIGINT)\n"
            "Interrupt.take = take\n")
    proc, _ = _launch(["check", KARPLUS], _env(tmp_path / "kernels"), preamble=code)
    stdout, stderr = proc.communicate(timeout=60)
    assert (proc.returncode, stdout, stderr) == (INTERRUPTED, "", "hapticgraph: interrupted\n")


def test_a_sigint_inside_an_import_says_one_line(tmp_path):
    """A KeyboardInterrupt raised while a C extension imports (numpy's, in the first moments of
    `play`) comes out as that import's ImportError: still the interrupt, one line and 130. An
    ImportError with no signal received stays an error with its traceback."""
    code = ("import signal, time\n"
            "from hapticgraph.graph import kernel\n"
            "def set_notice(notice):\n"           # before the command runs: main's own lines
            "    try:\n"
            "        signal.raise_signal(signal.SIGINT)\n"
            "        time.sleep(5)\n"
            "    except KeyboardInterrupt as exc:\n"
            "        raise ImportError('PyCapsule_Import could not import module \"datetime\"') from exc\n"
            "kernel.set_notice = set_notice\n")
    proc, _ = _launch(["check", KARPLUS], _env(tmp_path / "kernels"), preamble=code)
    stdout, stderr = proc.communicate(timeout=60)
    assert (proc.returncode, stdout, stderr) == (INTERRUPTED, "", "hapticgraph: interrupted\n")
    plain = ("import hapticgraph.cli.inspect as inspect\n"
             "def cmd_check(args):\n    raise ImportError('no such module')\n"
             "inspect.cmd_check = cmd_check\n")
    proc, _ = _launch(["check", KARPLUS], _env(tmp_path / "kernels"), preamble=plain)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 1 and "ImportError: no such module" in stderr


def test_a_sigint_in_a_finaliser_is_raised_after_it(tmp_path):
    """A signal handled inside a `__del__` (or a weakref callback) cannot raise there: Python
    would print `Exception ignored in: …` and drop the KeyboardInterrupt. It comes again, once
    the finaliser has returned."""
    code = ("import signal, time\n"
            "import hapticgraph.cli.inspect as inspect\n"
            "class Finalised:\n"
            "    def __del__(self):\n"
            "        signal.raise_signal(signal.SIGINT)\n"
            "def cmd_check(args):\n"
            "    Finalised()\n"
            "    time.sleep(5)\n"
            "    print('not interrupted')\n"
            "    return 0\n"
            "inspect.cmd_check = cmd_check\n")
    proc, began = _launch(["check", KARPLUS], _env(tmp_path / "kernels"), preamble=code)
    stdout, stderr = proc.communicate(timeout=60)
    assert (proc.returncode, stdout, stderr) == (INTERRUPTED, "", "hapticgraph: interrupted\n")
    assert time.monotonic() - began < 4


# -- play: through ALSA's file PCM (no sound card, no pacing: 60 s play in a few tenths; the take
# cannot keep up and drops samples, which the report counts) ---------------------------------------

def _interrupt_play(folder, env, delay):
    folder.mkdir()
    take = folder / "take"
    proc, began = _launch(["play", KARPLUS, "--seconds", 60, "--record", take], env)
    try:
        time.sleep(max(0.0, began + delay - time.monotonic()))
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    files = sorted(os.listdir(folder))
    frames = None
    if "take.wav" in files:
        data, rate = soundfile.read(folder / "take.wav")
        frames = len(data)
        assert rate == 44100 and np.all(np.isfinite(data))
    return delay, proc.returncode, out, err, files, frames


def test_sigint_at_moments_of_a_play(tmp_path):
    env, _ = alsa_file_env(tmp_path)             # skips without PortAudio or ALSA's configuration
    env.update(_env(tmp_path / "kernels"))
    proc, began = _launch(["play", KARPLUS, "--seconds", 60], env)
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    proc, began = _launch(["play", KARPLUS, "--seconds", 60], env)
    proc.communicate(timeout=300)
    span = 1.2 * (time.monotonic() - began)
    rng = random.Random(34)
    delays = [span * (k + rng.random()) / 40 for k in range(40)]
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(lambda k: _interrupt_play(tmp_path / f"p{k}", env, delays[k]), range(40)))
    codes = {}
    for delay, code, out, err, files, frames in sorted(results):
        said = f"SIGINT {delay:.3f} s after main began: exit {code}, {files}\n{err}"
        assert "Traceback" not in err and "Exception ignored" not in err, said
        assert code in (0, INTERRUPTED), said
        told = [line for line in err.splitlines() if not line.startswith("hapticgraph: playing ")]
        if code == 0:
            assert told == [] and "played 60.000 s" in out, said
        else:
            assert len(told) == 1 and told[0].startswith("hapticgraph: interrupted"), said
        assert files in ([], ["take.hgrec", "take.wav"]), said
        if frames is not None:              # the take's WAV holds what the report says was recorded
            assert f"and {frames} frames of audio to {tmp_path}" in out, said
        codes[code] = codes.get(code, 0) + 1
    assert codes.get(INTERRUPTED), codes


# -- sweep: Dask's local cluster ------------------------------------------------------------------

SWEEP = """\
sweep: 1
patch: ks.yaml
seconds: 0.3
axes:
  loop.length: [99, 149, 199, 249, 299, 349]
  damp.gain: [0.99, 0.995]
features: [rms]
audio: wav
"""


def test_sigint_during_a_sweep_says_one_line(tmp_path):
    (tmp_path / "ks.yaml").write_text(KARPLUS.read_text())
    (tmp_path / "s.yaml").write_text(SWEEP)
    env = _env(tmp_path / "kernels")
    env["HAPTICGRAPH_AOT"] = "0"
    proc, _ = _launch(["sweep", "s.yaml", "--out", "runs", "--workers", "1", "-q"], env, cwd=tmp_path)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:      # the cluster is up: a row
            if (tmp_path / "runs" / "manifest.csv").exists():
                break
            time.sleep(0.05)
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == INTERRUPTED, stderr
    assert "Traceback" not in stderr and "Exception ignored" not in stderr, stderr
    assert stderr.splitlines() == ["hapticgraph: interrupted"], stderr


# -- Session.withdraw and retire stop drivers under the same deadline ----------------------------

def _hang(driver, release, stopping):
    """Make `driver.stop` hang until `release` is set."""
    def stop():
        stopping.set()
        release.wait(30)
    driver.stop = stop


@pytest.mark.parametrize("how", ["withdraw", "retire"])
def test_withdraw_and_retire_abandon_a_driver_that_will_not_stop(tmp_path, monkeypatch, capsys, how):
    """`play --watch`: a swap withdrawn stops the drivers it opened, a swap applied retires the
    ones it no longer uses; each within STOP_SECONDS, past which the device is abandoned, named."""
    import hapticgraph.graph.engine as engine
    from hapticgraph import Session
    monkeypatch.setattr(engine, "STOP_SECONDS", 0.2)
    bowed = (ROOT / "patches" / "fig7_bowed_string.yaml").read_text()
    (tmp_path / "a.yaml").write_text(bowed)
    (tmp_path / "b.yaml").write_text(bowed.replace("mass: 0.05,", "mass: 0.06,"))   # the arm's entry changed
    session = Session.open(tmp_path / "a.yaml", blocksize=64)
    session.process(64)
    old = session.drivers["arm"]
    swap = session.swap(tmp_path / "b.yaml")
    assert list(swap.opened) == ["arm"]
    release, stopping = threading.Event(), threading.Event()
    try:
        if how == "withdraw":
            _hang(swap.opened["arm"], release, stopping)
            began = time.monotonic()
            assert swap.wait(0) is False                  # withdrawn: its new arm stops
        else:
            _hang(old, release, stopping)
            session.process(64)                           # the swap plays; the old arm is unused
            began = time.monotonic()
            assert swap.wait(0) is True                   # ... and retired
        took = time.monotonic() - began
    finally:
        release.set()
    assert stopping.is_set() and took < 2.0, took
    assert capsys.readouterr().err.splitlines() == [
        "hapticgraph: device 'arm' did not close within 0.2 s: abandoned"]
    session.close()


def test_after_a_signal_a_finalisers_own_error_is_not_printed():
    """Seen in the play loop: Ctrl-C inside llvmlite's PipelineTuningOptions.__init__ left an
    object whose __del__ raised AttributeError as it was dropped, and Python printed 'Exception
    ignored' with a traceback after 'interrupted'. Once a signal came, such errors are dropped;
    before one, they reach the hook as ever."""
    import types
    from hapticgraph.cli.common import Interrupt
    told = []
    interrupt = Interrupt()
    interrupt._hook = told.append         # the hook `take` would have saved
    error = types.SimpleNamespace(exc_type=AttributeError, exc_value=AttributeError("x"), object=None)
    interrupt._unraisable(error)
    assert told == [error]
    interrupt.signum = signal.SIGINT
    interrupt._unraisable(error)
    assert told == [error]
