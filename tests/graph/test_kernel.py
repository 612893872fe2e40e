"""The generated kernel: one readable module per patch, cached under a hash, dumped on request."""
import os
import subprocess
import sys

import numpy as np

from hapticgraph.graph.jit import JitBackend, KernelCode
from hapticgraph.graph.kernel import CompiledKernel, generate
from hapticgraph.graph.patch import load
from hapticgraph.graph.program import Program


def test_kernel_is_readable_and_cached(patches_dir, tmp_path, monkeypatch):
    monkeypatch.setenv("HAPTICGRAPH_CACHE", str(tmp_path / "cache"))
    prog = Program(load(patches_dir / "karplus_strong.yaml"))
    k1 = CompiledKernel(prog)
    assert os.path.dirname(os.path.dirname(k1.path)) == str(tmp_path / "cache")
    src = open(k1.path).read()
    # one sample loop; every output then every update in schedule order; numbers are data: the
    # taps an array argument, the delay's length a local loaded from coef
    assert src.count("for i in range(n):") == 1
    assert src.index("delay_output(") < src.index("lowpass_output(") < src.index("delay_update(")
    assert "0.25" not in src and "damp_coeffs" in src and "loop_n = int(coef[" in src and "t = t0 + i" in src
    assert "def kernel(n, t0, state, live, coef, rec, ext" in src and src == k1.source
    k2 = CompiledKernel(Program(load(patches_dir / "karplus_strong.yaml")))
    assert k2.path == k1.path
    # another length (the same ring capacity) is the same source; another wiring is another file
    same = CompiledKernel(Program(load(patches_dir / "karplus_strong.yaml", overrides=["loop.length=120"])))
    assert same.path == k1.path
    other = CompiledKernel(Program(load(patches_dir / "karplus_strong.yaml", overrides=["damp.gain=0.5"])))
    assert other.path == k1.path
    third = CompiledKernel(Program(load(patches_dir / "cymatic_string.yaml")))
    assert third.path != k1.path


def test_source_hash_covers_block_functions(patches_dir):
    prog = Program(load(patches_dir / "karplus_strong.yaml"))
    source, fns = generate(prog)
    names = {f.__qualname__ for f in fns}
    assert {"Delay.output", "Delay.update", "Lowpass.output", "Pluck.output"} <= names


def test_dump_prints_the_kernel_path(patches_dir, tmp_path):
    env = {**os.environ, "HAPTICGRAPH_DUMP": "1", "HAPTICGRAPH_CACHE": str(tmp_path / "c")}
    proc = subprocess.run([sys.executable, "-m", "hapticgraph", "run", str(patches_dir / "karplus_strong.yaml"),
                           "--seconds", "0.01", "--out", str(tmp_path / "o.wav"), "--quiet"],
                          capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "compiling" not in proc.stderr          # --quiet: no compile notice either
    line = [ln for ln in proc.stderr.splitlines() if "kernel for" in ln][0]
    path = line.split(" is ")[-1]
    assert path.startswith(str(tmp_path / "c")) and os.path.isfile(path)


def test_state_persists_across_chunks(patches_dir):
    """Rendering in chunks of any size gives the same samples as one long call."""
    patch = load(patches_dir / "karplus_strong.yaml")
    one = Program(patch)
    k = CompiledKernel(one)
    whole = np.zeros((3000, len(one.records)))
    k.run(0, whole, np.zeros((3000, 0)))
    two = Program(load(patches_dir / "karplus_strong.yaml"))
    k2 = CompiledKernel(two)
    parts = np.zeros_like(whole)
    start = 0
    for size in (1, 7, 64, 1000, 1928):
        k2.run(start, parts[start:start + size], np.zeros((size, 0)))
        start += size
    np.testing.assert_array_equal(whole, parts)


def test_live_parameter_change_without_recompiling(patches_dir):
    prog = Program(load(patches_dir / "karplus_strong.yaml"))
    k = CompiledKernel(prog)
    rec = np.zeros((100, len(prog.records)))
    k.run(0, rec, np.zeros((100, 0)))
    prog.set_param("mic", "gain", 0.0)
    k.run(100, rec, np.zeros((100, 0)))
    assert np.all(rec == 0.0)


PLUGIN = '''
import math
from hapticgraph.blocks import Block, Out, Param


class Chord(Block, name="chord_test"):
    """out = Σ gains[i] (gains from derive, scaled by the live level)."""
    y = Out(name="out")
    level = Param(1.0)

    @staticmethod
    def derive(p, fs):
        return {"gains": [p.level, 2.0 * p.level, 3.0 * p.level], "bias": 0.5 * p.level}

    @staticmethod
    def output(gains, bias):
        return gains[0] + gains[1] + gains[2] + bias
'''


def test_control_rate_rederive_updates_scalar_and_array_coefficients(tmp_path):
    (tmp_path / "chord.py").write_text(PLUGIN)
    (tmp_path / "p.yaml").write_text("hapticgraph: 1\nplugins: [chord.py]\nblocks:\n  c: {type: chord_test}\nconnect: []\n")
    for engine in ("compiled", "python"):
        from hapticgraph.graph.engine import make_engine
        prog = Program(load(tmp_path / "p.yaml"), probes=["c.out"])
        runner = make_engine(prog, engine)
        rec = np.zeros((4, 1))
        runner.run(0, rec, np.zeros((4, 0)))
        assert np.all(rec[:, 0] == 6.5)
        prog.set_param("c", "level", 2.0)      # derive reads a live parameter: coefficients re-derived
        runner.run(4, rec, np.zeros((4, 0)))
        assert np.all(rec[:, 0] == 13.0), engine


def _strings(node):
    """Every string a YAML document holds, keys included."""
    if isinstance(node, str):
        yield node
    elif isinstance(node, dict):
        for k, v in node.items():
            yield from _strings(k)
            yield from _strings(v)
    elif isinstance(node, (list, tuple)):
        for v in node:
            yield from _strings(v)


def test_generated_source_holds_no_patch_supplied_string(patches_dir, tmp_path):
    """Code lines hold no string of the patch (names, devices, choices, the file name) except
    block names reduced to the identifiers the kernel's locals are named after; comments hold
    names reduced to [A-Za-z0-9_] only."""
    import re
    import shutil
    import yaml
    text = (patches_dir / "fig8_pluck_damp.yaml").read_text()
    marked = text
    for name in ("finger", "tip", "pad", "string_x"):
        marked = re.sub(rf"\b{name}\b", f"zq{name}", marked)
    marked = re.sub(r"(?m)^name:.*$", "", marked).replace(
        "hapticgraph: 1", "hapticgraph: 1\nname: \"zq a patch's 'name'\\n#\"", 1)
    path = tmp_path / "zq fig8 (copy).yaml"
    path.write_text(marked)
    patch = load(path)
    from hapticgraph.devices import open_drivers
    first = sorted(patch.blocks)[0]
    prog = Program(patch, probes=[f"{first}.{patch.blocks[first].outputs[0].name}"], drivers=open_drivers(patch, {}))
    source, _ = generate(prog)
    code = "\n".join(line.split("#", 1)[0] for line in source.splitlines())
    comments = [line.split("#", 1)[1] for line in source.splitlines() if "#" in line]
    named = set(prog.names.known.values())
    assert [w for w in re.findall(r"\w*zq\w*", code) if w not in named] == []
    assert "zqfinger_pos" in code or "zqtip_y" in code      # a block's locals are named after it
    supplied = set(_strings(yaml.safe_load(marked))) | {path.name, patch.name}
    for s in supplied:
        if len(s) >= 3 and not re.fullmatch(r"[A-Za-z0-9_.]*", s):
            assert s not in source, s
    for s in supplied:                      # choices such as `exponential` reach no code line as text
        if len(s) >= 5 and re.fullmatch(r"[a-z_]+", s) and s not in ("fixed",):
            assert f"'{s}'" not in code and f'"{s}"' not in code, s
    assert [c for c in comments if not re.fullmatch(r"[ A-Za-z0-9_:;,.()>\-]*", c)] == []
    assert any("zqfinger" in c or "zqtip" in c for c in comments)
    shutil.rmtree(tmp_path, ignore_errors=True)


def test_kernel_imports_only_what_it_uses(patches_dir):
    """Every module and name the kernel imports is used in it (issue 12: no unused imports)."""
    import ast
    for name in ("karplus_strong.yaml", "cymatic_string.yaml", "string_drives_plate.yaml"):
        source, _ = generate(Program(load(patches_dir / name)))
        tree = ast.parse(source)
        imported = [a.asname or a.name for node in ast.walk(tree) if isinstance(node, (ast.Import, ast.ImportFrom))
                    for a in node.names]
        used = {node.id for node in ast.walk(tree) if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Load)}
        assert imported and [n for n in imported if n not in used] == [], name


def test_kernel_locals_are_named_after_the_patch(patches_dir):
    """Issue 12.6: the delay `loop` keeps its ring buffer in `loop_line` and its output in `loop_y`,
    the lowpass `damp` its live gain in `damp_gain`."""
    source, _ = generate(Program(load(patches_dir / "karplus_strong.yaml")))
    assert "def kernel(n, t0, state, live, coef, rec, ext, loop_line, damp_hist, damp_coeffs):" in source
    for name in ("loop_y = delay_output(loop_line,", "damp_gain = live[", "loop_y1 = state[", "pick_y + damp_y",
                 "loop_n = int(coef["):
        assert name in source, name


NAMES_ALIKE = """hapticgraph: 1
blocks:
  pick: {type: pluck, time: 0.0, force: 1.0, duration: 0.0005}
  t: {type: gain, gain: 0.5}
  b_t: {type: gain, gain: 0.25}
  math: {type: gain, gain: 2.0}
  mic: {type: mic, gain: 0.5}
  out: {type: audio_out, channels: 2}
connect:
  - pick.out -> t.in
  - t.out -> b_t.in
  - b_t.out -> math.in
  - math.out -> mic.in
  - mic.left -> out.left
  - mic.right -> out.right
"""


def test_blocks_whose_names_sanitize_alike_get_distinct_identifiers(tmp_path):
    """`t` is a kernel name, so its locals are prefixed (b_t); the block named `b_t` then gets
    b_t_2; both engines agree sample for sample."""
    from hapticgraph.graph.interpreter import Interpreter
    (tmp_path / "p.yaml").write_text(NAMES_ALIKE)
    prog = Program(load(tmp_path / "p.yaml"))
    prefixes = {bp.name: bp.ident for bp in prog.plans}
    assert prefixes["t"] == "b_t" and prefixes["b_t"] == "b_t_2" and prefixes["math"] == "b_math"
    assert len(set(prefixes.values())) == len(prefixes)
    source, _ = generate(prog)
    assert "b_t_gain" in source and "b_t_2_gain" in source and "b_math_gain" in source
    compiled = np.zeros((64, len(prog.records)))
    CompiledKernel(prog).run(0, compiled, np.zeros((64, 0)))
    ref_prog = Program(load(tmp_path / "p.yaml"))
    reference = np.zeros_like(compiled)
    Interpreter(ref_prog).run(0, reference, np.zeros((64, 0)))
    assert np.any(compiled != 0.0)
    np.testing.assert_array_equal(compiled, reference)


def test_a_groups_step_is_inlined_where_the_kernel_calls_it(write_patch):
    """Issue 25, item 4: the step of a fused group is rebound through jit (inline="always"), so
    its machine code holds no call to it (called, its arguments were pushed every sample); the
    functions of the kernel's end are called (compiled once, in the shared cache)."""
    path = write_patch("""
        hapticgraph: 1
        rate: 44100
        blocks:
          s: {type: lattice, shape: [16], mass: 0.001, tension: 1000.0}
          pick: {type: pluck, force: 1.0, duration: 0.001}
          out: {type: audio_out, channels: 1}
        connect:
          - pick.out -> s[3].force
          - s[5].position -> out.ch0
        """)
    prog = Program(load(path))
    source, _ = generate(prog)
    (step,) = [gs.call[0].__name__ for gs in prog.groups]
    assert f"\n{step} = jit({step})\n" in source
    # what runs once a call, after the loop (the guard's verdict, the buffers put back), is called
    assert "\nfrom hapticgraph.graph.guard import kernel_guard\n" in source and "= jit(kernel_guard)" not in source
    assert "\nfrom hapticgraph.graph.family import exchange\n" in source and "= jit(exchange)" not in source
    fn = JitBackend().memory(KernelCode("inline_test", source))
    rec = np.zeros((8, len(prog.records)))
    assert fn(8, 0, prog.state, prog.live, prog.coef, rec, np.zeros((8, 0)), *prog.buffers, *prog.arrays) == 0
    asm = fn.inspect_asm(fn.signatures[0])
    calls = [line for line in asm.splitlines() if "call" in line or "movabsq\t$_ZN" in line]
    assert not [line for line in calls if step in line], "the step is called, not inlined"
