"""The extension module a kernel is built into ahead of time (graph/aot.py) is verified like every
other file of its cache entry: random bytes in it, an edited aot.json or a missing module and the
entry is rebuilt, never loaded; a planted module is refused. numba's C runtime objects (built once
in the shared cache) are verified before every link. Without a C compiler the kernel is numba's,
and the run goes on."""
import json
import random
import shutil

import pytest
from hostile_env import STRING, run_hg

TIMEOUT = 300           # a first build also compiles numba's C runtime


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A kernel cache folder holding the patch's kernel built ahead of time (cold, then warm) and a
    shared one holding numba's C runtime: each test attacks a copy, so the runtime is compiled once
    for the module."""
    folder = tmp_path_factory.mktemp("built")
    env = _setup(folder)
    assert "compiling kernel for 4 blocks" in _run(folder, env)
    assert "compiling" not in _run(folder, env)
    entry = _entry(folder)
    assert not (entry / "__pycache__").exists()
    _module(entry)
    assert not list((folder / "cache").glob("aot_runtime_*")) and list((folder / "shared").glob("aot_runtime_*"))
    return folder


def _setup(tmp_path, **env):
    (tmp_path / "p.yaml").write_text(STRING)
    return {"HAPTICGRAPH_CACHE": str(tmp_path / "cache"), "HAPTICGRAPH_SHARED_CACHE": str(tmp_path / "shared"),
            "HAPTICGRAPH_AOT": "1", **env}


def _run(tmp_path, env):
    proc = run_hg("run", "p.yaml", "--seconds", "0.01", "--out", "o.wav", cwd=tmp_path, env=env, timeout=TIMEOUT)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, (proc.returncode, proc.stderr)
    return proc.stderr


def _entry(tmp_path):
    entries = [p for p in (tmp_path / "cache").iterdir() if p.name.startswith("kernel_")]
    assert len(entries) == 1, entries
    return entries[0]


def _module(entry):
    found = list(entry.glob("hapticgraph_aot*"))
    assert len(found) == 1, list(entry.iterdir())
    return found[0]


def _native_entry(tmp_path, built):
    """A copy of the built cache in tmp_path: (env, its entry, the entry's extension module)."""
    env = _setup(tmp_path)
    for folder in ("cache", "shared"):
        shutil.copytree(built / folder, tmp_path / folder)
    assert "compiling" not in _run(tmp_path, env)
    entry = _entry(tmp_path)
    return env, entry, _module(entry)


def _assert_rebuilt(tmp_path, env):
    """The first run after the damage compiles, the second loads the rebuilt module."""
    assert "compiling kernel for 4 blocks" in _run(tmp_path, env)
    assert "compiling" not in _run(tmp_path, env)
    _module(_entry(tmp_path))


def test_random_bytes_in_the_extension_module_are_rebuilt_not_run(tmp_path, built):
    env, _, module = _native_entry(tmp_path, built)
    data = bytearray(module.read_bytes())
    rng = random.Random(1)
    for k in range(len(data) // 3, len(data) // 3 + 4096):
        data[k] = rng.randrange(256)
    module.write_bytes(bytes(data))
    _assert_rebuilt(tmp_path, env)


def test_edited_types_and_a_missing_module_are_rebuilt(tmp_path, built):
    env, entry, module = _native_entry(tmp_path, built)
    spec = json.loads((entry / "aot.json").read_text())
    spec["args"][2][1] = 2                  # `state` as two-dimensional: the manifest says otherwise
    (entry / "aot.json").write_text(json.dumps(spec))
    _assert_rebuilt(tmp_path, env)
    _module(_entry(tmp_path)).unlink()
    _assert_rebuilt(tmp_path, env)


def test_a_module_planted_beside_a_numba_entry_is_refused(tmp_path, built):
    env, entry, module = _native_entry(tmp_path, built)
    planted = tmp_path / "planted"
    shutil.copytree(entry, planted)
    shutil.rmtree(entry)
    _run(tmp_path, {**env, "HAPTICGRAPH_AOT": "0"})          # numba's cache files only
    entry = _entry(tmp_path)
    assert (entry / "__pycache__").is_dir() and not list(entry.glob("hapticgraph_aot*"))
    for name in (module.name, "aot.json"):                   # not in the entry's manifest
        shutil.copy(planted / name, entry / name)
    _assert_rebuilt(tmp_path, env)


def test_a_tampered_runtime_object_is_rebuilt_not_linked(tmp_path, built):
    env, _, _ = _native_entry(tmp_path, built)
    runtime = next((tmp_path / "shared").glob("aot_runtime_*"))
    obj = sorted(runtime.glob("*.o"))[0]
    obj.write_bytes(obj.read_bytes()[:1000])
    shutil.rmtree(_entry(tmp_path))
    err = _run(tmp_path, env)
    assert "compiling kernel for 4 blocks" in err and "runtime" in err
    assert "compiling" not in _run(tmp_path, env)
    _module(_entry(tmp_path))


def test_no_c_compiler_means_numba_and_the_run_goes_on(tmp_path):
    env = _setup(tmp_path, CC=str(tmp_path / "no-such-cc"), CXX=str(tmp_path / "no-such-cxx"))
    err = _run(tmp_path, env)
    assert "compiling kernel for 4 blocks" in err and "numba loads them" in err and "warning" not in err
    entry = _entry(tmp_path)
    assert (entry / "__pycache__").is_dir() and not list(entry.glob("hapticgraph_aot*"))
    for folder in ("cache", "shared"):
        assert not list((tmp_path / folder).glob("aot_runtime_*")) and not list((tmp_path / folder).glob(".*"))
    assert "compiling" not in _run(tmp_path, env)
    assert (tmp_path / "o.wav").stat().st_size > 1000
