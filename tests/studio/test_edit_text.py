"""The studio's text edits (hapticgraph/studio/edits.py, yamltext.py): each changes only the span
of what was edited, keeps comments and layout byte for byte elsewhere, and gives a patch the
loader accepts; undoing an edit by its reverse gives back the original text."""
import difflib
import pathlib
import shutil

import pytest

from hapticgraph.graph.patch import load
from hapticgraph.studio import edits
from hapticgraph.studio import yamltext as yt

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _changed(a, b):
    """The lines removed and added from text a to text b."""
    diff = difflib.unified_diff(a.splitlines(True), b.splitlines(True), n=0)
    return [line for line in diff if line[:1] in "+-" and line[:3] not in ("+++", "---")]


@pytest.fixture
def block_patch(tmp_path):
    path = tmp_path / "cymatic_block.yaml"
    shutil.copy(ROOT / "patches" / "cymatic_block.yaml", path)
    return path


def test_set_replaces_only_the_value(block_patch):
    text = block_patch.read_text()
    new = edits.set_param(text, load(block_patch), "blk", "tension", 2400.5)
    assert _changed(text, new) == [
        "-  blk:   {type: lattice, shape: [6, 7, 8], mass: 0.0005, tension: 2600.0, damping: 0.002, boundary: fixed}\n",
        "+  blk:   {type: lattice, shape: [6, 7, 8], mass: 0.0005, tension: 2400.5, damping: 0.002, boundary: fixed}\n"]
    assert load(block_patch, text=new).blocks["blk"].values["tension"] == 2400.5


def test_a_parameter_not_written_yet_is_added_in_the_mappings_style(block_patch):
    text = block_patch.read_text()
    new = edits.set_param(text, load(block_patch), "hit", "duration", 0.001)
    assert "duration: 0.001}" in new
    new = edits.set_param(text, load(block_patch), "mic1", "gain", 3)
    assert "mic1:  {type: mic, gain: 3, pan: -0.5}" in new


def test_lock_then_unlock_gives_back_the_text(block_patch):
    text = block_patch.read_text()
    patch = load(block_patch)
    locked = edits.cell_edit(text, patch, "lock", "blk[1, 2, 3]")
    assert load(block_patch, text=locked).blocks["blk"].values["lock"] == [[1, 2, 3]]
    assert len(_changed(text, locked)) == 2
    assert edits.cell_edit(locked, patch, "unlock", "blk[1, 2, 3]") == text
    with pytest.raises(edits.EditError, match="not locked"):
        edits.cell_edit(text, patch, "unlock", "blk[1, 2, 3]")


def test_a_block_style_list_gets_a_line_in_its_style(write_patch):
    path = write_patch("""
        hapticgraph: 1
        blocks:
          # the plate
          plate:
            type: lattice
            shape: [4, 4]
            tension: 100.0   # soft
            cut:
              - [0, 0]
              - [0, 1]
          out: {type: audio_out, channels: 1}
        connect:
          - plate[2, 2].position -> out.ch0
        """)
    text = path.read_text()
    patch = load(path)
    cut = edits.cell_edit(text, patch, "cut", "plate[3, 3]")
    assert _changed(text, cut) == ["+      - [3, 3]\n"]
    assert load(path, text=cut).blocks["plate"].values["cut"] == [[0, 0], [0, 1], [3, 3]]
    soft = edits.set_param(text, patch, "plate", "tension", 50.0)
    assert "    tension: 50.0   # soft\n" in soft
    damped = edits.set_param(text, patch, "plate", "damping", 0.01)
    assert _changed(text, damped) == ["+    damping: 0.01\n"]
    load(path, text=damped)


def test_place_moves_a_microphone_and_an_excitation(block_patch):
    text = block_patch.read_text()
    patch = load(block_patch)
    moved = edits.place(text, patch, "mic1", "blk[0, 1, 2]")
    assert _changed(text, moved) == ["-  - blk[3, 4, 5].velocity -> mic1.in\n", "+  - blk[0, 1, 2].velocity -> mic1.in\n"]
    hit = edits.place(text, patch, "hit", "blk[5, 6, 7]")
    assert _changed(text, hit) == ["-  - hit.out -> blk[1, 1, 2].force\n", "+  - hit.out -> blk[5, 6, 7].force\n"]
    for new in (moved, hit):
        load(block_patch, text=new)


def test_a_new_microphone_is_added_and_wired_and_removed_again(block_patch):
    text = block_patch.read_text()
    patch = load(block_patch)
    new = edits.place(text, patch, "mic3", "blk[2, 2, 2]", type="mic", params={"pan": 0.25})
    assert _changed(text, new) == ["+  mic3: {type: mic, pan: 0.25}\n", "+  - blk[2, 2, 2].velocity -> mic3.in\n",
                                   "+  - mic3.left -> out.left\n", "+  - mic3.right -> out.right\n"]
    loaded = load(block_patch, text=new)
    assert [str(c) for c in loaded.connections if c.dst.block == "mic3"] == ["blk[2, 2, 2].velocity -> mic3.in"]
    assert edits.remove(new, loaded, "mic3") == text


def test_join_adds_a_spring_between_two_parts(tmp_path):
    path = tmp_path / "p.yaml"
    shutil.copy(ROOT / "patches" / "string_drives_plate.yaml", path)
    text = path.read_text()
    new, name = edits.join(text, load(path), "str[3]", "plate[1, 1]", tension=500.0)
    assert name == "join1"
    assert _changed(text, new) == ['+  join1: {type: spring, a: "str[3]", b: "plate[1, 1]", tension: 500.0}\n']
    assert load(path, text=new).blocks["join1"].values["b"] == "plate[1, 1]"


def test_cells_overrides_are_written_and_removed(block_patch):
    text = block_patch.read_text()
    patch = load(block_patch)
    heavy = edits.cells(text, patch, "blk", [[1, 1, 1], [2, 2, 2]], {"mass": 0.001})
    cells = load(block_patch, text=heavy).blocks["blk"].values["cells"]
    assert [(list(c["index"]), c["mass"]) for c in cells] == [([1, 1, 1], 0.001), ([2, 2, 2], 0.001)]
    assert edits.cells(heavy, patch, "blk", [[1, 1, 1], [2, 2, 2]], {"mass": None}) == text


def test_map_section_written_replaced_and_removed(tmp_path):
    for name in ("midi_melody.yaml", "melody.mid"):
        shutil.copy(ROOT / "patches" / name, tmp_path / name)
    path = tmp_path / "midi_melody.yaml"
    text = path.read_text()
    entries = [{"param": "tone.amplitude", "cc": 7, "min": 0.1, "max": 0.4}]
    new = edits.write_map(text, entries)
    assert _changed(text, new) == [
        "-  - {param: tone.amplitude, cc: 74, min: 0.1, max: 0.5, curve: exponential, smooth: 0.01}\n",
        "+  - {param: tone.amplitude, cc: 7, min: 0.1, max: 0.4}\n"]
    assert "map_tone_amplitude" in load(path, text=new).blocks
    gone = edits.write_map(text, [])
    assert "\nmap:" not in gone and "map_tone_amplitude" not in load(path, text=gone).blocks
    assert edits.write_map(gone, [{"param": "tone.amplitude", "cc": 74, "min": 0.1, "max": 0.5,
                                   "curve": "exponential", "smooth": 0.01}]) == text


def test_values_are_written_as_yaml_that_reads_back():
    for value in (1e-05, 2600.0, 3, True, None, "plain", "str[36]", "a: b", [1, 2], {"index": [1]}):
        assert yt.format_value(value) in {"1e-05", "2600.0", "3", "true", "null", "plain", '"str[36]"',
                                          '"a: b"', "[1, 2]", "{index: [1]}"}
    with pytest.raises(yt.TextError):
        yt.format_value(float("nan"))


def test_bad_cells_are_refused(block_patch):
    text, patch = block_patch.read_text(), load(block_patch)
    for cell in ("blk", "blk[1, x]", "nope[1, 1, 1]", "hit[0]"):
        with pytest.raises(edits.EditError):
            edits.cell_edit(text, patch, "lock", cell)
