"""The contract every registered block type keeps: a valid schema, defaults that pass it, and a
single-block patch (every input fed) that compiles both ways, agrees and stays finite."""
import os

import jsonschema
import numpy as np
import pytest

from project_env import single_block_patch
from hapticgraph.blocks.vocabulary import BlockDefinitionError
from hapticgraph import render
from hapticgraph.graph.patch import load
from hapticgraph.graph.registry import Registry

REGISTRY = Registry()
TYPES = sorted(REGISTRY.types)


@pytest.mark.parametrize("kind", TYPES)
def test_schema_and_defaults(kind):
    cls = REGISTRY.types[kind]
    schema = cls.schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    defaults = {"type": kind, **{n: (list(p.default) if p.kind == "list" else p.default)
                                 for n, p in cls.params.items() if not p.internal}}
    jsonschema.validate(defaults, schema)
    assert cls.__doc__ and cls.__doc__.strip(), "a block needs its one-line equation"
    for name, p in cls.params.items():
        assert name == name.lower() or name in ("R",), f"parameter {name} is not snake_case"


@pytest.mark.parametrize("kind", TYPES)
def test_single_block_compiles_both_ways(kind, write_patch, tmp_path):
    from hapticgraph.devices.wav import write_wav
    write_wav(tmp_path / "in.wav", np.sin(np.arange(4410) * 0.05)[:, None] * 0.5, 44100)
    cls = REGISTRY.types[kind]
    inputs, outputs = cls.ports(cls.default_params())
    feeds = [(p.name, f"{{type: noise, amplitude: 0.1, seed: {i + 1}}}") for i, p in enumerate(inputs)]
    patch = load(write_patch(single_block_patch(kind, inputs=feeds)))
    probes = [f"b.{o.name}" for o in outputs]
    a = render(patch, 500 / patch.rate, probes=probes, engine="compiled")
    b = render(load(patch.file), 500 / patch.rate, probes=probes, engine="python")
    for k in probes:
        assert np.all(np.isfinite(a.probes[k])), k
        np.testing.assert_allclose(a.probes[k], b.probes[k], rtol=0, atol=1e-12, err_msg=k)


def test_feedthrough_is_inferred_from_output_arguments():
    types = REGISTRY.types
    assert types["delay"].feedthrough() == set()
    assert types["lowpass"].feedthrough() == {"in", "gain"}
    assert types["sample_hold"].feedthrough() == {"in", "hold"}
    assert types["pluck"].feedthrough() == {"force"}   # the trigger acts one sample later


@pytest.mark.parametrize("body,needle", [
    ("x = In()\n    y = Out()", "declares outputs but no output()"),
    ("y = Out()\n    @staticmethod\n    def output(z):\n        return z", "argument 'z' is not a port"),
    ("y = Out()\n    def output(y):\n        return 1.0", "must be a @staticmethod"),
    ("s = State()\n    y = Out()\n    @staticmethod\n    def output(s):\n        return s", "no update()"),
    ("g = Param(5.0, maximum=1.0)", "outside its range"),
    ("g = Param('a', choices=('b', 'c'))", "is not one of"),
    ("t = In()", "reserved"),
    ("x = In(name='y')\n    y = Out()\n    @staticmethod\n    def output(x):\n        return x",
     "used for more than one port"),
    ("k = Param(1)\n    @staticmethod\n    def derive(p, fs):\n        return {'a': p.q}", "unknown parameter(s) ['q']"),
    ("@staticmethod\n    def derive(p, fs):\n        return {'a': 1 / 0}", "derive fails on the default"),
])
def test_definition_time_checks(body, needle, tmp_path):
    """A malformed block fails when its module is imported, with a message naming the fault."""
    import importlib.util
    import re
    path = tmp_path / "bad_plugin.py"
    path.write_text("from hapticgraph.blocks import Block, In, Out, Param, State\n\n"
                    f"class Bad(Block, name='bad_block'):\n    {body}\n")
    spec = importlib.util.spec_from_file_location("bad_plugin", path)
    with pytest.raises(BlockDefinitionError, match=re.escape(needle)):
        spec.loader.exec_module(importlib.util.module_from_spec(spec))


def test_live_param_is_an_input_port(write_patch):
    text = """
    hapticgraph: 1
    blocks:
      lfo: {type: wavetable, frequency: 100.0, amplitude: 0.5}
      one: {type: constant, value: 2.0}
      g: {type: gain, gain: 10.0}
    connect:
      - one.out -> g.in
      - lfo.out -> g.gain
    """
    r = render(load(write_patch(text)), 100 / 44100, probes=["lfo.out", "g.out", "g.gain"])
    np.testing.assert_allclose(r.probes["g.out"], 2.0 * r.probes["lfo.out"])
    np.testing.assert_allclose(r.probes["g.gain"], r.probes["lfo.out"])


def test_return_count_checked_for_a_block_defined_inside_a_function():
    """Block types made in a function (not at module or class level) are read from their own
    source, and the line named is the file's."""
    import inspect
    import re
    from hapticgraph.blocks import Block, Out
    with pytest.raises(BlockDefinitionError, match=re.escape("returns one value (line ")) as err:
        class Made(Block, name="made_in_a_function"):
            a = Out()
            b = Out()

            @staticmethod
            def output():
                return 1.0
    line = int(re.search(r"\(line (\d+)\)", str(err.value)).group(1))
    src, first = inspect.getsourcelines(test_return_count_checked_for_a_block_defined_inside_a_function)
    assert src[line - first].strip() == "return 1.0"


def test_an_edited_plugin_file_is_read_again(tmp_path):
    """The source a definition check reads is the file as it is now, not as first read."""
    import importlib.util
    path = tmp_path / "edited_plugin.py"
    head = "from hapticgraph.blocks import Block, Out\n\nclass P(Block, name='edited_p'):\n    y = Out()\n"
    good = head + "    @staticmethod\n    def output():\n        return 1.0\n"
    bad = head + "    @staticmethod\n    def output():\n        return 1.0, 2.0\n"
    for text, fails in ((good, False), (bad, True)):
        path.write_text(text)
        os.utime(path, (1, len(text)))          # a new mtime even within the file system's tick
        spec = importlib.util.spec_from_file_location("edited_plugin", path)
        if fails:
            with pytest.raises(BlockDefinitionError, match=r"returns 2 values \(line 7\)"):
                spec.loader.exec_module(importlib.util.module_from_spec(spec))
        else:
            spec.loader.exec_module(importlib.util.module_from_spec(spec))
