"""The compiler: emit ONE readable kernel module per patch, write it to the cache folder under a
hash, import it and let numba compile it (and cache the machine code beside it).

The generated `kernel(n, t0, state, live, coef, rec, ext, <buffers>, <arrays>)` runs n samples: state
and live parameters are loaded into locals before the sample loop and stored back after it; in
the loop every block's `output` then every `update` runs in schedule order, static values are
literals, buffers are power-of-two rings indexed through the shared counter `t`.

The source holds no text from a patch: only identifiers the compiler makes (slot numbers), names
of Python modules, classes and functions (each matched whole as an identifier), numbers it
formats, and comments reduced to [A-Za-z0-9_]. A file name or block name cannot become code.

The cache is verified, never trusted: each kernel has its own folder `kernel_<key>/` holding
`kernel.py`, numba's `__pycache__/` and `manifest.json` (the SHA-256 of every other file),
written after a successful compile. An entry is used only when `kernel.py` is byte for byte the
source just generated and every file matches the manifest (no file missing, none extra);
otherwise it is deleted and rebuilt. The key hashes the source, the numba, llvmlite, numpy and
Python versions, the CPU, every module that defines a function the kernel calls and every
plugin file the patch loaded.
"""
import hashlib
import inspect
import json
import math
import os
import platform
import re
import shutil
import sys
import tempfile
import time
import types

from ..blocks.core import Block, Out, Param, register_helpers
from .errors import PatchError, Problem
from .ir import KernelSourceError, ident
from .program import PlanError, Program

# Set by the command line (unless --quiet) to a callable taking one line of text: told when a
# kernel is compiled rather than loaded from the cache. Library code prints nothing by default.
notice = None

_DOTTED = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*")
_jitted = {}
_loaded = {}            # (cache folder, key) -> (dispatcher, path): kernels this process compiled or loaded
_warned = []            # the one "cache not usable" warning, given at most once per process
MANIFEST = "manifest.json"


def dotted(name, what):
    if not isinstance(name, str) or not _DOTTED.fullmatch(name):
        raise KernelSourceError(f"{what} {name!r} is not a dotted identifier; it cannot be compiled")
    return name


def note(text, limit=60):
    """Text for a comment of the kernel: every character outside [A-Za-z0-9_] becomes `_`."""
    return "".join(c if c.isascii() and (c.isalnum() or c == "_") else "_" for c in str(text)[:limit])


def jit(fn):
    """The numba dispatcher of a block function, made once per process.

    inline="always" makes numba splice the function into the kernel's IR instead of compiling
    and linking a module of its own: the code is the same (LLVM inlined the calls anyway), a
    cold compile takes about half as long. Block functions are not cached on their own: inlined,
    they are never compiled on their own, and a cache file beside a block's module (in
    site-packages or a plugin's folder) would be one nothing verifies.
    """
    d = _jitted.get(fn)
    if d is None:
        import numba
        register_helpers()
        d = _jitted[fn] = numba.njit(fn, cache=False, inline="always")
    return d


def cache_dir():
    """HAPTICGRAPH_CACHE, else the user cache directory of this platform."""
    path = os.environ.get("HAPTICGRAPH_CACHE")
    if not path:
        if sys.platform == "win32":
            base = os.environ.get("LOCALAPPDATA") or os.path.expanduser("~")
        elif sys.platform == "darwin":
            base = os.path.expanduser("~/Library/Caches")
        else:
            base = os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache")
        path = os.path.join(base, "hapticgraph")
    return path


class Emitter:
    """Lines of Python with indentation (the whole code generator leans on this)."""

    def __init__(self):
        self.lines, self.level = [], 0

    def __call__(self, line=""):
        self.lines.append("    " * self.level + line if line else "")

    def indent(self):
        self.level += 1

    def dedent(self):
        self.level -= 1

    def source(self):
        return "\n".join(self.lines) + "\n"


def generate(prog: Program):
    """The kernel module's source for a program, and the Python functions it calls.

    Nothing from the patch reaches the source as text: numbers are data (the coef array), names
    are sanitized identifiers, comments carry names reduced to [A-Za-z0-9_], and module, class,
    function and parameter names (which come from Python, not from the patch) are matched whole
    as identifiers. The sample loop is the program's schedule items, in order (graph/items.py).
    """
    body = Emitter()
    args = [node.emit() for node in prog.buffer_nodes + prog.array_nodes]
    body("# compiled by hapticgraph.graph.kernel with numba.njit, nogil; cached beside this file")
    body(f"def kernel(n, t0, state, live, coef, rec, ext{''.join(', ' + a for a in args)}):")
    body.indent()
    for node in _loaded_nodes(prog):
        body(f"{node.emit()} = {node.load()}")
    body("for i in range(n):")
    body.indent()
    body("t = t0 + i")
    for item in prog.items:
        item.emit(body)
    body.dedent()
    for bp in prog.plans:
        for node in bp.state_nodes:
            body(f"{node.load()} = {node.emit()}")
    body("return 0")
    e = Emitter()
    e("# hapticgraph kernel, generated; do not edit. Numbers are data (coef); this text is the structure.")
    e("# schedule: " + " -> ".join(f"{note(bp.name, 30)}" for bp in prog.plans))
    fns = _emit_imports(e, prog, uses_math="math." in body.source())
    e()
    e()
    return e.source() + body.source(), fns


def _loaded_nodes(prog):
    """Scalar state, live parameters, coefficients and numbers: loaded into locals before the
    sample loop (numba keeps them in registers inside it)."""
    nodes = [node for bp in prog.plans for node in bp.state_nodes]
    for bp in prog.plans:
        nodes += list(bp.live_nodes.values()) + list(bp.coef_nodes.values())
    return nodes + prog.number_nodes


def _emit_imports(e, prog, uses_math):
    """The modules and functions the kernel uses (and only those); the functions called."""
    per_sample = [bp for bp in prog.plans if bp.coef_mode == "per_sample"]
    if per_sample:
        e("import collections")
    if uses_math:
        e("import math")
    e("from hapticgraph.graph.kernel import jit")
    e()
    called = {fn for item in prog.items for fn in item.functions()}
    fns = _emit_block_imports(e, prog, called)
    for fn in sorted((fn for fn in called if fn not in fns), key=lambda f: (f.__module__, f.__name__)):
        module, name = dotted(fn.__module__, "module of a step function"), ident(fn.__name__, "step function")
        e(f"from {module} import {name}")     # a @helper: numba compiles it where the kernel calls it
        fns.append(fn)
    for bp in per_sample:
        fields = ", ".join(repr(ident(n, f"parameter of {bp.cls.type_name!r}")) for n in bp.cls.params)
        params = ident(prog.derived(bp)[1], "parameter tuple")
        e(f"{params} = collections.namedtuple('{params}', [{fields}])")
    return fns


def _emit_block_imports(e, prog, called):
    """Each block type whose functions the kernel calls, and `TYPE_output = jit(...)` for each."""
    classes, fns = set(), []
    for bp in prog.plans:
        cls = bp.cls
        which = [w for w in ("derive", "output", "update") if getattr(cls, w) is not None and getattr(cls, w) in called]
        if cls in classes or not which:
            continue
        classes.add(cls)
        tname = ident(cls.type_name, "block type name")
        alias = f"{tname}_type"
        module, qual = cls.__module__, cls.__qualname__
        if "<locals>" in qual:
            raise KernelSourceError(f"block type {tname!r} must be defined at module level to be compiled")
        dotted(module, f"module of block type {tname!r}")
        dotted(qual, f"class name of block type {tname!r}")
        if "." in qual:
            e(f"import {module} as {alias}_module")
            e(f"{alias} = {alias}_module.{qual}")
        else:
            e(f"from {module} import {qual} as {alias}")
        for w in which:
            e(f"{tname}_{w} = jit({alias}.{w})")
            fns.append(getattr(cls, w))
    return fns


# -- the cache key: everything the machine code depends on --------------------------------------

_SKIP_TOP = {"numpy", "numba", "llvmlite", "builtins"} | set(getattr(sys, "stdlib_module_names", ()))
_host = []


def _host_id():
    """Versions and the CPU the machine code is made for (numba's cache is per CPU)."""
    if not _host:
        import llvmlite
        import numba
        import numpy
        from llvmlite import binding
        cpu = f"{binding.get_host_cpu_name()} {binding.get_host_cpu_features().flatten()}"
        _host.append("\0".join([numba.__version__, llvmlite.__version__, numpy.__version__, sys.version,
                                sys.implementation.cache_tag or "", platform.machine(), cpu,
                                str(numba.config.CPU_NAME), str(numba.config.CPU_FEATURES)]))
    return _host[0]


def _codes(code):
    yield code
    for c in code.co_consts:
        if inspect.iscode(c):
            yield from _codes(c)


def _reachable_files(fns):
    """Source files of every function the kernel calls and of every function (a @helper, a
    dispatcher) those reach through their globals, outside the standard library and numpy/numba;
    plus the bytecode of functions that have no file."""
    files, seen, todo = set(), set(), list(fns)
    anonymous = []
    while todo:
        fn = todo.pop()
        fn = getattr(fn, "py_func", fn)          # a numba dispatcher: its Python function
        if not inspect.isfunction(fn) or fn in seen:
            continue
        seen.add(fn)
        top = (fn.__module__ or "").split(".")[0]
        if top in _SKIP_TOP:
            continue
        path = getattr(sys.modules.get(fn.__module__), "__file__", None)
        if path:
            files.add(os.path.realpath(path))
        else:
            anonymous.append(fn.__code__.co_code)
        g = fn.__globals__
        for code in _codes(fn.__code__):
            for name in code.co_names:
                value = g.get(name)
                if inspect.ismodule(value):
                    if value.__name__.split(".")[0] in _SKIP_TOP:
                        continue
                    todo += [getattr(value, attr, None) for attr in code.co_names]
                elif value is not None:
                    todo.append(value)
    return files, anonymous


def _file_digest(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def kernel_key(source, fns, prog):
    """The hash that names a kernel's cache entry."""
    h = hashlib.sha256()

    def add(text):
        h.update(str(text).encode("utf-8", "surrogatepass"))
        h.update(b"\0")
    add("hapticgraph kernel 2")
    add(source)
    add(_host_id())
    files, anonymous = _reachable_files(list(fns) + [jit])
    registry = getattr(prog.patch, "registry", None)
    files |= {os.path.realpath(p) for p in getattr(registry, "plugin_files", ())}
    for path in sorted(files):
        add(path)
        try:
            add(_file_digest(path))
        except OSError as exc:
            add(f"unreadable: {exc}")
    for code in anonymous:
        add(hashlib.sha256(code).hexdigest())
    return h.hexdigest()[:24]


# -- the cache folder -------------------------------------------------------------------------

def _say(text):
    if notice is not None:
        notice(text)


def _warn_once(text):
    if not _warned:
        _warned.append(text)
        print(f"hapticgraph: warning: {text}", file=sys.stderr, flush=True)


def usable_cache_dir():
    """The cache folder if it can hold kernels (a folder we own, writable, not world-writable);
    else None after one warning: kernels are then compiled in memory."""
    root = cache_dir()
    try:
        os.makedirs(root, mode=0o700, exist_ok=True)
        st = os.stat(root)
        if not os.path.isdir(root):
            raise NotADirectoryError("not a folder")
        if hasattr(os, "geteuid") and st.st_uid != os.geteuid():
            raise PermissionError("owned by another user")
        if hasattr(os, "geteuid") and st.st_mode & 0o002:
            raise PermissionError("writable by every user")
        tempfile.TemporaryFile(dir=root).close()
    except OSError as exc:
        reason = exc.strerror or str(exc) or type(exc).__name__
        _warn_once(f"kernel cache {root!r} is not usable ({reason}); compiling in memory "
                   "(set HAPTICGRAPH_CACHE to a folder of yours)")
        return None
    return root


def _listing(folder):
    """Every file under folder (relative paths with /), or None if a link or odd file is there."""
    found = []
    for top, dirs, names in os.walk(folder, followlinks=False):
        for d in dirs:
            if os.path.islink(os.path.join(top, d)):
                return None
        for n in names:
            path = os.path.join(top, n)
            if os.path.islink(path) or not os.path.isfile(path):
                return None
            found.append(os.path.relpath(path, folder).replace(os.sep, "/"))
    return sorted(found)


def verified(entry, source, key):
    """True if the entry folder is exactly what a compile of this source wrote: kernel.py is the
    source, and every file is listed in the manifest with its hash (none missing, none extra)."""
    try:
        if os.path.islink(entry) or not os.path.isdir(entry):
            return False
        with open(os.path.join(entry, MANIFEST), "rb") as f:
            manifest = json.loads(f.read(1 << 20))
        files = manifest.get("files") if isinstance(manifest, dict) else None
        if manifest.get("key") != key or not isinstance(files, dict):
            return False
        listing = _listing(entry)
        if listing is None or sorted(list(files) + [MANIFEST]) != listing or "kernel.py" not in files:
            return False
        with open(os.path.join(entry, "kernel.py"), "rb") as f:
            if f.read() != source.encode("utf-8"):
                return False
        return all(isinstance(d, str) and _file_digest(os.path.join(entry, *rel.split("/"))) == d
                   for rel, d in files.items())
    except (OSError, ValueError, AttributeError, TypeError):
        return False


def _write_manifest(entry, key):
    files = {rel: _file_digest(os.path.join(entry, *rel.split("/")))
             for rel in (_listing(entry) or ()) if rel != MANIFEST}
    tmp = os.path.join(entry, MANIFEST + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump({"key": key, "files": files}, f, indent=1, sort_keys=True)
    os.replace(tmp, os.path.join(entry, MANIFEST))


def _remove(path):
    if os.path.islink(path) or os.path.isfile(path):
        os.remove(path)
    elif os.path.isdir(path):
        shutil.rmtree(path)


_cache_class = []


def _pinned_cache(py_func):
    """numba's function cache, kept in `__pycache__` beside the kernel file whatever
    NUMBA_CACHE_DIR or numba's fallback locations say, so every file it reads is one we verify."""
    if not _cache_class:
        from numba.core import caching

        class Locator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
            def __init__(self, py_func, py_file):
                self._py_func, self._py_file = py_func, py_file
                self._lineno = py_func.__code__.co_firstlineno

            def get_cache_path(self):
                return os.path.join(os.path.dirname(self._py_file), "__pycache__")

        class Impl(caching.CompileResultCacheImpl):
            def __init__(self, py_func):
                self._lineno = py_func.__code__.co_firstlineno
                self._locator = Locator(py_func, py_func.__code__.co_filename)
                self._filename_base = self.get_filename_base(f"kernel.{py_func.__qualname__}",
                                                             getattr(sys, "abiflags", ""))

        class Cache(caching.FunctionCache):
            _impl_class = Impl
        _cache_class.append(Cache)
    return _cache_class[0](py_func)


def _module(name, source, filename):
    """The kernel module, executed from the source in memory (no .pyc is written or read)."""
    module = types.ModuleType(name)
    module.__file__ = filename
    sys.modules[name] = module   # numba re-imports it by name when it loads cached code
    try:
        exec(compile(source, filename, "exec"), module.__dict__)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def _dispatcher(module, cached):
    import numba
    fn = numba.njit(nogil=True)(module.kernel)
    if cached:
        fn._cache = _pinned_cache(module.kernel)
    return fn


def _compile(key, source, label, warm):
    """(dispatcher, path of kernel.py or None): from a verified cache entry, else compiled (into a
    fresh entry when the cache folder is usable, else in memory)."""
    name = f"hapticgraph_kernel_{key}"
    root = usable_cache_dir()
    if root is not None:
        entry = os.path.join(root, f"kernel_{key}")
        path = os.path.join(entry, "kernel.py")
        if verified(entry, source, key):
            fn = _dispatcher(_module(name, source, path), cached=True)
            warm(fn)
            if fn.stats.cache_misses:      # numba compiled after all (and wrote its files): list them
                try:
                    _write_manifest(entry, key)
                except OSError:
                    pass
            return fn, path
        _say(f"compiling {label}…")
        tmp = None
        try:
            tmp = tempfile.mkdtemp(prefix=f".kernel_{key}.", dir=root)
            with open(os.path.join(tmp, "kernel.py"), "w", encoding="utf-8") as f:
                f.write(source)
            fn = _dispatcher(_module(name, source, os.path.join(tmp, "kernel.py")), cached=True)
            warm(fn)
            fn._cache.disable()      # its files move with the rename below; nothing more is written
            _write_manifest(tmp, key)
            try:
                os.rename(tmp, entry)
            except OSError:
                if verified(entry, source, key):    # another process finished the same kernel first
                    _remove(tmp)
                else:
                    _remove(entry)
                    os.rename(tmp, entry)
            return fn, path
        except OSError as exc:
            if tmp is not None:
                shutil.rmtree(tmp, ignore_errors=True)
            _warn_once(f"kernel cache {root!r}: {exc.strerror or exc}; compiling in memory")
            sys.modules.pop(name, None)
        except BaseException:        # numba cannot compile it, or an interrupt: leave nothing behind
            if tmp is not None:
                shutil.rmtree(tmp, ignore_errors=True)
            sys.modules.pop(name, None)
            raise
    else:
        _say(f"compiling {label}…")
    fn = _dispatcher(_module(name, source, f"<hapticgraph kernel {key}>"), cached=False)
    warm(fn)
    return fn, None


class CompiledKernel:
    """The imported, jitted kernel of a program; `run(t0, rec)` fills rec (n × records)."""

    def __init__(self, prog: Program, label=None, diagnose=True):
        import numpy as np
        register_helpers()
        start = time.perf_counter()
        self.prog = prog
        source, fns = generate(prog)
        self.source = source
        self.key = kernel_key(source, fns, prog)
        self.extra = tuple(prog.buffers) + tuple(prog.arrays)

        def warm(fn):
            # compile now (or load numba's cache), so the first block of audio is not late
            fn(0, 0, prog.state, prog.live, prog.coef, np.zeros((0, len(prog.records))),
               np.zeros((0, len(prog.ext_columns))), *self.extra)
        label = label or f"kernel for {len(prog.plans)} block{'s' if len(prog.plans) != 1 else ''}"
        where = (cache_dir(), self.key)
        loaded = _loaded.get(where)
        try:
            if loaded is None:
                loaded = _loaded[where] = _compile(self.key, source, label, warm)
            else:
                warm(loaded[0])
        except Exception as exc:
            if not diagnose or not _is_numba_error(exc):
                raise
            # name the plugin block at fault (compiled on its own), not numba's view of the kernel
            problems = plugin_problems(prog.patch) if hasattr(prog.patch, "registry") else None
            if problems:
                raise PatchError(problems) from None
            raise
        self.fn, self.path = loaded
        if os.environ.get("HAPTICGRAPH_DUMP") == "1":
            where = self.path or "compiled in memory (no usable cache folder)"
            print(f"hapticgraph: kernel for {note(prog.patch.name)} is {where}", file=sys.stderr)
        self.compile_seconds = time.perf_counter() - start

    def run(self, t0, rec, ext):
        p = self.prog
        self.fn(rec.shape[0], t0, p.state, p.live, p.coef, rec, ext, *self.extra)


# -- plugin blocks, each compiled on its own --------------------------------------------------

def _is_numba_error(exc):
    try:
        from numba.core.errors import NumbaError
    except ImportError:
        return False
    return isinstance(exc, NumbaError)


def _reason(exc, limit=2):
    """numba's reason in at most `limit` short lines (its headers, source excerpts and
    'During: ...' context dropped)."""
    lines = []
    for raw in re.sub(r"\x1b\[[0-9;]*m", "", str(exc)).splitlines():
        line = raw.strip()
        if not line or line.startswith(("Failed in ", "File \"", "During:", "- Resolution", "^",
                                         "This error may have", "Enable logging")):
            if lines and line.startswith(("File \"", "During:")):
                break
            continue
        if line.startswith(("No implementation of function", "Invalid use of")) and lines:
            continue
        lines.append(line[:160])
        if len(lines) >= limit:
            break
    return " ".join(lines) or type(exc).__name__


def _culprit(cls, exc):
    """(function name, file, line) of the block function numba's message points into."""
    text = str(exc)
    candidates = []
    for which in ("derive", "output", "update"):
        fn = getattr(cls, which)
        if fn is None:
            continue
        try:
            lines, first = inspect.getsourcelines(fn)
            path = inspect.getsourcefile(fn)
        except (OSError, TypeError):
            continue
        candidates.append((which, path, first, first + len(lines) - 1))
    hits = [(m.group(1), int(m.group(2))) for m in re.finditer(r'File "([^"]+)", line (\d+)', text)]
    hits += [(m.group(1), int(m.group(2))) for m in re.finditer(r" at (\S+\.py) \((\d+)\)", text)]
    for file, line in hits:
        for which, path, lo, hi in candidates:
            if lo <= line <= hi and os.path.basename(file) == os.path.basename(path):
                return which, path, line
    if candidates:
        which, path, lo, _ = next((c for c in candidates if c[0] == "output"), candidates[0])
        return which, path, lo
    return "output", inspect.getsourcefile(cls) or "?", 1


class IsolationFeed(Block, name="isolation_feed"):
    """A signal that varies every sample, fed into each connected input of a plugin block compiled
    on its own (so its inputs and live parameters are typed as in the patch, not as constants)."""

    y = Out(name="out")
    seed = Param(1.0)

    @staticmethod
    def output(t, seed):
        return math.sin(0.001 * t + seed)


class _Isolated:
    """A patch of one block (every connected input fed by an IsolationFeed), for its own compile."""

    def __init__(self, patch, inst):
        from .patch import Connection, Endpoint, Instance
        noise = IsolationFeed
        self.file, self.doc, self.name, self.rate = patch.file, patch.doc, f"check_{inst.cls.type_name}", patch.rate
        self.devices, self.registry = patch.devices, patch.registry
        self.blocks, self.connections, self.order = {}, [], []
        fed = sorted({c.dst.port for c in patch.connections if c.dst.block == inst.name and c.dst.index is None})
        for k, port in enumerate(fed):
            feed = f"feed{k}"
            values = noise.default_params()
            values["seed"] = k + 1
            self.blocks[feed] = Instance(feed, noise, values, inst.line, {}, -1 - k)
            self.connections.append(Connection(Endpoint(feed, None, noise.y.name), Endpoint(inst.name, None, port),
                                               inst.line))
            self.order.append(feed)
        self.blocks[inst.name] = inst
        self.order.append(inst.name)


def plugin_blocks(patch):
    """(instance, plugin file) of every block whose type a plugin defines."""
    origin = patch.registry.origin
    out = []
    for inst in patch.blocks.values():
        if origin.get(inst.cls.type_name, "built-in") == "built-in":
            continue
        out.append((inst, inspect.getsourcefile(inst.cls) or getattr(sys.modules.get(inst.cls.__module__),
                                                                      "__file__", "?")))
    return out


def plugin_problems(patch):
    """Compile every plugin block of the patch on its own, with the patch's parameter values.

    A block that numba cannot compile is a Problem at its plugin's file and line:
    `block 'NAME' (TYPE): numba cannot compile output(): <reason>`.
    """
    problems, done = [], set()
    for inst, file in plugin_blocks(patch):
        sig = (inst.cls, repr(sorted((k, repr(v)) for k, v in inst.values.items())))
        if sig in done:
            continue
        done.add(sig)
        try:
            prog = Program(_Isolated(patch, inst))
        except (PlanError, KeyError, ValueError):
            continue         # bound to a device or a network: only the whole patch can compile it
        try:
            CompiledKernel(prog, label=f"plugin block {note(inst.name)} ({inst.cls.type_name})", diagnose=False)
        except KernelSourceError as exc:
            try:
                line = inspect.getsourcelines(inst.cls)[1]
            except (OSError, TypeError):
                line = 1
            problems.append(Problem(file, line,
                                    f"block {inst.name!r} ({inst.cls.type_name}): {exc}"))
        except Exception as exc:  # noqa: BLE001 - numba's errors have no one base class
            if not _is_numba_error(exc):
                raise
            which, path, line = _culprit(inst.cls, exc)
            problems.append(Problem(path, line, f"block {inst.name!r} ({inst.cls.type_name}): numba cannot "
                                                f"compile {which}(): {_reason(exc)}"))
    return problems
