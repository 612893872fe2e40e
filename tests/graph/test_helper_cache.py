"""The built-in helpers' machine code, built once per installation in the shared cache folder
(graph/helper_cache.py): a kernel compiled into another kernel cache folder loads the stencil
instead of compiling it again; the entry is verified like a kernel's, so a damaged file costs a
compile, never a crash; the numbers are the same."""
import os
import random
import subprocess
import sys

import numpy as np
import soundfile

from project_env import ROOT
from hapticgraph.graph.kcache import verified_files

PATCH = """\
hapticgraph: 1
rate: 44100
blocks:
  s:    {type: lattice, shape: [6, 5], mass: 0.001, tension: 100000.0, damping: 0.0001}
  pick: {type: pluck, time: 0.0, force: 1.0, duration: 0.001}
  out:  {type: audio_out, channels: 1}
connect:
  - pick.out -> s[2, 2].force
  - s[3, 3].position -> out.ch0
"""


def _run(tmp_path, cache, wav):
    """A cold compile (a new kernel cache folder) with numba telling what it does with its cache."""
    env = {**os.environ, "HAPTICGRAPH_CACHE": str(tmp_path / cache), "HAPTICGRAPH_SHARED_CACHE": str(tmp_path / "shared"),
           "HAPTICGRAPH_AOT": "0", "NUMBA_DEBUG_CACHE": "1"}
    proc = subprocess.run([sys.executable, "-m", "hapticgraph", "run", "p.yaml", "--seconds", "0.01", "--out", wav],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr
    return proc.stdout, soundfile.read(tmp_path / wav)[0]


def _entry(tmp_path):
    found = list((tmp_path / "shared").glob("numba_helpers_*"))
    assert len(found) == 1, found
    return found[0]


def _stencil_events(stdout, what):
    return [ln for ln in stdout.splitlines() if what in ln and "stencils" in ln]


def test_a_second_kernel_cache_loads_the_helpers_compiled_once(tmp_path):
    (tmp_path / "p.yaml").write_text(PATCH)
    first, audio = _run(tmp_path, "cache1", "a.wav")
    entry = _entry(tmp_path)
    assert _stencil_events(first, "data saved") and verified_files(str(entry), entry.name.split("_")[-1])
    assert not [p for p in (tmp_path / "cache1").iterdir() if p.name.startswith("numba_helpers")]
    second, again = _run(tmp_path, "cache2", "b.wav")
    assert _stencil_events(second, "data loaded") and not _stencil_events(second, "data saved")
    assert np.array_equal(audio, again) and np.any(audio != 0)


def test_a_damaged_helper_entry_is_compiled_again_not_loaded(tmp_path):
    (tmp_path / "p.yaml").write_text(PATCH)
    _, audio = _run(tmp_path, "cache1", "a.wav")
    nbc = sorted(_entry(tmp_path).rglob("*.nbc"))[0]
    data = bytearray(nbc.read_bytes())
    rng = random.Random(2)
    for k in range(len(data) // 2, min(len(data), len(data) // 2 + 2048)):
        data[k] = rng.randrange(256)
    nbc.write_bytes(bytes(data))
    out, again = _run(tmp_path, "cache2", "b.wav")
    # compiled again and saved; a helper called from two places (stencils.row_width) is loaded
    # back in the same run, but only after this run saved it: nothing of the damaged entry
    assert _stencil_events(out, "data saved")
    for line in _stencil_events(out, "data loaded"):
        path = line.split("data loaded from ")[1]
        saved = f"data saved to {path}"
        assert saved in out and out.index(saved) < out.index(line), line
    assert np.array_equal(audio, again)
    entry = _entry(tmp_path)
    assert verified_files(str(entry), entry.name.split("_")[-1])
    planted = entry / "hapticgraph.blocks.massspring.stencils" / "planted.nbi"     # a file of no manifest
    planted.write_bytes(b"\x80\x04N.")
    out, _ = _run(tmp_path, "cache3", "c.wav")
    assert _stencil_events(out, "data saved") and not planted.exists()


def test_only_hapticgraph_s_own_helpers_are_kept(tmp_path):
    """A plugin's @helper (examples/law_plugin) is compiled with each kernel, cached nowhere; no
    cache file is written beside hapticgraph's sources."""
    for name in ("tanh_spring.py", "saturating_spring.yaml"):
        (tmp_path / name).write_text((ROOT / "examples" / "law_plugin" / name).read_text())
    (tmp_path / "p.yaml").write_text((tmp_path / "saturating_spring.yaml").read_text()
                                     + "  - bob.position -> out.ch0\n"
                                     + "  - hit.out -> s2[1, 1].force\n  - s2[2, 2].position -> out.ch0\n")
    text = (tmp_path / "p.yaml").read_text().replace(
        "connect:", "  out: {type: audio_out, channels: 1}\n"
        "  s2: {type: lattice, shape: [4, 4], mass: 0.001, tension: 1000.0}\nconnect:")
    (tmp_path / "p.yaml").write_text(text)
    out, _ = _run(tmp_path, "cache1", "a.wav")
    assert _stencil_events(out, "data saved")
    names = {p.name for p in _entry(tmp_path).iterdir()}
    assert "hapticgraph.blocks.massspring.stencils" in names
    assert all(n == "manifest.json" or n.startswith("hapticgraph.") for n in names)
    assert not [p for p in tmp_path.rglob("*.nb*") if "shared" not in p.parts and "cache1" not in p.parts]
    for folder in ("blocks", "graph", "devices"):
        assert not list((ROOT / folder).rglob("*.nbi"))
