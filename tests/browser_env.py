"""A real browser for the studio's tests: `hapticgraph studio` as a subprocess on loopback and
Debian's chromium driven by Selenium through /usr/bin/chromedriver (headless, a throw-away
profile). No browser or driver is downloaded: Selenium Manager is never asked (the driver's path
is given). Everything started here is stopped by its own handle in a `finally`, every wait has a
deadline, and screenshots and the server's log go to the artifacts folder
(HAPTICGRAPH_ARTIFACTS, else the test's tmp_path)."""
import contextlib
import os
import pathlib
import queue
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import urllib.parse

import pytest

PATCHES = pathlib.Path(__file__).resolve().parent.parent / "patches"
CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
START_S = 120          # the studio's first line: importing, loading and compiling the patch
FIRST_LINE = re.compile(r"^hapticgraph studio: (http://127\.0\.0\.1:\d+/\?token=[\w-]+)$")
FLAGS = ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-background-networking",
         "--disable-component-update", "--no-first-run", "--no-default-browser-check",
         "--disable-extensions", "--window-size=1400,860",
         # headless chromium draws WebGL with SwiftShader; say so, rather than rely on the
         # deprecated automatic fallback
         "--enable-unsafe-swiftshader", "--autoplay-policy=no-user-gesture-required")


def browser_or_skip():
    """Selenium and Debian's chromium + chromium-driver (apt, as .ci/run installs them)."""
    pytest.importorskip("selenium", reason="selenium is in the dev extra: pip install -e '.[dev]'")
    for path in (CHROMIUM, CHROMEDRIVER):
        if not os.access(path, os.X_OK):
            pytest.skip(f"{path} is missing: apt-get install chromium chromium-driver")


def artifacts(tmp_path, name):
    """The folder where a test keeps its screenshots and logs."""
    root = os.environ.get("HAPTICGRAPH_ARTIFACTS")
    folder = pathlib.Path(root) / name if root else pathlib.Path(tmp_path) / "artifacts"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _first_line(stream, deadline_s):
    lines = queue.Queue()
    threading.Thread(target=lambda: lines.put(stream.readline()), daemon=True).start()
    try:
        return lines.get(timeout=deadline_s)
    except queue.Empty:
        return None


@contextlib.contextmanager
def studio(patch, log_dir, *args, audio="none", cwd=None):
    """`hapticgraph studio PATCH --no-browser --port 0` running; yields its URL."""
    log = open(pathlib.Path(log_dir) / "studio-server.log", "w")
    cmd = [sys.executable, "-m", "hapticgraph", "studio", str(patch), "--no-browser", "--port", "0",
           "--audio", audio, *args]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=log, text=True, cwd=cwd)
    try:
        line = _first_line(proc.stdout, START_S)
        assert line is not None, f"no first line from the studio within {START_S} s"
        m = FIRST_LINE.match(line.strip())
        assert m, f"first line is not the studio's URL on loopback: {line!r}"
        threading.Thread(target=proc.stdout.read, daemon=True).start()     # never let stdout fill
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
def chromium(log_dir):
    """A headless chromium with a fresh profile; quit (driver and browser) however the test ends."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    profile = tempfile.TemporaryDirectory(prefix="hg-chromium-")
    for flag in (*FLAGS, f"--user-data-dir={profile.name}"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    service = Service(CHROMEDRIVER, log_output=str(pathlib.Path(log_dir) / "chromedriver.log"))
    driver = webdriver.Chrome(service=service, options=options)
    driver.set_page_load_timeout(60)
    driver.set_script_timeout(60)
    try:
        yield driver
    finally:
        try:
            (pathlib.Path(log_dir) / "browser-console.log").write_text(
                "\n".join(f"{e['level']} {e['message']}" for e in driver.get_log("browser")))
        finally:
            driver.quit()
            service.stop()
            profile.cleanup()


def open_page(driver, url, deadline_s=60):
    """Loads the studio page and waits until it has its instrument (body[data-ready])."""
    host = urllib.parse.urlsplit(url).hostname
    assert host == "127.0.0.1", url
    driver.get(url)
    until(lambda: driver.execute_script("return document.body.dataset.ready === '1'"), deadline_s,
          "the page did not get the instrument")


@contextlib.contextmanager
def patch_page(tmp_path, name, what):
    """The studio on a copy of patches/NAME.yaml, and a browser on its page (a screenshot of it
    kept in the test's artifacts, named `what`)."""
    browser_or_skip()
    patch = tmp_path / f"{name}.yaml"
    shutil.copyfile(PATCHES / f"{name}.yaml", patch)
    out = artifacts(tmp_path, what)
    with studio(patch, out) as url, chromium(out) as driver:
        open_page(driver, url)
        yield driver
        driver.save_screenshot(str(out / f"{what}.png"))


def until(check, deadline_s, what):
    """Polls `check` until it is true; fails naming `what` at the deadline (`what` may be a
    callable, asked then: what the page shows at that moment)."""
    end = time.monotonic() + deadline_s
    while time.monotonic() < end:
        value = check()
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError(f"{what() if callable(what) else what} (waited {deadline_s} s)")


def send(driver, command):
    """window.studio.send(command) in the page: the server's JSON reply."""
    return driver.execute_async_script(
        "const done = arguments[arguments.length - 1];"
        "window.studio.send(arguments[0]).then(done, (e) => done({ok: false, error: String(e)}));", command)
