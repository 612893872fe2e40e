#!/usr/bin/env python
"""Is each stencil's interior loop vectorised? Asks the compiler (issue 25, item 3).

    python benchmarks/vectorised.py [PATCH ...] [--json] [--no-remarks] [--dump DIR] [--aot]

Compiles each patch's kernel as a run does (Program + CompiledKernel, numba's JIT in a fresh
temporary kernel cache, so numba compiles it now) and reads what LLVM made of it:
1. the optimised LLVM IR of the kernel's module (`inspect_llvm`: the kernel and every function it
   calls that LLVM did not inline: string_step, sheet_step, _sheet_bulk, ...): each function's
   control-flow graph, its natural loops (a back edge to a block that dominates it, networkx's
   dominators) and, in each innermost loop, the packed double loads and arithmetic (`<4 x double>`
   fadd/fsub/fmul/llvm.fma);
2. the assembly (`inspect_asm`): per function, the packed double instructions (vaddpd, vmulpd,
   vfmadd…pd) and the widest register they use (xmm 2, ymm 4, zmm 8 doubles);
3. LLVM's loop-vectorize remarks (llvmlite's `set_option('', '-pass-remarks=loop-vectorize')` and
   the -missed / -analysis ones, read from file descriptor 2 during the compile): how many loops it
   vectorised at which width and interleave, and every reason it gave for a loop it did not.
4. with --aot, the kernel built ahead of time (graph/aot.py, numba.pycc: what a warm `hapticgraph
   run` loads), disassembled with objdump: the functions holding the interior loop must have
   packed instructions there too.
A lattice of D dimensions steps its cells through a (2D+1)-point stencil: its interior loop is
vectorised when some innermost loop of the kernel's call tree loads at least 2D+1 packed vectors
of doubles and adds and multiplies packed vectors. The scalar remainder of that loop and the loops
over the faces (branches at the boundary) are listed but are not the interior loop.

Without arguments: benchmarks/string_30000.yaml, sheet_32.yaml, sheet_150.yaml and cube_20.yaml.
Exit status 1 if a patch's stencil has no vectorised interior loop (the report says what LLVM
said instead). Nothing is written outside temporary folders (and --dump DIR: kernel.ll, kernel.s).
"""
import argparse
import contextlib
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

import networkx as nx

HERE = pathlib.Path(__file__).resolve().parent
PATCHES = ("string_30000.yaml", "sheet_32.yaml", "sheet_150.yaml", "cube_20.yaml")
REGISTER_WIDTH = {"xmm": 2, "ymm": 4, "zmm": 8}

_NAME = r'("[^"]+"|[\w.$-]+)'
_DEFINE = re.compile(r"^define [^@]*@" + _NAME + r"\(")
_LABEL = re.compile(r"^" + _NAME + r":")
_SUCCESSOR = re.compile(r"label %" + _NAME)
_CALLEE = re.compile(r"\bcall [^@]*@" + _NAME + r"\(")
_PACKED_LOAD = re.compile(r"= load <(\d+) x double>|@llvm\.masked\.load\.v(\d+)f64")
_PACKED_ADD = re.compile(r"= f(?:add|sub)\b[^<]*<(\d+) x double>")
_PACKED_MUL = re.compile(r"= fmul\b[^<]*<(\d+) x double>|@llvm\.fmuladd\.v(\d+)f64|@llvm\.fma\.v(\d+)f64")
_PACKED_STORE = re.compile(r"\bstore <(\d+) x double> |@llvm\.masked\.store\.v(\d+)f64")
_PREDICATED = re.compile(r"@llvm\.masked\.|= select <\d+ x i1>")
_SCALAR_LOAD = re.compile(r"= load double,")
_SCALAR_STORE = re.compile(r"\bstore double ")
_ASM_FUNCTION = re.compile(r"^([A-Za-z_][\w.$]*):")
_ASM_PACKED = re.compile(r"^\s+v(?:add|sub|mul|fn?madd\d*|fn?msub\d*)pd\s.*%([xyz]mm)\d+")
_REMARK = re.compile(r"^remark: [^:]*:\d+:\d+: (.*)$")


def demangle(name):
    """numba's mangled name as a dotted path (`hapticgraph.blocks.massspring.stencils.sheet_step`)."""
    name = name.strip('"')
    if not name.startswith("_ZN"):
        return name
    parts, i = [], 3
    while i < len(name) and name[i].isdigit():
        j = i
        while name[j].isdigit():
            j += 1
        size = int(name[i:j])
        parts.append(name[j:j + size])
        i = j + size
    return ".".join(parts) or name


def functions(ir):
    """{function name: [(block label, [lines])]} of every function defined in the module's IR."""
    found, current = {}, None
    for line in ir.splitlines():
        head = _DEFINE.match(line)
        if head:
            current = found[head.group(1).strip('"')] = [("<entry>", [])]
        elif current is not None and line.startswith("}"):
            current = None
        elif current is not None:
            label = _LABEL.match(line)
            if label:
                if current[-1][0] == "<entry>" and not current[-1][1]:
                    current.pop()
                current.append((label.group(1).strip('"'), []))
            elif line.strip() and not line.lstrip().startswith(";"):
                current[-1][1].append(line)
    return found


def control_flow(blocks):
    """The function's control-flow graph (networkx DiGraph of block labels)."""
    g = nx.DiGraph()
    for label, lines in blocks:
        g.add_node(label)
        for line in lines:
            if " phi " not in line:
                g.add_edges_from((label, s.strip('"')) for s in _SUCCESSOR.findall(line))
    return g


def innermost_loops(blocks):
    """[set of block labels] of each innermost natural loop of a function."""
    g = control_flow(blocks)
    entry = blocks[0][0]
    idom = nx.immediate_dominators(g, entry)

    def dominates(a, b):
        while True:
            if a == b:
                return True
            if idom.get(b, b) == b:
                return False
            b = idom[b]
    bodies = {}
    for u, h in g.edges:
        if u in idom and dominates(h, u):
            inside = g.subgraph(n for n in g if n != h)
            body = bodies.setdefault(h, {h})
            body |= {u} | (nx.ancestors(inside, u) if u != h else set())
    return [body for h, body in bodies.items()
            if not any(other != h and other in body for other in bodies)]


def _widths(pattern, lines):
    """The vector width of each match of pattern (whichever of its groups matched) in lines."""
    return [int(next(w for w in ((m,) if isinstance(m, str) else m) if w))
            for line in lines for m in pattern.findall(line)]


def loop_stats(lines):
    """What one loop's body does with doubles: packed loads, adds and multiplies and their width."""
    loads, stores, adds, muls = (_widths(p, lines) for p in (_PACKED_LOAD, _PACKED_STORE, _PACKED_ADD, _PACKED_MUL))
    return {"width": max(adds + muls + loads, default=1), "packed_loads": len(loads), "packed_stores": len(stores),
            "packed_adds": len(adds), "packed_muls": len(muls),
            "predicated": sum(bool(_PREDICATED.search(ln)) for ln in lines),
            "scalar_loads": sum(bool(_SCALAR_LOAD.search(ln)) for ln in lines),
            "scalar_stores": sum(bool(_SCALAR_STORE.search(ln)) for ln in lines)}


def reachable(funcs, root):
    """The functions defined in the module that `root` calls, directly or not, and root."""
    seen, todo = {root}, [root]
    while todo:
        for _, lines in funcs[todo.pop()]:
            for line in lines:
                for callee in _CALLEE.findall(line):
                    callee = callee.strip('"')
                    if callee in funcs and callee not in seen:
                        seen.add(callee)
                        todo.append(callee)
    return seen


def kernel_loops(ir, kernel):
    """[loop stats + its function's name] of every innermost loop that stores doubles, in the kernel
    and the functions it calls."""
    funcs = functions(ir)
    found = []
    for name in sorted(reachable(funcs, kernel)):
        lines_of = dict(funcs[name])
        for body in innermost_loops(funcs[name]):
            stats = loop_stats([ln for label in body for ln in lines_of.get(label, [])])
            if stats["packed_stores"] or stats["scalar_stores"]:
                found.append({"function": demangle(name), "blocks": len(body), **stats})
    return found


def is_interior(loop, dims):
    """The vectorised interior loop of a (2D+1)-point stencil: for each packed store, 2D+1 packed loads
    at least (the cell and its 2D neighbours; the loop that only adds dt·v to x has 2), packed adds
    and multiplies, and no predication (no masked load or store, no per-lane select: a loop whose
    boundary tests were if-converted is a face's, not the interior's)."""
    return (loop["width"] >= 2 and loop["packed_stores"] > 0 and dims > 0
            and loop["packed_loads"] >= (2 * dims + 1) * loop["packed_stores"]
            and loop["packed_adds"] > 0 and loop["packed_muls"] > 0 and loop["predicated"] == 0)


def asm_packed(asm):
    """{function: {"packed": packed double arithmetic instructions, "width": widest register}}."""
    found, current = {}, None
    for line in asm.splitlines():
        head = _ASM_FUNCTION.match(line)
        if head and not line.startswith(".L"):
            current = demangle(head.group(1))
            continue
        m = _ASM_PACKED.match(line)
        if m and current is not None:
            entry = found.setdefault(current, {"packed": 0, "width": 1})
            entry["packed"] += 1
            entry["width"] = max(entry["width"], REGISTER_WIDTH[m.group(1)])
    return found


def remark_summary(text):
    """{"vectorized": [message, ...], "not vectorized": {reason: count}} from LLVM's remarks."""
    done, missed = [], {}
    for line in text.splitlines():
        m = _REMARK.match(line.strip())
        if not m:
            continue
        message = m.group(1)
        if message.startswith("vectorized loop"):
            done.append(message)
        else:
            missed[message] = missed.get(message, 0) + 1
    return {"vectorized": done, "not vectorized": missed}


def enable_remarks():
    """LLVM's loop-vectorize remarks on, for every compile that follows in this process."""
    import llvmlite.binding as llvm
    for kind in ("", "-missed", "-analysis"):
        llvm.set_option("", f"-pass-remarks{kind}=loop-vectorize")


@contextlib.contextmanager
def captured_fd2(out):
    """Whatever is written to file descriptor 2 inside (LLVM writes its remarks there) into out[0]."""
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as f:
        os.dup2(f.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            f.seek(0)
            out.append(f.read().decode("utf-8", "replace"))


@contextlib.contextmanager
def fresh_kernel_cache(aot=False):
    """An empty kernel cache, so the kernel is compiled now: by numba's JIT, or `aot` into an
    extension module (graph/aot.py), as a run of the patch would."""
    saved = {k: os.environ.get(k) for k in ("HAPTICGRAPH_CACHE", "HAPTICGRAPH_AOT")}
    with tempfile.TemporaryDirectory(prefix="hg-vectorised-") as folder:
        os.environ.update(HAPTICGRAPH_CACHE=folder, HAPTICGRAPH_AOT="1" if aot else "0")
        try:
            yield
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v


def lattice_dims(patch):
    """The largest number of dimensions of a lattice block in the patch (0: none)."""
    return max((len(inst.values["shape"]) for inst in patch.blocks.values()
                if inst.cls.type_name == "lattice"), default=0)


def compile_patch(path):
    """(patch, optimised IR, assembly, the kernel's function name, LLVM's stderr) of a patch's kernel."""
    from hapticgraph.graph.kernel import CompiledKernel
    from hapticgraph.graph.patch import load
    from hapticgraph.graph.program import Program
    patch = load(path)
    err = []
    with fresh_kernel_cache(), captured_fd2(err):
        fn = CompiledKernel(Program(patch)).fn
    sig = fn.signatures[0]
    return patch, fn.inspect_llvm(sig), fn.inspect_asm(sig), fn.overloads[sig].fndesc.mangled_name, err[0]


def aot_packed(path):
    """asm_packed() of the kernel built ahead of time (graph/aot.py: the machine code a warm
    `hapticgraph run` loads), read with objdump -d; None without objdump or an extension module."""
    from hapticgraph.graph.kernel import CompiledKernel
    from hapticgraph.graph.patch import load
    from hapticgraph.graph.program import Program
    objdump = shutil.which("objdump")
    if objdump is None:
        return None
    with fresh_kernel_cache(aot=True):
        with captured_fd2([]):                  # the same remarks again: read once, in analyse()
            kernel = CompiledKernel(Program(load(path)))
        folder = pathlib.Path(kernel.path).parent if kernel.path else None
        built = sorted(folder.glob("hapticgraph_aot*.so")) if kernel.backend.name == "aot" else []
        if not built:
            return None
        dis = subprocess.run([objdump, "-d", "--no-show-raw-insn", str(built[0])], capture_output=True,
                             text=True, check=True, timeout=300).stdout
    # objdump's "0000000000001234 <name>:" and "   1234:\tvaddpd %ymm1,..." as the assembler's
    text = re.sub(r"^[0-9a-f]+ <([^>]+)>:$", r"\1:", dis, flags=re.M)
    return asm_packed(re.sub(r"^\s+[0-9a-f]+:\s+", "\t", text, flags=re.M))


def analyse(path, dump=None):
    """The report of one patch (a JSON-able dict); "vectorised" is the verdict."""
    patch, ir, asm, kernel, err = compile_patch(path)
    if dump is not None:
        folder = pathlib.Path(dump) / pathlib.Path(path).stem
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "kernel.ll").write_text(ir, encoding="utf-8")
        (folder / "kernel.s").write_text(asm, encoding="utf-8")
    dims = lattice_dims(patch)
    loops = kernel_loops(ir, kernel)
    interior = [lp for lp in loops if is_interior(lp, dims)]
    return {"patch": str(path), "dims": dims, "vectorised": bool(interior) and dims > 0,
            "interior": interior, "loops": loops, "asm": asm_packed(asm), "remarks": remark_summary(err)}


def check_aot(report):
    """Adds the ahead-of-time module's packed instructions to the report; the verdict holds only if
    each function holding an interior loop has packed instructions there too."""
    report["aot"] = aot_packed(report["patch"])
    if report["aot"] is not None:
        report["vectorised"] = report["vectorised"] and all(
            report["aot"].get(lp["function"], {"width": 1})["width"] >= 2 for lp in report["interior"])


def short(function):
    return function.split(".")[-1] if function.startswith("hapticgraph.") else function[:40]


def show(report):
    """The report as text."""
    verdict = "VECTORISED" if report["vectorised"] else "NOT VECTORISED"
    lines = [f"{report['patch']}: {report['dims']}-D lattice, interior loop {verdict}"]
    for lp in report["loops"]:
        if lp["width"] == 1 and lp["scalar_loads"] < 2:
            continue                            # fills and copies: not a stencil
        mark = "*" if lp in report["interior"] else " "
        lines.append(f"  {mark} loop in {short(lp['function']):<14} width {lp['width']}  packed: loads "
                     f"{lp['packed_loads']:>2} stores {lp['packed_stores']:>2} adds {lp['packed_adds']:>2} muls "
                     f"{lp['packed_muls']:>2} predicated {lp['predicated']:>2}   scalar: loads {lp['scalar_loads']:>2} "
                     f"stores {lp['scalar_stores']:>2}   ({lp['blocks']} blocks)")
    asm = ", ".join(f"{short(f)} {a['packed']} (width {a['width']})" for f, a in report["asm"].items())
    lines.append(f"    assembly, packed double instructions: {asm or 'none'}")
    if "aot" in report:
        aot = report["aot"]
        lines.append("    ahead of time: " + ("not built (no objdump, or no compiler for the extension module)"
                                            if aot is None else ", ".join(f"{short(f)} {a['packed']} (width {a['width']})"
                                                                          for f, a in aot.items()) or "none"))
    rem = report["remarks"]
    lines.append(f"    remarks: {len(rem['vectorized'])} loops vectorised: " + "; ".join(sorted(set(rem["vectorized"])))
                 + ("" if rem["vectorized"] else " (none: remarks off, or the helpers were compiled already, "
                    "for an earlier patch of this run, and only the kernel was compiled now)"))
    lines += [f"    remark x{n}: {reason}" for reason, n in sorted(rem["not vectorized"].items())]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("patches", nargs="*", default=[str(HERE / p) for p in PATCHES])
    ap.add_argument("--json", action="store_true", help="print the reports as one JSON list")
    ap.add_argument("--no-remarks", action="store_true", help="do not turn LLVM's remarks on")
    ap.add_argument("--dump", metavar="DIR", help="write each kernel's kernel.ll and kernel.s under DIR/PATCH/")
    ap.add_argument("--aot", action="store_true", help="also disassemble the kernel built ahead of time: the "
                    "functions holding the interior loop must have packed instructions there too")
    args = ap.parse_args(argv)
    if not args.no_remarks:
        enable_remarks()
    reports = [analyse(p, args.dump) for p in args.patches]
    if args.aot:
        for r in reports:
            check_aot(r)
    print(json.dumps(reports, indent=1) if args.json else "\n".join(show(r) for r in reports))
    return 0 if all(r["vectorised"] for r in reports) else 1


if __name__ == "__main__":
    sys.exit(main())
