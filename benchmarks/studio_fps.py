"""The studio's frame rate while the sound runs in real time (issue 22, Speed).

For a 32 × 32 sheet, a 100 × 100 sheet and a 20 × 20 × 20 block: `hapticgraph studio` plays the
lattice (64-frame blocks, 44.1 kHz) through a JACK dummy server (jackd2 `-d dummy -p 64`, the
clock of a sound card without one) and a headless chromium draws it; each second the page's
`window.studio` gives the cell frames received and the frames drawn with new cell data, and the
server's `status` event its xruns. In the same run, `hapticgraph play` plays the same lattice
alone for as long on the same JACK server: the xruns the studio causes are the difference.

    python benchmarks/studio_fps.py                      # 3 lattices x (60 s studio + 60 s play)
    python benchmarks/studio_fps.py --seconds 10         # shorter
    python benchmarks/studio_fps.py --audio none         # no JACK: the session paced by the clock
    python benchmarks/studio_fps.py --screenshot docs/studio.png   # also the README's picture

Needs jackd (Debian jackd2), PortAudio (libportaudio2), chromium and chromium-driver, selenium.
The browser rasterises WebGL in software (SwiftShader) when the machine has no GPU, as here: the
frame rates are then a floor for a desktop with a graphics card.
"""
import argparse
import contextlib
import math
import os
import queue
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time

from benchlib import child_env, cpu_model

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
FLAGS = ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-background-networking",
         "--disable-component-update", "--no-first-run", "--window-size=1400,860", "--enable-unsafe-swiftshader")

LATTICE = """\
hapticgraph: 1
name: studio benchmark {label}
rate: 44100
blocks:
  lat:  {{type: lattice, shape: {shape}, mass: 0.001, tension: 200000.0, damping: 0.05}}
  bow:  {{type: wavetable, shape: sine, frequency: 3.0, amplitude: 0.2}}
  hit:  {{type: pluck, time: 0.01, force: 0.5, duration: 0.0005}}
  mic:  {{type: mic, gain: 5.0, pan: 0.2}}
  out:  {{type: audio_out}}
connect:
  - hit.out -> lat[{hit}].force
  - bow.out -> lat[{drive}].force
  - lat[{mic}].velocity -> mic.in
  - mic.left -> out.left
  - mic.right -> out.right
"""
CASES = (("32x32", [32, 32]), ("100x100", [100, 100]), ("20x20x20", [20, 20, 20]))


def write_patch(folder, label, shape):
    at = lambda f: ", ".join(str(max(1, int(n * f))) for n in shape)    # noqa: E731
    path = os.path.join(folder, f"lattice_{label}.yaml")
    with open(path, "w") as f:
        f.write(LATTICE.format(label=label, shape=list(shape), hit=at(0.3), drive=at(0.5), mic=at(0.7)))
    return path


@contextlib.contextmanager
def jack(folder, period=64, rate=44100):
    """A jackd dummy server of its own name, stopped by its PID."""
    name = f"hapticgraph-studio-bench-{os.getpid()}"
    log = open(os.path.join(folder, "jackd.log"), "w+")
    proc = subprocess.Popen(["jackd", "-n", name, "-R", "-d", "dummy", "-r", str(rate), "-p", str(period)],
                            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        for _ in range(75):
            out = subprocess.run(["jack_wait", "-c", "-s", name], capture_output=True, text=True, timeout=10).stdout
            if "running" in out and "not" not in out:
                break
            time.sleep(0.2)
        else:
            raise RuntimeError("jackd did not start")
        yield {"JACK_DEFAULT_SERVER": name, "JACK_NO_START_SERVER": "1"}
    finally:
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGTERM)
            proc.wait(10)
        log.close()


def play_alone(patch, seconds, env):
    """`hapticgraph play` alone on the JACK server: its xruns (from its report)."""
    proc = subprocess.run([sys.executable, "-m", "hapticgraph", "play", patch, "--blocksize", "64",
                           "--audio-device", "system", "--seconds", str(seconds)],
                          capture_output=True, text=True, env=child_env(**env), timeout=seconds + 180)
    text = proc.stdout + proc.stderr
    m = re.search(r"xruns (\d+)", text)
    if proc.returncode != 0 or not m:
        raise RuntimeError(f"play failed ({proc.returncode}):\n{text[-2000:]}")
    return int(m.group(1))


@contextlib.contextmanager
def studio(patch, audio, env, folder, cwd=None):
    args = [sys.executable, "-m", "hapticgraph", "studio", patch, "--no-browser", "--port", "0", "--audio", audio]
    if audio == "card":
        args += ["--audio-device", "system", "--blocksize", "64"]
    log = open(os.path.join(folder, "studio.log"), "a")
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=log, text=True, env=child_env(**env), cwd=cwd)
    try:
        lines = queue.Queue()
        threading.Thread(target=lambda: lines.put(proc.stdout.readline()), daemon=True).start()
        line = lines.get(timeout=180)
        m = re.match(r"^hapticgraph studio: (http://127\.0\.0\.1:\d+/\?token=[\w-]+)$", line.strip())
        if not m:
            raise RuntimeError(f"studio did not start: {line!r} (see {log.name})")
        threading.Thread(target=proc.stdout.read, daemon=True).start()
        yield m.group(1)
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=15)
        log.close()


@contextlib.contextmanager
def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    profile = tempfile.TemporaryDirectory(prefix="hg-bench-chromium-")
    for flag in (*FLAGS, f"--user-data-dir={profile.name}"):
        options.add_argument(flag)
    service = Service(CHROMEDRIVER)
    driver = webdriver.Chrome(service=service, options=options)
    try:
        yield driver
    finally:
        driver.quit()
        service.stop()
        profile.cleanup()


def open_page(driver, url):
    driver.get(url)
    end = time.monotonic() + 60
    while not driver.execute_script("return document.body.dataset.ready === '1'"):
        if time.monotonic() > end:
            raise RuntimeError("the page did not get the instrument")
        time.sleep(0.1)


def measure_page(driver, url, seconds):
    """Per second: frames received, frames drawn, the server's xruns; after a 3 s warm-up."""
    open_page(driver, url)
    time.sleep(3)
    status = lambda: driver.execute_script("return window.studio.status || null")   # noqa: E731
    first = status()
    received, drawn = [], []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        time.sleep(1.0)
        r, d = driver.execute_script("return [window.studio.received, window.studio.fps]")
        received.append(r)
        drawn.append(d)
    last = status()
    xruns = None if not (first and last) else last["xruns"] - first["xruns"]
    load = None if not last else last.get("load")
    return {"received": received, "drawn": drawn, "xruns": xruns, "xruns_total": last and last["xruns"], "load": load}


def picture(path, env, folder):
    """The README's picture: patches/string_drives_plate.yaml struck again, the scope open."""
    # run from the repository with a relative path: the page shows the patch's path as given
    with studio(os.path.join("patches", "string_drives_plate.yaml"), "none", env, folder, cwd=ROOT) as url, \
            browser() as driver:
        open_page(driver, url)
        driver.find_element("css selector", "#tabs button[data-tab=scope]").click()
        driver.execute_async_script("const done = arguments[0]; window.studio.send({cmd: 'restart'}).then(done);")
        time.sleep(1.5)
        driver.save_screenshot(os.path.abspath(path))


def server_alone(url, seconds):
    """The studio's xruns over `seconds` with a script connected that asks for no cell frames."""
    import json
    from websockets.sync.client import connect
    statuses = []
    with connect(url.replace("http://", "ws://").replace("/?", "/ws?"), max_size=None) as ws:
        ws.send(json.dumps({"id": 1, "cmd": "frames", "fps": 0}))
        end = time.monotonic() + seconds + 3
        while time.monotonic() < end:
            try:
                msg = ws.recv(timeout=max(0.01, end - time.monotonic()))
            except TimeoutError:
                break
            if isinstance(msg, str):
                m = json.loads(msg)
                if m.get("type") == "status":
                    statuses.append(m["xruns"])
    # the first 3 s (connecting, the first status) are not counted, as for the page
    return statuses[-1] - statuses[min(3, len(statuses) - 1)] if len(statuses) > 1 else None


def run_case(label, patch, args, env, folder):
    row = {"label": label, "load_before": os.getloadavg()[0]}
    with studio(patch, args.audio, env, folder) as url, browser() as driver:
        row.update(measure_page(driver, url, args.seconds))
    with studio(patch, args.audio, env, folder) as url:
        row["server_xruns"] = server_alone(url, args.seconds)
    if args.audio == "card":
        row["play_xruns"] = play_alone(patch, args.seconds, env)
    row["load_after"] = os.getloadavg()[0]
    d, r = row["drawn"], row["received"]
    print(f"  {label:>9}: drawn median {statistics.median(d):.1f} min {min(d):.1f} frames/s, received median "
          f"{statistics.median(r):.1f}; xruns: studio + page {row['xruns']} (since start {row['xruns_total']}), "
          f"studio without page {row['server_xruns']}, play alone {row.get('play_xruns', '-')}; "
          f"load average {row['load_before']:.1f} -> {row['load_after']:.1f}", flush=True)
    return row


def table(rows, args):
    print(f"\n{cpu_model()}, {os.cpu_count()} cores; audio {args.audio}"
          f"{' (jackd -d dummy -p 64, 44.1 kHz)' if args.audio == 'card' else ' (paced by the clock)'}; "
          f"{args.seconds:.0f} s per lattice\n")
    print("| lattice | cells | frames drawn/s median (min) | frames received/s median | xruns: studio + page "
          "| studio, no page | play alone | load average |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        cells = math.prod(int(n) for n in r["label"].split("x"))
        print(f"| {r['label'].replace('x', ' × ')} | {cells} | {statistics.median(r['drawn']):.1f} ({min(r['drawn']):.1f}) | "
              f"{statistics.median(r['received']):.1f} | {r['xruns']} | {r['server_xruns']} | {r.get('play_xruns', '—')} | "
              f"{r['load_before']:.1f} → {r['load_after']:.1f} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--audio", choices=("card", "none"), default="card")
    ap.add_argument("--only", help="one lattice: 32x32, 100x100 or 20x20x20")
    ap.add_argument("--screenshot", help="also save the page playing patches/string_drives_plate.yaml here")
    args = ap.parse_args(argv)
    if args.audio == "card" and shutil.which("jackd") is None:
        raise SystemExit("jackd (Debian jackd2) is not installed: use --audio none")
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        env = {"HAPTICGRAPH_CACHE": os.environ.get("HAPTICGRAPH_CACHE", os.path.join(folder, "cache"))}
        with (jack(folder) if args.audio == "card" else contextlib.nullcontext({})) as jack_env:
            env.update(jack_env)
            for label, shape in CASES:
                if args.only and args.only != label:
                    continue
                rows.append(run_case(label, write_patch(folder, label, shape), args, env, folder))
        if args.screenshot:
            picture(args.screenshot, env, folder)
    table(rows, args)


if __name__ == "__main__":
    main()
