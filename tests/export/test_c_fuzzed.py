"""The fuzzed graphs the engines are tested on (tests/graph/test_random_graphs.py: random block
types and parameters within their declared ranges, random wiring with feedback through blocks that
do not feed through, at 8, 44.1 or 48 kHz) exported to C: each one either exports and its C gives
the bits of the Python run — every output of every block, wired to an audio_out added for the
purpose — at its rate and at another (48 kHz, or 44.1 for a graph written at 48), or is refused
cleanly: exit 2 and every line `FILE:LINE: message`, never a crash of the translator. 20 graphs,
the same 20 on every run (derandomized)."""
import importlib.util
import itertools
import re

import numpy as np
from hypothesis import HealthCheck, given, settings

from hapticgraph import render
from hapticgraph.cli.main import main
from hapticgraph.graph.patch import load
from project_env import ROOT

# the generator itself, from the module the engines' test lives in
_SPEC = importlib.util.spec_from_file_location("random_graphs", ROOT / "tests" / "graph" / "test_random_graphs.py")
RANDOM_GRAPHS = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(RANDOM_GRAPHS)
SAMPLES = 300
EXAMPLES = 20
COUNT = itertools.count()


def with_outputs(text, n):
    """The graph with an audio_out recording every output of every block, one channel each."""
    patch = load_text(text)
    outs = [f"b{i}.{o.name}" for i in range(n) for o in patch.blocks[f"b{i}"].outputs]
    blocks, _, connect = text.partition("connect:")
    ports = ["left", "right"] if len(outs) == 2 else [f"ch{k}" for k in range(len(outs))]
    lines = [blocks.rstrip("\n"), f"  rec: {{type: audio_out, channels: {len(outs)}}}", "connect:"]
    lines += [line for line in connect.splitlines() if line.strip().startswith("- ")]
    lines += [f"  - {o} -> rec.{port}" for o, port in zip(outs, ports)]
    return "\n".join(lines) + "\n"


def load_text(text):
    return load("fuzzed.yaml", text=text)


def test_fuzzed_graphs_export_with_the_bits_of_python_or_are_refused_at_file_line(tmp_path, capsys, c_export,
                                                                                 same_bits):
    seen = {"exported": 0, "refused": 0}

    @settings(max_examples=EXAMPLES, derandomize=True, database=None, deadline=None,
              suppress_health_check=[HealthCheck.too_slow])
    @given(case=RANDOM_GRAPHS.patches())
    def one(case):
        text, n = case
        path = tmp_path / f"fuzzed{next(COUNT)}.yaml"
        path.write_text(with_outputs(text, n), encoding="utf-8")
        patch = load(path)
        capsys.readouterr()
        status = main(["export", str(path), "--to", "c", "--out", str(tmp_path / path.stem)])
        said = capsys.readouterr().err.strip().splitlines()
        if status == 2:
            seen["refused"] += 1
            assert said and all(re.match(rf"{re.escape(str(path))}:\d+: ", line) for line in said), said
            return
        assert status == 0, said
        seen["exported"] += 1
        built = c_export(path)
        expected = render(patch, SAMPLES / patch.rate).audio
        got = built.run(patch.rate, SAMPLES, block=SAMPLES)
        assert np.abs(expected).max() > 0.0 or not np.any(got), text
        assert same_bits(got, expected), text
        other = 48000 if patch.rate != 48000 else 44100      # and at another rate, as `run` renders it there
        at_other = load(path, text=re.sub(r"(?m)^rate: .*$", f"rate: {other}", path.read_text(encoding="utf-8")))
        assert same_bits(built.run(other, SAMPLES, block=SAMPLES), render(at_other, SAMPLES / other).audio), text

    one()
    assert seen["exported"] + seen["refused"] == EXAMPLES
    assert seen["exported"] >= EXAMPLES * 3 // 4, seen       # most export: a refusal is the exception
