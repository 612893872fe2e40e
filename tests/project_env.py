"""What the tests share besides fixtures: the repository's root and patches, patch texts and a
patch writer for one block. Imported by name (`from project_env import ROOT`), never from
`conftest`: tests/sweep and tests/studio have conftest modules of their own, and the module name
`conftest` is then whichever was imported first."""
import pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
PATCHES = sorted((ROOT / "patches").glob("*.yaml"))


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
