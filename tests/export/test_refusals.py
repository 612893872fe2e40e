"""Every shipped patch exports; what cannot be lowered to C is refused, never a crash: exit status
2 and one `FILE:LINE: message` per problem naming the block and why — at the Python line of a
block function the translator does not read, at the patch's line of a block whose meaning has no
source to read."""
import pytest

from hapticgraph.cli.main import main
from project_env import ROOT

PATCHES = sorted((ROOT / "patches").glob("*.yaml"))


@pytest.mark.parametrize("path", PATCHES, ids=[p.stem for p in PATCHES])
def test_every_shipped_patch_exports(path, tmp_path, capsys):
    code = main(["export", str(path), "--to", "c", "--out", str(tmp_path)])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"{path.stem}.c", f"{path.stem}.h"]
    assert out.split() == [str(tmp_path / f"{path.stem}.h"), str(tmp_path / f"{path.stem}.c")]


PLUGIN = '''\
from hapticgraph.blocks import Block, In, Out, Param

_space = {}
exec("def twice(x):\\n    return 2.0 * x\\n", _space)      # a function made from text nothing keeps
twice = _space["twice"]


class Twice(Block, name="twice"):
    """out = 2·in, by a function made from text."""
    x = In(name="in")
    y = Out(name="out")

    @staticmethod
    def output(x):
        return twice(x)


class Shout(Block, name="shout"):
    """out = in, printed."""
    x = In(name="in")
    y = Out(name="out")

    @staticmethod
    def output(x):
        try:
            return x
        except ValueError:
            return 0.0


class Follow(Block, name="follow"):
    """out = in · g, g = 2·gain derived."""
    x = In(name="in")
    y = Out(name="out")
    gain = Param(1.0)

    @staticmethod
    def derive(p, fs):
        return {"g": 2.0 * p.gain}

    @staticmethod
    def output(x, g):
        return x * g
'''


def _plugin_patch(tmp_path, block):
    (tmp_path / "blocks_x.py").write_text(PLUGIN, encoding="utf-8")
    wiring = {"shout": "  - src.out -> b.in\n", "twice": "  - src.out -> b.in\n",
              "follow": "  - src.out -> b.in\n  - src.out -> b.gain\n"}[block]
    patch = tmp_path / "p.yaml"
    patch.write_text(f"hapticgraph: 1\nplugins: [blocks_x.py]\nblocks:\n  src: {{type: constant, value: 1.0}}\n"
                     f"  b: {{type: {block}}}\n  out: {{type: audio_out, channels: 1}}\nconnect:\n{wiring}"
                     "  - b.out -> out.ch0\n", encoding="utf-8")
    return patch


def test_a_construct_outside_the_subset_is_refused_at_the_block_functions_line(tmp_path, capsys):
    patch = _plugin_patch(tmp_path, "shout")
    assert main(["export", str(patch), "--to", "c", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    line = PLUGIN.splitlines().index("        try:") + 1
    assert err.strip() == (f"{tmp_path / 'blocks_x.py'}:{line}: block 'b' (shout) cannot be exported to C: "
                           "the statement Try (try:)")


def test_a_function_made_from_text_not_kept_is_refused_at_the_patch_line(tmp_path, capsys):
    patch = _plugin_patch(tmp_path, "twice")
    assert main(["export", str(patch), "--to", "c", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.strip() == (f"{patch}:5: block 'b' (twice) cannot be exported to C: twice is made at run time "
                           "from text that is not kept (linecache): there is no source to translate (<string>)")
    assert not (tmp_path / "out").exists()


def test_a_derive_driven_every_sample_is_refused_at_the_patch_line(tmp_path, capsys):
    patch = _plugin_patch(tmp_path, "follow")
    assert main(["export", str(patch), "--to", "c", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.strip() == (f"{patch}:5: block 'b' (follow) cannot be exported: a connection drives gain, which "
                           "its derive reads every sample (not lowered yet)")


def test_wasm_without_its_toolchain_is_one_line_and_exit_1(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("WASM_CC", "no-such-clang-hg")
    assert main(["export", str(PATCHES[0]), "--to", "wasm", "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert err.startswith("hapticgraph: error: no WebAssembly toolchain: no-such-clang-hg not on PATH"), err
    assert not list(tmp_path.glob("*.wasm"))
