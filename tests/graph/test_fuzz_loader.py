"""Random invalid documents never crash the loader: every outcome is a Patch or a PatchError
whose problems all read `FILE:LINE: message`."""
import re

import yaml
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from hapticgraph.graph.errors import PatchError
from hapticgraph.graph.patch import load
from hapticgraph.graph.registry import Registry

TYPES = sorted(Registry().types)
PORTS = ["in", "out", "left", "right", "force", "position", "velocity", "x", "v", "gain", "aL", "bR", "ch0"]

scalars = st.one_of(st.none(), st.booleans(), st.integers(-10**12, 10**12),
                    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12))
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                       st.dictionaries(st.text(max_size=8), inner, max_size=4)),
                      max_leaves=12)
names = st.from_regex(r"[a-z][a-z0-9_]{0,6}", fullmatch=True)
ints = st.integers(-3, 12)
index = st.lists(ints, max_size=3)
structured = {
    "shape": st.one_of(index, st.lists(st.integers(0, 4000), max_size=3)),
    "lock": st.lists(index, max_size=3), "cut": st.lists(index, max_size=3),
    "cells": st.lists(st.fixed_dictionaries({"index": index}, optional={
        "mass": scalars, "damping": scalars, "locked": st.booleans()}), max_size=3),
    "a": st.builds(lambda n, i: f"{n}[{', '.join(map(str, i))}]", st.sampled_from(["s", "p", "c"]), index),
    "b": st.sampled_from(["s", "p[0]", "c", "p[1, 1]", ""]),
}


@st.composite
def documents(draw):
    """Mostly patch-shaped documents with random damage."""
    blocks = {}
    for name in draw(st.lists(st.one_of(names, st.sampled_from(["s", "p", "c"])), max_size=5, unique=True)):
        spec = {"type": draw(st.one_of(st.sampled_from(TYPES), st.text(max_size=6)))}
        for key in draw(st.lists(st.one_of(st.sampled_from(
                ["length", "gain", "shape", "mass", "tension", "coeffs", "device", "a", "b", "cut", "lock", "cells",
                 "channels", "frequency", "impedance", "k", "pole", "file", "seed"]), st.text(max_size=6)),
                max_size=4)):
            spec[key] = draw(st.one_of(structured[key], values) if key in structured else values)
        blocks[name] = spec
    endpoints = st.builds(lambda b, i, p: f"{b}{i}.{p}", st.sampled_from(list(blocks) or ["x"]),
                          st.sampled_from(["", "[0]", "[1, 2]", "[-1]", "[99999]"]), st.sampled_from(PORTS))
    doc = {"hapticgraph": draw(st.sampled_from([1, 1, 1, 2, "1", None])),
           "rate": draw(st.one_of(st.just(44100), scalars)),
           "blocks": blocks if draw(st.booleans()) or not blocks else draw(values),
           "connect": draw(st.lists(st.one_of(st.builds(lambda a, b: f"{a} -> {b}", endpoints, endpoints),
                                              scalars), max_size=5))}
    if draw(st.booleans()):
        keyframe = st.dictionaries(st.sampled_from(["t", "x", "v", "pedal", "force", "1x"]), scalars, max_size=4)
        doc["devices"] = draw(st.one_of(values, st.fixed_dictionaries({"finger": st.fixed_dictionaries(
            {"driver": st.sampled_from(["simulated", "hid", "replay", "x"])},
            optional={"script": st.one_of(st.lists(keyframe, max_size=4), values), "max_force": scalars,
                      "mass": scalars, "profile": scalars, "file": scalars, "hold": scalars})})))
    for key in draw(st.lists(st.text(max_size=6), max_size=2)):
        doc[key] = draw(values)
    return doc


LINE = re.compile(r"^.+:\d+: \S")


def _check(path):
    try:
        load(path)
    except PatchError as exc:
        assert exc.problems
        for p in exc.problems:
            assert LINE.match(str(p)), str(p)


@settings(max_examples=int(__import__("os").environ.get("FUZZ_EXAMPLES", "300")), deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(doc=documents())
@example(doc={"hapticgraph": 1, "rate": 44100, "connect": [],      # a type that is a list (unhashable)
              "blocks": {"b": {"type": "audio_in"}, "f": {"type": [], "length": None}}})
def test_damaged_documents(doc, tmp_path):
    path = tmp_path / "fuzz.yaml"
    path.write_text(yaml.safe_dump(doc, allow_unicode=True))
    _check(path)


@settings(max_examples=int(__import__("os").environ.get("FUZZ_EXAMPLES", "300")), deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=st.text(alphabet=st.sampled_from(list("abxyz019:-[]{},.&*!|>'\"#\n \t<%@`?") + ["\u00e9", "\x00"]),
                    max_size=120))
@example(text="*0:")                    # a key that is an undefined alias (it has no tag to read)
@example(text="a: &x [1]\n*x : 2\n")   # a key that is an alias of a list
def test_random_text(text, tmp_path):
    path = tmp_path / "fuzz.yaml"
    path.write_text("hapticgraph: 1\nblocks:\n" + text, encoding="utf-8")
    _check(path)
    path.write_text(text, encoding="utf-8")
    _check(path)
