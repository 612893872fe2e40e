"""hapticgraph: physical-model haptic musical instruments, compiled to one single-sample kernel.

    import hapticgraph
    patch = hapticgraph.load("patches/karplus_strong.yaml")      # raises PatchError
    problems = hapticgraph.check("patches/karplus_strong.yaml")  # [] when the patch is fine
    result = hapticgraph.render(patch, seconds=1.0, probes=["loop.out"])
    result.audio, result.probes["loop.out"], result.rate

The names are imported when first used (PEP 562), so `import hapticgraph` and the command line's
`--help`, `check` and `graph` start without numba, scipy or sounddevice.
"""
import importlib
import importlib.machinery
import os
import sys
import warnings

from .graph.registry import provide_drivers as _provide_drivers

__version__ = "0.2.0.dev0"   # the one source: pyproject.toml reads it, `hapticgraph --version` prints it


def _device_drivers():
    """The one table of drivers (hapticgraph.devices.table, read from the entry-point group
    `hapticgraph.drivers`): what a patch's `devices:` entries may name. The loader (graph/)
    imports nothing from devices/; this top floor hands the table over, when a patch is loaded
    (imported then, to keep `import hapticgraph` light)."""
    from .devices.table import driver_kinds
    return driver_kinds()


_provide_drivers(_device_drivers)

# public name -> (module relative to this package, attribute)
_LAZY = {
    "Block": (".blocks", "Block"),
    "Buffer": (".blocks", "Buffer"),
    "In": (".blocks", "In"),
    "Out": (".blocks", "Out"),
    "Param": (".blocks", "Param"),
    "State": (".blocks", "State"),
    "helper": (".blocks", "helper"),
    "Patch": (".graph.patch", "Patch"),
    "Registry": (".graph.registry", "Registry"),
    "Render": (".graph.engine", "Render"),
    "Session": (".session", "Session"),
    "PatchError": (".graph.errors", "PatchError"),
    "Problem": (".graph.errors", "Problem"),
    "PlanError": (".graph.program", "PlanError"),
    "SafetyStop": (".graph.engine", "SafetyStop"),
    "DeviceError": (".devices", "DeviceError"),
    "open_drivers": (".devices", "open_drivers"),
}


# module paths that name a module of a package: `hapticgraph.features` is public (docs/sweeps.md, plugins
# register features through it); the others are the flat modules of 0.1.0, kept for one release
PUBLIC_MODULES = {"features": "hapticgraph.sweeps.features"}
MOVED = {
    **{f"cli_{m}": f"hapticgraph.cli.{m}" for m in ("common", "parser", "run", "play", "inspect", "sizes", "sweep")},
    **{f"sweep_{m}": f"hapticgraph.sweeps.{m}" for m in ("spec", "check", "files", "worker", "manifest")},
    "fitting": "hapticgraph.sweeps.fitting",
    "studio.cli": "hapticgraph.cli.studio",
}


class _Alias:
    """Imports `hapticgraph.NAME`, for a NAME of PUBLIC_MODULES or MOVED, as the very module it now
    is (one module object under both names; MOVED ones with a DeprecationWarning). A meta path
    finder and its own loader (importlib's protocol; importlib.abc is not imported for it: it
    brings importlib.resources and pathlib into every start)."""

    def __init__(self):
        self.specs = {}         # alias -> the spec of the module it names, while it is imported

    def find_spec(self, fullname, path=None, target=None):
        name = fullname.partition("hapticgraph.")[2]
        if fullname.startswith("hapticgraph.") and (name in PUBLIC_MODULES or name in MOVED):
            return importlib.machinery.ModuleSpec(fullname, self)
        return None

    def create_module(self, spec):
        name = spec.name.partition("hapticgraph.")[2]
        target = PUBLIC_MODULES.get(name) or MOVED[name]
        if name in MOVED:
            warnings.warn(f"{spec.name} is now {target}; the old name goes in the next release",
                          DeprecationWarning, stacklevel=2)   # warnings skips importlib's frames
        real = importlib.import_module(target)
        self.specs[spec.name] = real.__spec__    # the import system sets the alias's spec on it next
        return real

    def exec_module(self, module):
        module.__spec__ = self.specs.pop(module.__spec__.name)     # the module keeps its own spec


sys.meta_path.append(_Alias())


def __getattr__(name):
    if name in PUBLIC_MODULES or name in MOVED:
        return importlib.import_module(f"{__name__}.{name}")
    try:
        module, attr = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'hapticgraph' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module, __name__), attr)
    globals()[name] = value          # the next lookup is a plain attribute
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


def load(path, overrides=(), registry=None, drivers=None):
    """Load and check a patch file: a Patch, or PatchError listing every problem (`.problems`).

    `overrides` are "BLOCK.PARAM=VALUE" strings, as `--set` takes them; `drivers` (driver kinds,
    default: hapticgraph.devices') the drivers its `devices:` entries may name.
    """
    from .graph.patch import load as _load
    return _load(path, overrides=overrides, registry=registry, drivers=drivers)


def check(path, overrides=()):
    """Every problem of a patch file, as a list of Problem (`.file`, `.line`, `.message`); empty
    when the patch is fine. Nothing is compiled or run."""
    from .graph.errors import PatchError
    try:
        load(path, overrides=overrides)
    except PatchError as exc:
        return list(exc.problems)
    return []


def render(patch, seconds=1.0, probes=(), engine="compiled", progress=None, devices=None, drivers=None,
           safety=False, chunk=1 << 14, runaway=1e3):
    """Render a patch (a Patch or a path) offline to arrays: a Render with `.audio`
    (frames × channels, float64), `.probes` ({name: array}) and `.rate`.

    Devices run on their patch's drivers (the simulated device by default); `devices` maps a
    device name to another driver name, `drivers` to ready Driver objects. Raises PatchError for a
    bad patch, PlanError for a probe or device the patch cannot supply, SafetyStop (when
    `safety=True`) for a NaN, an infinity or a runaway.
    """
    from .devices import open_drivers
    from .graph.engine import render as _render
    if isinstance(patch, (str, os.PathLike)):
        patch = load(patch)
    if drivers is None:
        drivers = open_drivers(patch, devices)
    return _render(patch, seconds, probes=probes, engine=engine, progress=progress, drivers=drivers,
                   safety=safety, chunk=chunk, runaway=runaway)


def sweep(spec_or_path, out, client=None, **options):
    """Render every variant of a sweep file (or a loaded SweepSpec) on Dask into the folder `out`
    (manifest.csv, audio/); `client` a dask.distributed Client, else a local cluster. Returns the
    manifest's rows (a pandas DataFrame when pandas is installed). See hapticgraph.sweeps.sweep
    for the options (workers, scheduler, scheduler_file, resume, limit, progress)."""
    from .sweeps import sweep as _sweep
    return _sweep(spec_or_path, out, client=client, **options)


def fit(patch, target, axes, client=None, **options):
    """Find the values of `axes` ({"block.param": (min, max)} or an axes file) whose render of
    `patch` matches the recording `target`, on Dask; a FitResult (`.values`, `.distance`,
    `.patch_path`, `.rows`). See hapticgraph.sweeps.fit for the options."""
    from .sweeps import fit as _fit
    return _fit(patch, target, axes, client=client, **options)


__all__ = ["Block", "Buffer", "In", "Out", "Param", "State", "helper", "Patch", "Registry", "Render", "Session",
           "load", "check", "render", "sweep", "fit", "PatchError", "Problem", "PlanError", "SafetyStop", "DeviceError",
           "__version__"]
