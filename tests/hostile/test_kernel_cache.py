"""Issue 10.3: the kernel cache is verified, never trusted. A planted, edited, truncated or random
file in the cache is detected by the hashes written with the entry and the entry is rebuilt:
never run, never a crash. An unwritable cache folder means compiling in memory, one warning."""
import os
import random
import shutil

from hostile_env import STRING, run_hg


def _setup(tmp_path, text=STRING):
    """numba's own cache files (the kernel built by numba's JIT): tests/hostile/test_kernel_native.py
    attacks the extension module built ahead of time."""
    (tmp_path / "p.yaml").write_text(text)
    return {"HAPTICGRAPH_CACHE": str(tmp_path / "cache"), "HAPTICGRAPH_AOT": "0"}


def _run(tmp_path, env, *extra):
    return run_hg("run", "p.yaml", "--seconds", "0.01", "--out", "o.wav", *extra, cwd=tmp_path, env=env)


def _entry(tmp_path):
    entries = [p for p in (tmp_path / "cache").iterdir() if p.name.startswith("kernel_")]
    assert len(entries) == 1, entries
    return entries[0]


def _assert_rebuilt(tmp_path, env):
    """Two runs after the damage: the first rebuilds (says it compiles), the second is a hit."""
    first = _run(tmp_path, env)
    assert first.returncode == 0, (first.returncode, first.stderr)
    assert "compiling kernel for 4 blocks" in first.stderr
    assert "Traceback" not in first.stderr
    second = _run(tmp_path, env)
    assert second.returncode == 0, (second.returncode, second.stderr)
    assert "compiling" not in second.stderr


def test_random_bytes_in_numba_cache_file_rebuild_not_segfault(tmp_path):
    env = _setup(tmp_path)
    cold = _run(tmp_path, env)
    assert cold.returncode == 0 and "compiling kernel for 4 blocks" in cold.stderr, cold.stderr
    warm = _run(tmp_path, env)
    assert warm.returncode == 0 and "compiling" not in warm.stderr, warm.stderr
    nbc = next(_entry(tmp_path).glob("__pycache__/*.nbc"))
    data = bytearray(nbc.read_bytes())
    start = data.index(b"\x7fELF")           # the machine code inside numba's pickle
    rng = random.Random(1)
    for k in range(start + 64, min(len(data), start + 4096)):
        data[k] = rng.randrange(256)
    nbc.write_bytes(bytes(data))             # this killed every later run with SIGSEGV
    _assert_rebuilt(tmp_path, env)


def test_random_numba_index_and_truncated_kernel_are_rebuilt(tmp_path):
    env = _setup(tmp_path)
    assert _run(tmp_path, env).returncode == 0
    entry = _entry(tmp_path)
    nbi = next(entry.glob("__pycache__/*.nbi"))
    nbi.write_bytes(os.urandom(nbi.stat().st_size))   # numba unpickles this file
    _assert_rebuilt(tmp_path, env)
    kernel = entry / "kernel.py"
    kernel.write_text(kernel.read_text()[:200])
    _assert_rebuilt(tmp_path, env)


def test_planted_kernel_file_never_runs(tmp_path):
    env = _setup(tmp_path)
    assert _run(tmp_path, env).returncode == 0
    entry = _entry(tmp_path)
    evil = "import pathlib; pathlib.Path('PWNED').touch()\n"
    # a kernel with the matching name, its manifest left as it was: the content differs
    (entry / "kernel.py").write_text(evil + (entry / "kernel.py").read_text())
    _assert_rebuilt(tmp_path, env)
    assert not (tmp_path / "PWNED").exists()
    # a planted entry with a self-consistent manifest: kernel.py is not the source we generate
    shutil.rmtree(entry)
    entry.mkdir()
    (entry / "kernel.py").write_text(evil + "def kernel(*a):\n    return 0\n")
    import hashlib
    import json
    digest = hashlib.sha256((entry / "kernel.py").read_bytes()).hexdigest()
    (entry / "manifest.json").write_text(json.dumps({"key": entry.name[len("kernel_"):],
                                                     "files": {"kernel.py": digest}}))
    _assert_rebuilt(tmp_path, env)
    assert not (tmp_path / "PWNED").exists()
    # an extra file numba would read (a stray index) is refused too
    (entry / "__pycache__" / "kernel.kernel-99.py311.nbi").write_bytes(b"\x80\x04junk")
    _assert_rebuilt(tmp_path, env)


def test_unwritable_cache_compiles_in_memory_with_one_warning(tmp_path):
    (tmp_path / "p.yaml").write_text(STRING)
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    for cache in (blocker, blocker / "below"):
        proc = _run(tmp_path, {"HAPTICGRAPH_CACHE": str(cache)})
        assert proc.returncode == 0, proc.stderr
        warnings = [ln for ln in proc.stderr.splitlines() if "warning" in ln]
        assert len(warnings) == 1 and "compiling in memory" in warnings[0], proc.stderr
        assert (tmp_path / "o.wav").stat().st_size > 1000
        assert blocker.read_text() == "not a folder"


def test_edited_plugin_is_never_served_stale(tmp_path):
    plugin = """from hapticgraph.blocks import Block, Out


class Level(Block, name="level"):
    '''out = {value}.'''
    y = Out(name="out")

    @staticmethod
    def output():
        return {value}
"""
    (tmp_path / "level.py").write_text(plugin.format(value="0.25"))
    env = _setup(tmp_path, "hapticgraph: 1\nplugins: [level.py]\nblocks:\n  l: {type: level}\n"
                           "  g: {type: gain, gain: 1.0}\nconnect: [l.out -> g.in]\n")
    first = run_hg("run", "p.yaml", "--seconds", "0.001", "--probe", "g.out", "--probes", "a.npz", "--quiet",
                   cwd=tmp_path, env=env)
    assert first.returncode == 0, first.stderr
    (tmp_path / "level.py").write_text(plugin.format(value="0.75"))
    second = run_hg("run", "p.yaml", "--seconds", "0.001", "--probe", "g.out", "--probes", "b.npz", "--quiet",
                    cwd=tmp_path, env=env)
    assert second.returncode == 0, second.stderr
    import numpy as np
    assert np.all(np.load(tmp_path / "a.npz")["g.out"] == 0.25)
    assert np.all(np.load(tmp_path / "b.npz")["g.out"] == 0.75)


def test_edited_helper_module_of_a_plugin_is_never_served_stale(tmp_path):
    """The plugin's own file is unchanged; the @helper it calls, in another module, is edited."""
    pkg = tmp_path / "site" / "hgpkg"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "blocks.py").write_text(
        "from hapticgraph.blocks import Block, Out\nfrom . import dsp\n\n\n"
        "class Level(Block, name='level'):\n    '''out = dsp.level().'''\n    y = Out(name='out')\n\n"
        "    @staticmethod\n    def output():\n        return dsp.level()\n")
    helper = "from hapticgraph.blocks import helper\n\n\n@helper\ndef level():\n    return {value}\n"
    (pkg / "dsp.py").write_text(helper.format(value="0.25"))
    env = _setup(tmp_path, "hapticgraph: 1\nplugins: [hgpkg.blocks]\nblocks:\n  l: {type: level}\n"
                           "  g: {type: gain, gain: 1.0}\nconnect: [l.out -> g.in]\n")
    env["PYTHONPATH"] = str(tmp_path / "site")
    values = []
    for value, out in (("0.25", "a.npz"), ("0.75", "b.npz")):
        (pkg / "dsp.py").write_text(helper.format(value=value))
        proc = run_hg("run", "p.yaml", "--seconds", "0.001", "--probe", "g.out", "--probes", out, "--quiet",
                      cwd=tmp_path, env=env)
        assert proc.returncode == 0, proc.stderr
        import numpy as np
        values.append(float(np.load(tmp_path / out)["g.out"][0]))
    assert values == [0.25, 0.75]
