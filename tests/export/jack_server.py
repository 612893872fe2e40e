"""A JACK server of a test's own (`jackd -d dummy`, which paces real time, by a unique name) for
the export's hosts, and how to read its log for xruns."""
import contextlib
import os
import subprocess
import time
import uuid


def stop(proc, deadline=10):
    """Terminate `proc` (one we started), killed if it does not go within `deadline` s."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=deadline)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=deadline)


def until(check, deadline_s, what):
    """Polls `check` until it is true; fails naming `what` at the deadline."""
    end = time.monotonic() + deadline_s
    while time.monotonic() < end:
        if check():
            return
        time.sleep(0.1)
    raise AssertionError(f"{what} (waited {deadline_s} s)")


@contextlib.contextmanager
def jack_server(folder, rate, period):
    """jackd on the dummy backend at `rate` with `period`-frame periods, its log in
    folder/jackd.log; yields the environment that reaches it (JACK_DEFAULT_SERVER, no autostart)."""
    name = f"hgtest-{uuid.uuid4().hex[:8]}"
    env = dict(os.environ, JACK_DEFAULT_SERVER=name, JACK_NO_START_SERVER="1")
    with open(os.path.join(folder, "jackd.log"), "w") as log:
        proc = subprocess.Popen(["jackd", "-n", name, "-d", "dummy", "-r", str(rate), "-p", str(period)],
                                stdout=log, stderr=subprocess.STDOUT, env=env)
        try:
            subprocess.run(["jack_wait", "-w", "-t", "20"], env=env, check=True, capture_output=True, timeout=30)
            yield env
        finally:
            stop(proc)


def xruns(log, client):
    """(xruns the client caused, xruns of the server's own timer) in jackd's log. A run of XRun
    lines is one cycle; on a loaded machine the dummy driver's timer may be late ("JackTimedDriver::
    Process XRun") and every client of that cycle is then reported late: the client is to blame
    only where its cycle has no timer line."""
    caused = late_timer = 0
    cycle = []
    for line in log.splitlines() + [""]:
        if "XRun" in line:
            cycle.append(line)
            continue
        if cycle:
            timer = any("JackTimedDriver" in c for c in cycle)
            late_timer += timer
            caused += not timer and any(f"client = {client} " in c for c in cycle)
        cycle = []
    return caused, late_timer
