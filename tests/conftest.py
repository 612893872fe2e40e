"""Shared fixtures: one kernel cache per test session (never the user's), patch writers."""
import os
import pathlib
import textwrap

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
PATCHES = sorted((ROOT / "patches").glob("*.yaml"))


@pytest.fixture(scope="session", autouse=True)
def _kernel_cache(tmp_path_factory):
    if "HAPTICGRAPH_CACHE" not in os.environ:
        os.environ["HAPTICGRAPH_CACHE"] = str(tmp_path_factory.mktemp("kernels"))
    # kernels compiled by numba's JIT, as before: building extension modules (graph/aot.py) costs
    # a link per kernel and numba's C runtime once per cache folder, and many tests start with an
    # empty one; tests/graph/test_aot.py and tests/hostile/test_kernel_native.py turn it on
    os.environ.setdefault("HAPTICGRAPH_AOT", "0")
    yield


@pytest.fixture
def write_patch(tmp_path):
    """write_patch(text, name="p.yaml") -> path of a patch file (text is dedented)."""
    def write(text, name="p.yaml"):
        path = tmp_path / name
        path.write_text(textwrap.dedent(text).lstrip("\n"), encoding="utf-8")
        return path
    return write


def single_block_patch(kind, params=None, inputs=(), rate=44100, probes=("out",)):
    """A patch text with one block `b` whose named inputs are fed by constant/noise sources."""
    from hapticgraph.graph.registry import Registry
    cls = Registry().types[kind]
    params = dict(params or {})
    lines = ["hapticgraph: 1", f"rate: {rate}"]
    for name, p in cls.params.items():
        if p.refers == "devices" and name not in params:
            lines.append("devices:\n  dev: {driver: simulated, script: [{t: 0.0, x: 0.0}, {t: 0.01, x: 0.001}]}")
            params[name] = "dev"
        if p.refers == "controller" and name not in params:     # a silent controller
            lines.append("devices:\n  ctl: {driver: " + ("osc, port: 0}" if kind == "osc_in" else "midi}"))
            params[name] = "ctl"
    lines.append("blocks:")
    if kind == "audio_in":   # the test writes in.wav beside the patch
        params.setdefault("file", "in.wav")
    if kind in ("spring", "contact", "friction"):   # a link needs two cells to join
        lines += ["  c1: {type: cell}", "  c2: {type: cell}"]
        params.setdefault("a", "c1")
        params.setdefault("b", "c2")
    lines.append(f"  b: {{type: {kind}{''.join(f', {k}: {v}' for k, v in params.items())}}}")
    conns = []
    for i, (port, src) in enumerate(inputs):
        lines.append(f"  src{i}: {src}")
        conns.append(f"  - src{i}.out -> b.{port}")
    lines.append("connect:" + ("" if conns else " []"))
    lines.extend(conns)
    return "\n".join(lines) + "\n"


@pytest.fixture
def patches_dir():
    return ROOT / "patches"


# a 41-cell lattice string, plucked, heard at cell 12: the patch of the live-edit tests
EDITABLE_STRING = """
hapticgraph: 1
rate: 44100
blocks:
  str: {type: lattice, shape: [41], mass: 0.001, tension: 200000.0}
  hit: {type: pluck, time: 0.0, force: 0.5, duration: 0.0005}
  mic: {type: mic}
  out: {type: audio_out, channels: 1}
connect:
  - hit.out -> str[5].force
  - str[12].velocity -> mic.in
  - mic.left -> out.ch0
"""


@pytest.fixture
def string_session(write_patch):
    """string_session(blocksize, editable=True) -> a Session of EDITABLE_STRING."""
    from hapticgraph import load
    from hapticgraph.devices import open_drivers
    from hapticgraph.graph.engine import Session

    def make(blocksize, editable=True):
        patch = load(write_patch(EDITABLE_STRING))
        return Session(patch, drivers=open_drivers(patch), blocksize=blocksize, editable=editable)
    return make


@pytest.fixture
def hg():
    """`hapticgraph ARGS` in a child process under a memory and time limit (tests/hostile)."""
    from hostile_env import run_hg
    return run_hg
