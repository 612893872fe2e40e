"""Both plugin routes: a `.py` file named in a patch's `plugins:`, and an installed package's
entry point in the `hapticgraph.blocks` group. A plugin block compiles like a built-in one."""
import math
import shutil
import threading

import numpy as np

from project_env import ROOT
from hapticgraph import render
from hapticgraph.graph.kernel import CompiledKernel
from hapticgraph.graph.patch import load
from hapticgraph.graph.program import Program
from hapticgraph.graph.registry import Registry, block_types_in, import_file

EXAMPLES = ROOT / "examples"


def test_file_plugin_relative_to_patch(tmp_path):
    folder = tmp_path / "instrument"
    shutil.copytree(EXAMPLES / "file_plugin", folder)
    patch = load(folder / "saturated_string.yaml")
    assert patch.registry.origin["cubic"] == "plugin 'cubic.py'"
    a = render(patch, 0.05, probes=["shape.out", "damp.out"])
    b = render(load(folder / "saturated_string.yaml"), 0.05, probes=["shape.out", "damp.out"], engine="python")
    np.testing.assert_allclose(a.probes["shape.out"], b.probes["shape.out"], atol=1e-12)
    x = a.probes["damp.out"]
    np.testing.assert_allclose(a.probes["shape.out"], x - 0.2 * x ** 3, atol=1e-15)
    # the plugin's function is called from the generated kernel exactly like a built-in's
    kernel = CompiledKernel(Program(patch))
    assert "cubic_output(" in kernel.source and "hapticgraph_plugin_cubic_" in kernel.source


def test_entry_point_plugin(tmp_path, monkeypatch):
    """An installed distribution advertising the entry point (a dist-info on sys.path)."""
    site = tmp_path / "site"
    shutil.copytree(EXAMPLES / "hapticgraph-example-plugin" / "hg_example_plugin", site / "hg_example_plugin")
    info = site / "hapticgraph_example_plugin-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: hapticgraph-example-plugin\nVersion: 0.1.0\n")
    (info / "entry_points.txt").write_text("[hapticgraph.blocks]\nexample = hg_example_plugin\n")
    monkeypatch.syspath_prepend(str(site))
    registry = Registry()
    assert "soft_clip" in registry.types
    assert registry.origin["soft_clip"].startswith("entry point example")
    patch_file = tmp_path / "p.yaml"
    patch_file.write_text(
        "hapticgraph: 1\nblocks:\n  w: {type: wavetable, amplitude: 3.0}\n  c: {type: soft_clip, limit: 0.5}\n"
        "connect: [w.out -> c.in]\n")
    r = render(load(patch_file, registry=registry), 0.01, probes=["w.out", "c.out"])
    np.testing.assert_allclose(r.probes["c.out"], 0.5 * np.tanh(r.probes["w.out"] / 0.5), atol=1e-15)


def test_plugin_cannot_shadow_a_builtin(tmp_path, capsys):
    from hapticgraph.cli import main
    (tmp_path / "shadow.py").write_text(
        "from hapticgraph.blocks import Block, Out\n\nclass Gain(Block, name='gain'):\n"
        "    '''out = 1.'''\n    y = Out(name='out')\n\n    @staticmethod\n    def output():\n        return 1.0\n")
    (tmp_path / "p.yaml").write_text("hapticgraph: 1\nplugins:\n  - shadow.py\nblocks: {}\n")
    assert main(["check", str(tmp_path / "p.yaml")]) == 2
    assert "p.yaml:3: block type 'gain' from plugin 'shadow.py' is already defined by built-in" in capsys.readouterr().err


def test_broken_plugin_file_is_a_patch_error(tmp_path, capsys):
    from hapticgraph.cli import main
    (tmp_path / "broken.py").write_text("import math\nraise RuntimeError('oops')\n")
    (tmp_path / "p.yaml").write_text("hapticgraph: 1\nplugins: [broken.py]\nblocks: {}\n")
    assert main(["check", str(tmp_path / "p.yaml")]) == 2
    err = capsys.readouterr().err
    assert "p.yaml:2: plugin file 'broken.py' failed to import (broken.py:2): RuntimeError: oops" in err
    assert "Traceback" not in err
    assert math.isfinite(1.0)


LEVEL = '''from hapticgraph.blocks import Block, Out


class Level(Block, name="level_test"):
    """out = {value}."""
    y = Out(name="out")

    @staticmethod
    def output():
        return {value}
'''


def test_edited_plugin_is_reloaded_in_the_same_process(tmp_path):
    """`play --watch` loads the patch again in the same process: an edited plugin file is imported
    again and its kernel is a new one (the cache key holds the plugin's content)."""
    (tmp_path / "p.yaml").write_text("hapticgraph: 1\nplugins: [level.py]\nblocks:\n  l: {type: level_test}\n")
    seen, keys = [], []
    for value in ("0.25", "0.75"):
        (tmp_path / "level.py").write_text(LEVEL.format(value=value))
        patch = load(tmp_path / "p.yaml")
        assert str((tmp_path / "level.py").resolve()) in patch.registry.plugin_files
        kernel = CompiledKernel(Program(patch, probes=["l.out"]))
        rec = np.zeros((3, 1))
        kernel.run(0, rec, np.zeros((3, 0)))
        seen.append(rec[0, 0])
        keys.append(kernel.key)
    assert seen == [0.25, 0.75] and keys[0] != keys[1]


def test_entry_point_that_exits_is_a_warning_not_an_exit(tmp_path, monkeypatch, capsys):
    site = tmp_path / "site"
    (site / "leaver_pkg").mkdir(parents=True)
    (site / "leaver_pkg" / "__init__.py").write_text("import sys\nsys.exit(0)\n")
    info = site / "leaver-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: leaver\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[hapticgraph.blocks]\nleaver = leaver_pkg\n")
    monkeypatch.syspath_prepend(str(site))
    registry = Registry()
    assert "gain" in registry.types
    assert "plugin entry point 'leaver' failed to load: SystemExit: 0" in capsys.readouterr().err


SLOW_PLUGIN = """
import time

from hapticgraph.blocks import Block, In, Out

time.sleep(0.3)          # a plugin that takes a while to import


class Slow(Block, name="slow_gain"):
    x = In(name="in")
    y = Out(name="out")

    @staticmethod
    def output(x):
        return x
"""


def test_two_threads_importing_one_plugin_both_get_its_types(tmp_path):
    """A Dask worker of two threads loads the same patch twice at once: neither thread may take the
    module while the other is still running its file (it had no block types yet)."""
    path = tmp_path / "slow.py"
    path.write_text(SLOW_PLUGIN)
    found, start = [], threading.Barrier(2)

    def load_it():
        start.wait()
        found.append([cls.type_name for cls in block_types_in(import_file(str(path)))])
    threads = [threading.Thread(target=load_it) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert found == [["slow_gain"], ["slow_gain"]]
