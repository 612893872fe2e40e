"""The `voices:` template (hapticgraph.graph.voices): copied per voice before the patch is
checked, connections rewritten (inside a voice, into a shared block, from a shared block), the
voice parameters numbered, and every problem in the template told once, at its own line."""
import pytest

import hapticgraph
from hapticgraph import PatchError

HEAD = """
hapticgraph: 1
devices:
  keys: {driver: midi}
blocks:
  level: {type: constant, value: 0.5}
  out: {type: audio_out, channels: 1}
"""
VOICES = """
voices:
  count: 3
  blocks:
    note: {type: midi_note, device: keys}
    amp: {type: gain, gain: 1.0}
  connect:
    - note.gate -> amp.in
    - level.out -> amp.gain
    - amp.out -> out.ch0
"""


def _problems(write_patch, text):
    with pytest.raises(PatchError) as err:
        hapticgraph.load(write_patch(text))
    return [(p.line, p.message) for p in err.value.problems]


def test_copies_connections_and_voice_numbers(write_patch):
    patch = hapticgraph.load(write_patch(HEAD + VOICES))
    assert list(patch.blocks) == ["level", "out", "v1_note", "v1_amp", "v2_note", "v2_amp", "v3_note", "v3_amp"]
    assert [(patch.blocks[f"v{k}_note"].values["voice"], patch.blocks[f"v{k}_note"].values["voices"])
            for k in (1, 2, 3)] == [(1, 3), (2, 3), (3, 3)]
    assert sorted(map(str, patch.connections)) == sorted(
        [f"v{k}_note.gate -> v{k}_amp.in" for k in (1, 2, 3)] + [f"level.out -> v{k}_amp.gain" for k in (1, 2, 3)]
        + [f"v{k}_amp.out -> out.ch0" for k in (1, 2, 3)])
    lines = {str(c): c.line for c in patch.connections}
    assert lines["v2_amp.out -> out.ch0"] == lines["v3_amp.out -> out.ch0"] == HEAD.count("\n") + VOICES.count("\n") - 1
    assert patch.blocks["v3_amp"].line == patch.blocks["v1_amp"].line == HEAD.count("\n") + 5


def test_a_voice_block_may_be_wired_from_outside_and_set(write_patch):
    text = HEAD + "connect:\n  - v2_amp.out -> out.ch0\n" + VOICES.replace("count: 3", "count: 2\n  prefix: string")
    text = text.replace("v2_amp", "string2_amp")
    patch = hapticgraph.load(write_patch(text), overrides=["string1_amp.gain=0.25"])
    assert patch.blocks["string1_amp"].values["gain"] == 0.25 and "string2_note" in patch.blocks


def test_a_problem_in_the_template_is_told_once_at_its_line(write_patch):
    text = HEAD + VOICES.replace("gain: 1.0", "gain: 1.0e+9").replace("note.gate -> amp.in", "note.gait -> amp.in")
    base = HEAD.count("\n")
    found = _problems(write_patch, text)
    assert found[0] == (base + 5, "voices: block 'amp' (gain): parameter 'gain': 1000000000.0 is above the "
                                  "maximum 1000000.0")
    assert len(found) == 2 and found[1][0] == base + 7     # each once, not once per voice
    found = _problems(write_patch, HEAD + VOICES.replace("note.gate -> amp.in", "note.gait -> amp.in"))
    assert len(found) == 1 and found[0][0] == base + 7
    assert found[0][1].startswith("voices: connection 'note.gait -> amp.in': block 'note' (midi_note) has no "
                                  "output 'gait' (did you mean 'gate'?)")


def test_section_problems(write_patch):
    base = HEAD.count("\n")
    assert _problems(write_patch, HEAD + VOICES.replace("count: 3", "count: 0")) == [
        (base + 2, "voices.count: 0 is below the minimum 1")]
    found = _problems(write_patch, HEAD + VOICES.replace("- level.out -> amp.gain", "- level.out -> out.ch0"))
    assert found == [(base + 8, "voices: connection 'level.out -> out.ch0' joins no block of the voice; "
                                "it belongs under connect:")]
    found = _problems(write_patch, HEAD.replace("level:", "v2_amp:") + VOICES.replace("level.out", "v2_amp.out"))
    assert any("would be named 'v2_amp', a block of the patch" in m for _, m in found)


def test_voice_beyond_the_group(write_patch):
    found = _problems(write_patch, HEAD.replace("out: {", "n: {type: midi_note, device: keys, voice: 3, voices: 2}\n  out: {"))
    assert found == [(HEAD.count("\n") - 1, "block 'n' (midi_note): parameter 'voice': voice 3 of a group of 2: "
                                            "voices are numbered 1 … 2")]


def test_schema_offers_the_section():
    from hapticgraph.graph.registry import Registry
    from hapticgraph.graph.schema import patch_schema
    section = patch_schema(Registry())["properties"]["voices"]
    assert section["required"] == ["count", "blocks"] and "$ref" not in str(section["properties"]["count"])


def test_unreadable_template_connection_and_copy_budget(write_patch):
    base = HEAD.count("\n")
    found = _problems(write_patch, HEAD + VOICES.replace("- note.gate -> amp.in", "- note.gate amp.in"))
    assert found == [(base + 7, "cannot read 'note.gate amp.in': write \"block.port -> block.port\"")]
    big = VOICES.replace("count: 3", "count: 128") + "".join("    - level.out -> amp.gain\n" for _ in range(200))
    found = _problems(write_patch, HEAD + big)
    assert len(found) == 1 and "at most 20,000" in found[0][1] and found[0][0] == base + 2
