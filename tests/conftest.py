"""Shared fixtures: one kernel cache and one shared cache per test session (never the user's),
patch writers."""
import os
import textwrap

import pytest

from project_env import EDITABLE_STRING, PATCHES, ROOT, single_block_patch  # noqa: F401 - shared with the tests


@pytest.fixture(scope="session", autouse=True)
def _kernel_cache(tmp_path_factory):
    if "HAPTICGRAPH_CACHE" not in os.environ:
        os.environ["HAPTICGRAPH_CACHE"] = str(tmp_path_factory.mktemp("kernels"))
    if "HAPTICGRAPH_SHARED_CACHE" not in os.environ:      # numba's runtime, the helpers' machine code
        os.environ["HAPTICGRAPH_SHARED_CACHE"] = str(tmp_path_factory.mktemp("shared"))
    # kernels compiled by numba's JIT, as before: building extension modules (graph/aot.py) costs
    # a link per kernel (numba's C runtime once, in the shared cache), and many tests start with an
    # empty kernel cache; tests/graph/test_aot.py and tests/hostile/test_kernel_native.py turn it on
    os.environ.setdefault("HAPTICGRAPH_AOT", "0")
    yield


@pytest.fixture
def write_patch(tmp_path):
    """write_patch(text, name="p.yaml") -> path of a patch file (text is dedented)."""
    def write(text, name="p.yaml"):
        path = tmp_path / name
        path.write_text(textwrap.dedent(text).lstrip("\n"), encoding="utf-8")
        return path
    return write


@pytest.fixture
def patches_dir():
    return ROOT / "patches"




@pytest.fixture
def string_session(write_patch):
    """string_session(blocksize, editable=True) -> a Session of EDITABLE_STRING."""
    from hapticgraph import load
    from hapticgraph.devices import open_drivers
    from hapticgraph.graph.engine import Runner

    def make(blocksize, editable=True):
        patch = load(write_patch(EDITABLE_STRING))
        return Runner(patch, drivers=open_drivers(patch), blocksize=blocksize, editable=editable)
    return make


@pytest.fixture
def hg():
    """`hapticgraph ARGS` in a child process under a memory and time limit (tests/hostile)."""
    from hostile_env import run_hg
    return run_hg
