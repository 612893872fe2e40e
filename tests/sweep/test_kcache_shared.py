"""A kernel cache folder shared by workers (a shared file system): two processes compiling the
same kernel into it at once both succeed, leave one verified entry and no temporary folder, and a
third process loads that entry without compiling (graph/kcache: entries written into a fresh
folder and renamed into place, used only when every file matches their manifest)."""
import os
import subprocess
import sys

import numpy as np
import soundfile

from hapticgraph.graph import kcache
from sweeps_env import karplus, write


def _run(patch, out, cache):
    env = dict(os.environ, HAPTICGRAPH_CACHE=str(cache), HAPTICGRAPH_AOT="0")
    return subprocess.Popen([sys.executable, "-m", "hapticgraph", "run", str(patch), "--seconds", "0.1", "--out", str(out)],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_two_writers_of_one_kernel_into_a_shared_cache(tmp_path):
    text = karplus(tmp_path).read_text().replace("[0.25, 0.5, 0.25]", "[0.125, 0.375, 0.375, 0.125]")
    patch = write(tmp_path, "ks_shared.yaml", text)
    cache = tmp_path / "shared_cache"
    procs = [_run(patch, tmp_path / f"w{i}.wav", cache) for i in range(2)]
    try:
        results = [p.communicate(timeout=600) for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait(timeout=30)
    assert [p.returncode for p in procs] == [0, 0], results
    a, _ = soundfile.read(tmp_path / "w0.wav")
    b, _ = soundfile.read(tmp_path / "w1.wav")
    assert np.array_equal(a, b)
    entries = [n for n in os.listdir(cache) if n.startswith("kernel_")]
    assert len(entries) == 1 and not [n for n in os.listdir(cache) if n.startswith(".kernel_")]
    assert kcache.verified_files(str(cache / entries[0]), entries[0][len("kernel_"):])
    third = _run(patch, tmp_path / "w2.wav", cache)
    _, err = third.communicate(timeout=600)
    assert third.returncode == 0 and "compiling" not in err
