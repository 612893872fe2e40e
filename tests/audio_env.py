"""The real audio stack for tests, with no sound card: PortAudio (Debian libportaudio2) through an
ALSA `file` PCM configured per process with XDG_CONFIG_HOME, and a `jackd -d dummy` server for
real-time pacing (started here, stopped by its PID)."""
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

ASOUNDRC = """\
# hapticgraph tests: the default PCM writes every frame, as sent, to a raw file (no sound card)
pcm.!default {{
    type file
    slave.pcm "null"
    file "{raw}"
{infile}    format "raw"
}}
"""


def portaudio_or_skip():
    """sounddevice with a working PortAudio, or skip naming what is missing."""
    try:
        import sounddevice  # noqa: F401
    except ImportError:
        pytest.skip("the sounddevice package is not installed (pip install sounddevice)")
    except OSError as exc:
        pytest.skip(f"the PortAudio library (Debian libportaudio2) is not installed: {exc}")


def alsa_file_env(folder, infile=None):
    """(env, raw_path): an environment whose ALSA default PCM appends float frames to raw_path
    (and, with `infile`, captures from that raw file: a live input with no sound card)."""
    portaudio_or_skip()
    if not any(os.path.exists(p) for p in ("/usr/share/alsa/alsa.conf", "/etc/alsa/alsa.conf")):
        pytest.skip("ALSA's configuration (Debian libasound2-data) is not installed")
    folder = os.fspath(folder)
    os.makedirs(os.path.join(folder, "alsa"), exist_ok=True)
    raw = os.path.join(folder, "out.raw")
    with open(os.path.join(folder, "alsa", "asoundrc"), "w", encoding="utf-8") as f:
        f.write(ASOUNDRC.format(raw=raw, infile=f'    infile "{os.fspath(infile)}"\n' if infile else ""))
    env = dict(os.environ, XDG_CONFIG_HOME=folder, JACK_NO_START_SERVER="1",
               JACK_DEFAULT_SERVER="hapticgraph-no-server")
    return env, raw


def hapticgraph(args, env, timeout=120, **kw):
    """Run the command line in a subprocess; CompletedProcess with text output."""
    return subprocess.run([sys.executable, "-m", "hapticgraph", *map(str, args)], env=env, text=True,
                          capture_output=True, timeout=timeout, **kw)


def read_raw(path, channels):
    return np.fromfile(path, dtype="<f4").reshape(-1, channels)


def align(played, rendered):
    """Offset of `rendered` inside `played` (PortAudio primes the device with silence first)."""
    first_p = np.flatnonzero(np.any(played != 0, axis=1))
    first_r = np.flatnonzero(np.any(rendered != 0, axis=1))
    assert first_p.size and first_r.size, "silence: nothing to align"
    return int(first_p[0] - first_r[0])


class Jack:
    """A `jackd -d dummy` server: real-time pacing with no sound card."""

    def __init__(self, folder, rate=44100, period=64):
        self.name = f"hapticgraph-test-{os.getpid()}-{time.monotonic_ns() % 100000}"
        self.rate, self.period = rate, period
        self.log = open(os.path.join(os.fspath(folder), "jackd.log"), "w+")
        self.proc = subprocess.Popen(["jackd", "-n", self.name, "-R", "-d", "dummy", "-r", str(rate),
                                      "-p", str(period)], stdout=self.log, stderr=subprocess.STDOUT,
                                     start_new_session=True)
        self.env = dict(os.environ, JACK_DEFAULT_SERVER=self.name, JACK_NO_START_SERVER="1",
                        XDG_CONFIG_HOME=os.fspath(folder))   # no ALSA default here: only JACK's "system"
        deadline = time.monotonic() + 15
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"jackd exited with {self.proc.returncode}: {self.text()}")
            ok = subprocess.run(["jack_wait", "-c", "-s", self.name], env=self.env, capture_output=True,
                                text=True, timeout=10) if shutil.which("jack_wait") else None
            if ok is not None and "running" in ok.stdout and "not" not in ok.stdout:
                break
            time.sleep(0.2)
        else:
            self.stop()
            raise RuntimeError(f"jackd did not come up: {self.text()}")

    def text(self):
        self.log.flush()
        self.log.seek(0)
        return self.log.read()

    def stop(self):
        if self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                os.kill(self.proc.pid, signal.SIGKILL)
                self.proc.wait(10)
        self.log.close()


def jack_or_skip(folder, **kw):
    portaudio_or_skip()
    if shutil.which("jackd") is None:
        pytest.skip("the JACK server (Debian jackd2) is not installed")
    if shutil.which("jack_wait") is None:
        pytest.skip("jack_wait (Debian jackd2's example clients) is not installed")
    return Jack(folder, **kw)


def parse_report(stdout):
    """The numbers of play's closing report."""
    import re
    out = {}
    m = re.search(r"xruns (\d+)", stdout)
    out["xruns"] = int(m.group(1)) if m else None
    for key in ("mean", "p99", "max"):
        m = re.search(rf"{key} ([0-9.]+)%", stdout)
        out[key] = float(m.group(1)) / 100 if m else None
    m = re.search(r"played ([0-9.]+) s", stdout)
    out["seconds"] = float(m.group(1)) if m else None
    m = re.search(r"callbacks (\d+)", stdout)
    out["callbacks"] = int(m.group(1)) if m else None
    m = re.search(r"wall ([0-9.]+) s", stdout)
    out["wall"] = float(m.group(1)) if m else None
    return out
