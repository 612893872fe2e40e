"""The commands that look at a patch without playing it: `check`, `blocks`, `schema`, `graph`,
`modes` and `plot`. This module imports the loader only: `check` and `graph` compile nothing
(numba, scipy and matplotlib come with the commands that need them)."""
import json
import os
import sys

from .common import UsageError, check_output, input_files
from ..graph.errors import PatchError
from ..graph.patch import load
from ..graph.program import PlanError
from ..graph.registry import Registry
from ..graph.schema import patch_schema


def cmd_schema(args):
    print(json.dumps(patch_schema(Registry()), indent=2))
    return 0


def describe_block(cls, origin):
    inputs, outputs = cls.ports(cls.default_params())
    return {
        "type": cls.type_name,
        "origin": origin,
        "equation": (cls.__doc__ or "").strip().splitlines()[0] if cls.__doc__ else "",
        "inputs": [p.name for p in inputs],
        "outputs": [p.name for p in outputs],
        "params": {n: {"kind": p.kind, "default": list(p.default) if p.kind == "list" else p.default,
                       "unit": p.unit, "minimum": p.minimum, "maximum": p.maximum, "above": p.above,
                       "below": p.below, "live": p.live, "choices": list(p.choices) if p.choices else None,
                       "doc": p.doc}
                   for n, p in cls.params.items()},
        "states": [s.attr for s in cls.states],
        "feedthrough": sorted(cls.feedthrough()),
    }


def cmd_blocks(args):
    registry = Registry()
    if args.patch:
        registry = load(args.patch).registry
    if args.markdown:
        from ..reference import block_reference
        sys.stdout.write(block_reference(None if not args.patch else registry))
        return 0
    rows = [describe_block(registry.types[n], registry.origin[n]) for n in sorted(registry.types)]
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    for r in rows:
        ins = ", ".join(r["inputs"] + [f"{n}*" for n, p in r["params"].items() if p["live"]])
        print(f"{r['type']}: {ins or '-'} -> {', '.join(r['outputs']) or '-'}")
        print(f"    {r['equation']}")
        for n, p in r["params"].items():
            unit = f" {p['unit']}" if p["unit"] else ""
            print(f"    {n} = {p['default']!r}{unit}{'  (live)' if p['live'] else ''}")
    print("(* a live parameter, also an input port)")
    return 0


def cmd_check(args):
    patch = load(args.patch, overrides=args.overrides)
    origin = patch.registry.origin
    plugins = set(patch.registry.plugin_files)          # every file a `plugins:` entry imported
    plugins |= {os.path.realpath(sys.modules[inst.cls.__module__].__file__) for inst in patch.blocks.values()
                if origin.get(inst.cls.type_name) != "built-in"
                and getattr(sys.modules.get(inst.cls.__module__), "__file__", None)}  # installed plugins used
    if any(origin.get(inst.cls.type_name) != "built-in" for inst in patch.blocks.values()):
        # plugins are the only code a patch runs: each plugin block is compiled on its own here, so
        # a body numba cannot compile fails `check` at the plugin's line, not `run` in another block
        from ..graph.isolate import plugin_problems
        problems = plugin_problems(patch)
        if problems:
            raise PatchError(problems)
    print(f"{args.patch}: ok: {len(patch.blocks)} blocks, {len(patch.connections)} connections at "
          f"{patch.rate:g} Hz; schedule: {' -> '.join(patch.order)}")
    for path in sorted(plugins):
        print(f"  plugins run: {os.path.basename(path)} ({path})")
    return 0


def cmd_graph(args):
    from ..graph.diagram import to_dot, to_mermaid
    patch = load(args.patch)
    out = check_output("-o", args.out, input_files(patch), "command") if args.out else None
    text = (to_dot if args.format == "dot" else to_mermaid)(patch)
    if out:
        with open(out, "w", encoding="utf-8") as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    return 0


def cmd_modes(args):
    """The lowest modes of each network: K φ = ω² M φ (locked cells removed, damping ignored),
    sounding at f = (fs/π)·asin(ω/(2 fs)) under the half-step scheme; rigid modes print as 0 Hz."""
    from ..graph.modes import BudgetError, network_modes
    if args.count < 1:
        raise UsageError("--count must be at least 1")
    patch = load(args.patch, overrides=args.overrides)
    try:
        nets = network_modes(patch, args.count)
    except BudgetError as exc:            # the count past the memory budget: the largest that fits
        raise UsageError(f"--count {args.count}: {exc}") from None
    if args.json:
        print(json.dumps({"patch": args.patch, "rate": patch.rate, "networks": [m.as_dict() for m in nets]},
                         indent=2))
        return 0
    if not nets:
        print(f"{args.patch}: no mass-spring network")
        return 0
    for m in nets:
        print(f"{m.name}: {m.cells} moving cells, {m.locked} locked ({m.method}); half-step scheme at "
              f"{patch.rate:g} Hz, damping ignored")
        print(f"  {'mode':>4}  {'f [Hz]':>14}  {'continuous [Hz]':>15}  {'f/f1':>8}")
        first = next((f for f in m.frequencies if f > 0), None)
        for i, (f, fc) in enumerate(zip(m.frequencies, m.continuous), 1):
            ratio = f"{f / first:8.4f}" if first and f > 0 else f"{'rigid' if f == 0 else '-':>8}"
            print(f"  {i:4d}  {f:14.6f}  {fc:15.6f}  {ratio}")
        for note in m.notes:
            print(f"  note: {note}")
    return 0


def cmd_plot(args):
    from .. import plot
    try:
        plot.pyplot()                 # before any work: without matplotlib, one line and exit 1
    except plot.MatplotlibMissing as exc:
        print(f"hapticgraph: {exc}", file=sys.stderr)
        return 1
    if args.mode is not None and args.mode < 1:
        raise UsageError(f"--mode {args.mode}: modes are numbered from 1 (the lowest), as "
                         f"`hapticgraph modes` lists them")
    patch = load(args.patch, overrides=args.overrides)
    check_output("-o", args.out, input_files(patch), "command")
    if args.mode is not None or args.lattice:
        return _plot_mode(args, patch, plot)
    return _plot_render(args, patch, plot)


def _mode_blocks(patch):
    """The blocks whose modes `plot --mode` can draw: the bodies of fused groups with a linear
    model (lattices and cells)."""
    from ..graph.modes import mode_blocks
    return mode_blocks(patch)


def _plot_mode(args, patch, plot):
    from ..graph.modes import mode_shape
    lattices = _mode_blocks(patch)
    name = args.lattice or (lattices[0] if lattices else None)
    if name is None:
        raise UsageError("--mode: the patch has no lattice or cell block")
    mode = args.mode or 1
    try:
        freq, shape = mode_shape(patch, name, mode)
    except ValueError as exc:
        raise UsageError(f"--mode: {exc}") from None
    plot.plot_mode(freq, shape, args.out, title=args.title or f"{patch.name}: {name}, mode {mode}:")
    print(f"{args.patch}: {name} mode {mode} at {freq:.2f} Hz -> {args.out}")
    return 0


def _plot_render(args, patch, plot):
    from .. import render
    spec = None if args.spectrogram == "none" else args.spectrogram
    probes = list(args.probe)
    if spec not in (None, "audio") and spec not in probes:
        probes.append(spec)
    try:
        result = render(patch, args.seconds, probes=probes, progress=False)
    except PlanError as exc:
        raise UsageError(str(exc)) from None
    if spec == "audio" and not result.audio.shape[1]:
        spec = probes[0] if probes else None
    if not probes and spec is None:
        raise UsageError("nothing to draw: give --probe or a patch with audio_out")
    plot.plot_render(result, list(args.probe), args.out, title=args.title or patch.name,
                     window=tuple(args.window) if args.window else None, spectrogram=spec, patch=patch)
    print(f"{args.patch}: {len(args.probe)} trace(s){' and a spectrogram' if spec else ''} -> {args.out}")
    return 0
