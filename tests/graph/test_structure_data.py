"""Structure and data declared (issue 20, item 5): a block names the values of `derive` that are the
kernel's structure (`structure = (...)`: flags, choices); every other number it derives is data.
Editing a fractional delay length or a filter's coefficient re-uses the compiled kernel; a change
of structure (a flag, a choice) compiles another one. The cache entries on disk are counted. The
literals left in the kernel carry their names."""
import numpy as np
import pytest

from hapticgraph import render
from hapticgraph.blocks import Block, BlockDefinitionError, In, Out, Param
from hapticgraph.graph import kernel
from hapticgraph.graph.codegen import generate
from hapticgraph.graph.errors import PlanError
from hapticgraph.graph.patch import load
from hapticgraph.graph.program import Program

PATCH = """\
hapticgraph: 1
blocks:
  pick:  {{type: pluck, time: 0.0, force: 1.0, duration: 0.001}}
  loop:  {{type: delay, length: {length}}}
  damp:  {{type: lowpass, gain: 0.99}}
  speed: {{type: velocity_estimator, cutoff: {cutoff}}}
  curve: {{type: scale, in_range: [-1.0, 1.0], out_range: [0.5, 2.0], curve: {curve}}}
  mic:   {{type: mic, gain: 1.0}}
  out:   {{type: audio_out, channels: 2}}
connect:
  - pick.out -> loop.in
  - loop.out -> damp.in
  - damp.out -> loop.in
  - damp.out -> speed.in
  - speed.out -> curve.in
  - curve.out -> mic.in
  - mic.left -> out.left
  - mic.right -> out.right
"""
BASE = dict(length=99.25, cutoff=1000.0, curve="linear")


def _entries(cache):
    return sorted(p.name for p in cache.iterdir() if p.name.startswith("kernel_"))


def _path(tmp_path, name, **values):
    path = tmp_path / f"{name}.yaml"
    path.write_text(PATCH.format(**{**BASE, **values}))
    return path


@pytest.fixture
def fresh_cache(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("HAPTICGRAPH_CACHE", str(cache))
    monkeypatch.setattr(kernel, "_loaded", {})      # nothing this process compiled before counts
    return cache


def test_fractional_delay_lengths_and_filter_coefficients_reuse_one_kernel(tmp_path, fresh_cache):
    first = render(load(_path(tmp_path, "a", length=99.25)), 0.01)
    second = render(load(_path(tmp_path, "b", length=98.5)), 0.01)
    assert len(_entries(fresh_cache)) == 1, _entries(fresh_cache)
    assert not np.array_equal(first.audio, second.audio)       # the edit did change the sound
    third = render(load(_path(tmp_path, "c", length=98.5, cutoff=2500.0)), 0.01)
    assert len(_entries(fresh_cache)) == 1, "a filter's coefficient compiled a new kernel"
    assert not np.array_equal(second.audio, third.audio)


def test_a_change_of_structure_compiles_again(tmp_path, fresh_cache):
    render(load(_path(tmp_path, "a", length=99.25)), 0.01)
    render(load(_path(tmp_path, "b", length=99.0)), 0.01)           # `whole`: a flag
    assert len(_entries(fresh_cache)) == 2
    render(load(_path(tmp_path, "c", length=99.0, curve="exponential")), 0.01)     # a choice
    assert len(_entries(fresh_cache)) == 3


@pytest.mark.parametrize("length", [99.25, 98.5, 99.0])
def test_compiled_equals_interpreter(tmp_path, length):
    path = _path(tmp_path, "p", length=length)
    a = render(load(path), 0.005, engine="compiled")
    b = render(load(path), 0.005, engine="python")
    np.testing.assert_array_equal(a.audio, b.audio)


def test_literals_in_the_kernel_carry_their_names(tmp_path):
    source, _ = generate(Program(load(_path(tmp_path, "p"))))
    assert "loop_y = delay_output(loop_line, 127,  # loop: line ring mask\n" in source
    assert "False)  # loop: whole\n" in source          # declared structure
    assert "curve_expo = " not in source and "curve_x0 = coef[" in source     # a choice literal, a number data
    assert "speed_a = coef[" in source and "loop_c0 = coef[" in source


PLUGIN = '''from hapticgraph.blocks import Block, In, Out, Param


class Gate(Block, name="gate"):
    """out = in while level > 0.5, else 0."""
    x = In(name="in")
    y = Out(name="out")
    level = Param(1.0, minimum=0.0, maximum=1.0)
    structure = ("open",)

    @staticmethod
    def derive(p, fs):
        return {"open": p.level > 0.5, "scale": 2.0 * p.level}

    @staticmethod
    def output(x, open, scale):
        return scale * x if open else 0.0
'''


def test_set_param_refuses_to_change_structure(tmp_path):
    (tmp_path / "gate.py").write_text(PLUGIN)
    (tmp_path / "p.yaml").write_text("hapticgraph: 1\nplugins: [gate.py]\nblocks:\n"
                                     "  w: {type: wavetable}\n  g: {type: gate, level: 0.8}\nconnect: [w.out -> g.in]\n")
    prog = Program(load(tmp_path / "p.yaml"))
    source, _ = generate(prog)
    assert "gate_output(w_y, True,  # g: open\n" in source and "g_scale = coef[" in source
    prog.set_param("g", "level", 0.6)                     # data: the coefficient follows
    assert prog.coef[prog.by_name["g"].coef_slots["scale"]] == pytest.approx(1.2)
    with pytest.raises(PlanError, match="'open', part of the kernel's structure"):
        prog.set_param("g", "level", 0.2)
    assert prog.block_values("g")["level"] == 0.6        # refused: nothing changed
    assert prog.coef[prog.by_name["g"].coef_slots["scale"]] == pytest.approx(1.2)


def test_structure_is_checked_when_the_class_is_defined():
    with pytest.raises(BlockDefinitionError, match=r"structure names \['mode'\], which derive does not return"):
        class Bad(Block, name="bad_structure"):
            """out = in."""
            x = In(name="in")
            y = Out(name="out")
            structure = ("mode",)

            @staticmethod
            def derive(p, fs):
                return {"k": 1.0}

            @staticmethod
            def output(x, k):
                return k * x
    with pytest.raises(BlockDefinitionError, match=r"derive's value 'shape' \(str\) is not a number"):
        class Undeclared(Block, name="undeclared_structure"):
            """out = in."""
            x = In(name="in")
            y = Out(name="out")
            shape = Param("a", choices=("a", "b"))

            @staticmethod
            def derive(p, fs):
                return {"shape": p.shape}

            @staticmethod
            def output(x, shape):
                return x
