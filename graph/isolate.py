"""Plugin blocks, each compiled on its own, so that a block numba cannot compile is reported at its
plugin's file and line (`block 'NAME' (TYPE): numba cannot compile output(): <reason>`), not as
numba's view of the whole kernel. `compiled(prog)` is the compiler with that diagnosis (what the
engine uses); `plugin_problems(patch)` what `hapticgraph check` runs."""
import inspect
import math
import os
import re
import sys

from ..blocks.vocabulary import Block, Out, Param
from .errors import PatchError, Problem
from .identifiers import KernelSourceError, note
from .kernel import CompiledKernel
from .model import Connection, Endpoint, Instance
from .program import PlanError, Program


def compiled(prog):
    """The CompiledKernel of a program; when numba cannot compile it, PatchError naming the plugin
    block at fault (compiled on its own), not numba's view of the kernel, if one is."""
    try:
        return CompiledKernel(prog)
    except Exception as exc:  # noqa: BLE001 - numba's errors have no one base class
        if not is_numba_error(exc):
            raise
        problems = plugin_problems(prog.patch)
        if problems:
            raise PatchError(problems) from None
        raise


def is_numba_error(exc):
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


def isolated(patch, inst):
    """The part of the patch that is one block, each connected input fed by an IsolationFeed (so
    its inputs and live parameters are typed as in the patch, not as constants)."""
    fed = sorted({c.dst.port for c in patch.connections if c.dst.block == inst.name and c.dst.index is None})
    feeds, connections = [], []
    for k, port in enumerate(fed):
        values = IsolationFeed.default_params()
        values["seed"] = k + 1
        feed = Instance(f"feed{k}", IsolationFeed, values, inst.line, {}, -1 - k)
        feeds.append(feed)
        connections.append(Connection(Endpoint(feed.name, None, IsolationFeed.y.name),
                                      Endpoint(inst.name, None, port), inst.line))
    return patch.subset(feeds + [inst], connections, name=f"check_{inst.cls.type_name}")


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
            prog = Program(isolated(patch, inst))
        except (PlanError, KeyError, ValueError):
            continue         # bound to a device or a network: only the whole patch can compile it
        try:
            CompiledKernel(prog, label=f"plugin block {note(inst.name)} ({inst.cls.type_name})")
        except KernelSourceError as exc:
            try:
                line = inspect.getsourcelines(inst.cls)[1]
            except (OSError, TypeError):
                line = 1
            problems.append(Problem(file, line,
                                    f"block {inst.name!r} ({inst.cls.type_name}): {exc}"))
        except Exception as exc:  # noqa: BLE001 - numba's errors have no one base class
            if not is_numba_error(exc):
                raise
            which, path, line = _culprit(inst.cls, exc)
            problems.append(Problem(path, line, f"block {inst.name!r} ({inst.cls.type_name}): numba cannot "
                                                f"compile {which}(): {_reason(exc)}"))
    return problems
