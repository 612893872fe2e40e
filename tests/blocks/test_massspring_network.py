"""The mass-spring network (blocks/massspring/network.py) is built once per load: the stability
check, `hapticgraph modes` and the first Program share it, and a second Program of the same
patch gets a network of its own, so both start from rest and play the same."""
import pathlib

import numpy as np
import pytest

from hapticgraph import PatchError, load, render
from hapticgraph.blocks.family import LinearGroup
from hapticgraph.blocks.massspring import network as network_module
from hapticgraph.blocks.massspring import stencils
from hapticgraph.graph.modes import mode_blocks, mode_shape, modal_frequencies
from hapticgraph.graph.program import Program

ROOT = pathlib.Path(__file__).resolve().parents[2]
STRING = """
hapticgraph: 1
rate: 44100
blocks:
  str: {type: lattice, shape: [40], mass: 0.0002, tension: 20000.0}
  hit: {type: pluck, time: 0.0, force: 1.0, duration: 0.0005}
  out: {type: audio_out}
connect:
  - hit.out -> str[10].force
  - str[30].position -> out.left
"""


@pytest.fixture
def builds(monkeypatch):
    """The Networks built from now on, in order."""
    built = []
    init = network_module.Network.__init__

    def counted(self, *args, **kwargs):
        built.append(self)
        init(self, *args, **kwargs)

    monkeypatch.setattr(network_module.Network, "__init__", counted)
    return built


def test_the_check_modes_and_the_program_share_one_network(write_patch, builds):
    patch = load(write_patch(STRING.replace("tension: 20000.0", "tension: 20000.0, lock: [[0]]")))
    assert len(builds) == 1                                   # the stability check's
    modal_frequencies(patch, count=3)
    assert mode_blocks(patch) == ["str"]
    mode_shape(patch, "str", 1)
    prog = Program(patch)
    assert len(builds) == 1
    assert prog.groups[0].group is builds[0]
    assert isinstance(builds[0], LinearGroup)


def test_a_uniform_lattice_is_checked_from_its_declarations(write_patch, builds):
    """One uniform lattice: the stability check's bound is exact, so loading builds no network
    (no per-cell table); the first to ask (here `modes`) builds it and the Program shares it."""
    patch = load(write_patch(STRING))
    assert builds == []
    modal_frequencies(patch, count=3)
    assert len(builds) == 1
    prog = Program(patch)
    assert prog.groups[0].group is builds[0] and len(builds) == 1
    assert builds[0].tables_built                      # modes read them
    fresh = Program(load(write_patch(STRING, name="again.yaml")))
    assert fresh.groups[0].group.stencil == "string" and not fresh.groups[0].group.tables_built


def test_a_second_program_runs_a_network_of_its_own(write_patch, builds):
    patch = load(write_patch(STRING))
    first = render(patch, 0.02)
    second = render(patch, 0.02)
    assert len(builds) == 2
    assert builds[0].pos is not builds[1].pos
    assert np.abs(first.audio).max() > 0
    np.testing.assert_array_equal(first.audio, second.audio)


def test_the_shared_network_takes_the_programs_path(write_patch, builds):
    """The check's network steps on a stencil, or on the CSR lists when the Program is editable."""
    patch = load(write_patch(STRING))
    assert Program(patch, editable=True).groups[0].group.stencil is None
    assert Program(patch).groups[0].group.stencil == "string"
    assert len(builds) == 2


def test_modes_read_only_groups_with_a_linear_model():
    """The plugin family's bank (a Group, not a LinearGroup) has no modes to list."""
    bell = load(ROOT / "examples" / "family_plugin" / "bell.yaml")
    assert mode_blocks(bell) == [] and modal_frequencies(bell) == {}


OLD_LINK = """
from hapticgraph.blocks import Block, Param
from hapticgraph.blocks.massspring import MassSpring


class OldSpring(Block, name="old_spring"):
    a = Param("")
    b = Param("")
    family = MassSpring

    @staticmethod
    def law_of(values):
        return None
"""


def test_a_link_block_that_is_not_a_link_is_named(write_patch, tmp_path):
    (tmp_path / "old.py").write_text(OLD_LINK)
    path = write_patch("""
        hapticgraph: 1
        plugins: [old.py]
        blocks:
          c1: {type: cell}
          c2: {type: cell}
          s: {type: old_spring, a: c1, b: c2}
        connect: []
        """)
    with pytest.raises(PatchError) as err:
        load(path)
    assert "block 's' (old_spring): a member of the mass-spring family is a cell, a lattice, a point or a link" \
           in str(err.value)
    assert "subclasses Link" in str(err.value)


@pytest.mark.parametrize("shape", [(30000,), (32, 32), (7,), (5, 6, 7), (1, 1), (100, 100), (3, 4, 37)])
def test_a_stencils_first_cell_starts_a_cache_line(shape, write_patch):
    """A uniform lattice's two position buffers have their first cell (where each run's first
    load and store fall) on a 64-byte boundary (stencils.padded_zeros: 8-wide loads and stores
    that straddle two lines cost the run 12-20 %), contiguous, of the padded size."""
    patch = load(write_patch(f"""
        hapticgraph: 1
        rate: 44100
        blocks:
          s: {{type: lattice, shape: {list(shape)}, mass: 0.001, tension: 10.0}}
          out: {{type: audio_out, channels: 1}}
        connect:
          - s[{', '.join('0' for _ in shape)}].position -> out.ch0
        """))
    group = Program(patch).groups[0].group
    assert group.stencil == ("string", "sheet", "cube")[len(shape) - 1]
    first = stencils.padded_index(shape, (0,) * len(shape))
    for buffer in (group.pos, group.prev):
        assert buffer.flags["C_CONTIGUOUS"] and buffer.size == stencils.padded_size(shape)
        assert (buffer.ctypes.data + 8 * first) % 64 == 0
    width = stencils.padded(shape)[-1]
    if len(shape) >= 2 and width != shape[-1] + 2:          # rows rounded up: each starts a line too
        assert width % 8 == 0 and width - (shape[-1] + 2) <= width / 16
        rows = [stencils.padded_index(shape, (0,) * (len(shape) - 2) + (r, 0)) for r in range(shape[-2])]
        assert all((group.pos.ctypes.data + 8 * i) % 64 == 0 for i in rows)
