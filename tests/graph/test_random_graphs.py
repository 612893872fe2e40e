"""Random valid graphs (hypothesis): random block types and parameters within their declared
ranges, random wiring (feedback only through blocks whose output reads no input), compiled
kernel == reference interpreter sample for sample."""
import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hapticgraph import render
from hapticgraph.graph.engine import SafetyStop
from hapticgraph.graph.patch import load
from hapticgraph.graph.registry import Registry

REGISTRY = Registry()
POOL = ["gain", "sum", "delay", "lowpass", "constant", "noise", "wavetable", "scale", "sample_hold",
        "envelope", "mic", "pluck"]


def _number(draw, p, integer=False):
    lo = p.minimum if p.minimum is not None else (p.above + 1e-3 if p.above is not None else -1e9)
    hi = p.maximum if p.maximum is not None else (p.below - 1e-3 if p.below is not None else 1e9)
    # a window around the default, inside the declared range: musically sane values
    lo, hi = max(lo, p.default - 2.0), min(hi, p.default + 2.0)
    if integer:
        return draw(st.integers(int(np.ceil(lo)), int(np.floor(hi))))
    return draw(st.floats(lo, hi, allow_nan=False, allow_infinity=False))


@st.composite
def patches(draw):
    n = draw(st.integers(2, 7))
    kinds = [draw(st.sampled_from(POOL)) for _ in range(n)]
    lines = ["hapticgraph: 1", f"rate: {draw(st.sampled_from([8000, 44100, 48000]))}", "blocks:"]
    for i, kind in enumerate(kinds):
        cls = REGISTRY.types[kind]
        params = {}
        for name, p in cls.params.items():
            if not draw(st.booleans()):
                continue
            if p.kind == "number":
                params[name] = _number(draw, p)
            elif p.kind == "integer":
                params[name] = _number(draw, p, integer=True)
            elif p.kind == "boolean":
                params[name] = draw(st.booleans())
            elif p.kind == "string" and p.choices:
                params[name] = draw(st.sampled_from(p.choices))
        if kind == "scale":
            params.pop("curve", None)   # exponential needs a one-signed out_range (a checked error)
        if kind == "delay" and params.get("interpolation") == "allpass":
            params["length"] = max(params.get("length", 1.0), 1.5)
        body = ", ".join(f"{k}: {v!r}".replace("'", "") for k, v in params.items())
        lines.append(f"  b{i}: {{type: {kind}{', ' + body if body else ''}}}")
    conns = []
    for i, kind in enumerate(kinds):
        cls = REGISTRY.types[kind]
        targets = [p.name for p in cls.inputs] + [n for n, p in cls.params.items() if p.live]
        for port in targets:
            for _ in range(draw(st.integers(0, 2))):
                # any earlier block, or any block whose outputs read no input (breaks loops)
                sources = [j for j in range(n) if j < i or not REGISTRY.types[kinds[j]].feedthrough()]
                if not sources:
                    break
                j = draw(st.sampled_from(sources))
                out = draw(st.sampled_from([o.name for o in REGISTRY.types[kinds[j]].outputs]))
                conns.append(f"  - b{j}.{out} -> b{i}.{port}")
    lines.append("connect:" + ("" if conns else " []"))
    lines += conns
    return "\n".join(lines) + "\n", n


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(case=patches())
def test_random_graph_compiled_equals_interpreter(case, tmp_path):
    text, n = case
    path = tmp_path / "random.yaml"
    path.write_text(text)
    patch = load(path)
    probes = [f"b{i}.{o.name}" for i in range(n) for o in patch.blocks[f"b{i}"].outputs]
    a = render(patch, 300 / patch.rate, probes=probes, engine="compiled")
    b = render(load(path), 300 / patch.rate, probes=probes, engine="python")
    for k in probes:
        np.testing.assert_allclose(a.probes[k], b.probes[k], rtol=1e-12, atol=1e-12, equal_nan=True,
                                   err_msg=f"{k}\n{text}")
    # random feedback may legitimately diverge (a loop gain above 1); what must hold is that the
    # run is finite, or the safety check stops it in the block where it stops being finite
    try:
        safe = render(load(path), 300 / patch.rate, probes=probes, safety=True, runaway=np.inf, chunk=64)
    except SafetyStop as stop:
        assert "numerical blow-up" in str(stop)
        assert all(np.all(np.isfinite(v)) for v in stop.result.probes.values())
        assert not all(np.all(np.isfinite(a.probes[k])) for k in probes)
    else:
        assert all(np.all(np.isfinite(v)) for v in safe.probes.values())
