"""Shared by tests/hostile/: hostile-input tests: every attack runs in a child process under a memory and time limit, so a
regression fails its test instead of taking the machine down."""
import os
import resource
import subprocess
import sys

MEMORY_LIMIT_MB = 1536      # address space of the child; numba and LLVM fit in under 1 GB
TIME_LIMIT_S = 60


def _limits(memory_mb):
    def apply():
        limit = memory_mb << 20
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    return apply


def run_hg(*args, cwd=None, env=None, memory_mb=MEMORY_LIMIT_MB, timeout=TIME_LIMIT_S, input=None):
    """`hapticgraph ARGS` in a child process under the limits; a CompletedProcess (text)."""
    full_env = dict(os.environ)
    full_env.update(env or {})
    return subprocess.run([sys.executable, "-m", "hapticgraph", *map(str, args)], cwd=cwd, env=full_env,
                          capture_output=True, text=True, timeout=timeout, input=input,
                          preexec_fn=_limits(memory_mb))


def run_py(code, cwd=None, env=None, memory_mb=MEMORY_LIMIT_MB, timeout=TIME_LIMIT_S):
    """A Python snippet in a child process under the limits; a CompletedProcess (text)."""
    full_env = dict(os.environ)
    full_env.update(env or {})
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, env=full_env, capture_output=True,
                          text=True, timeout=timeout, preexec_fn=_limits(memory_mb))


def assert_patch_error(proc, fragment=None):
    """Exit 2, `FILE:LINE: message` lines (or `hapticgraph: error:`), no traceback."""
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr, proc.stderr
    if fragment is not None:
        assert fragment in proc.stderr, proc.stderr


# A small patch whose kernel the cache tests build, tamper with and load again: a plucked delay loop.
STRING = """hapticgraph: 1
blocks:
  pick: {type: pluck, time: 0.0, force: 1.0, duration: 0.0005}
  loop: {type: delay, length: 99}
  mic:  {type: mic, gain: 0.5}
  out:  {type: audio_out, channels: 2}
connect:
  - pick.out -> loop.in
  - loop.out -> mic.in
  - mic.left -> out.left
  - mic.right -> out.right
"""
