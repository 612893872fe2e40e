"""The one table of drivers: the driver kinds registered in the entry-point group
`hapticgraph.drivers` (name -> a DriverKind subclass) and the input kinds in
`hapticgraph.inputs` (a block type fed from outside -> an InputKind subclass). hapticgraph's own
drivers are registered there the same way as a plugin package's (pyproject.toml,
`[project.entry-points."hapticgraph.drivers"]`). The loader (through hapticgraph/__init__.py),
`--device`, `hapticgraph devices` and the drivers all read this table; it is read once per
process.

A source checkout whose installed metadata predates the groups (an editable install made before
they existed) reads hapticgraph's own entries from its pyproject.toml instead; a plugin that fails
to load, is not a kind, or takes a name already taken is skipped with a warning on stderr.
"""
import functools
import importlib.metadata
import pathlib
import sys

from .driver_kind import DriverKind, InputKind

DRIVER_GROUP = "hapticgraph.drivers"
INPUT_GROUP = "hapticgraph.inputs"
PYPROJECT = pathlib.Path(__file__).resolve().parent.parent / "pyproject.toml"


class Entry:
    """One registered kind: `kind` (the instance), `origin` (the package and `module:attr`)."""

    def __init__(self, kind, origin):
        self.kind, self.origin = kind, origin


@functools.cache
def _installed():
    """Every installed entry point, in one scan: importlib.metadata reads every distribution's
    entry points for each call, so both groups are read at once."""
    return importlib.metadata.entry_points()


_names = {}             # id(distribution) -> (distribution, its name): its metadata parsed once


def _ours(ep):
    dist = ep.dist
    if dist is None:
        return False
    known = _names.get(id(dist))
    if known is None or known[0] is not dist:
        known = _names[id(dist)] = (dist, dist.name)
    return known[1] == "hapticgraph"


def _source_entry_points(group):
    """hapticgraph's own entries of `group` as its pyproject.toml declares them (a checkout)."""
    if not PYPROJECT.is_file():
        return []
    try:
        import tomllib
    except ImportError:                  # Python 3.10: tomli, when installed
        try:
            import tomli as tomllib
        except ImportError:
            return []
    with open(PYPROJECT, "rb") as f:
        table = tomllib.load(f).get("project", {}).get("entry-points", {}).get(group, {})
    return [importlib.metadata.EntryPoint(name, value, group) for name, value in table.items()]


def entry_points(group):
    """[(entry point, origin)] of `group`, hapticgraph's own first."""
    found = list(_installed().select(group=group))
    ours = sorted([ep for ep in found if _ours(ep)] or _source_entry_points(group), key=lambda ep: ep.name)
    others = sorted((ep for ep in found if not _ours(ep)), key=lambda ep: ep.name)
    return ([(ep, f"hapticgraph ({ep.value})") for ep in ours]
            + [(ep, f"{ep.dist.name if ep.dist is not None else 'a package'} ({ep.value})") for ep in others])


def _warn(ep, what):
    print(f"hapticgraph: warning: driver entry point {ep.name!r} ({ep.value}) {what}; skipped", file=sys.stderr)


def _load(group, base, named=True):
    """{name: Entry} of the kinds registered in `group` (each a subclass of `base`; `named`: its
    `name` is the entry point's, the name a patch gives it)."""
    table = {}
    for ep, origin in entry_points(group):
        try:
            cls = ep.load()
        except KeyboardInterrupt:
            raise
        except BaseException as exc:  # noqa: BLE001 - a broken plugin must not hide the other drivers
            _warn(ep, f"failed to load: {type(exc).__name__}: {exc}")
            continue
        if not (isinstance(cls, type) and issubclass(cls, base)):
            _warn(ep, f"is not a {base.__name__} subclass")
        elif named and cls.name != ep.name:
            _warn(ep, f"names a kind called {cls.name!r}")
        elif ep.name in table:
            _warn(ep, f"takes the name of {table[ep.name].origin}")
        else:
            table[ep.name] = Entry(cls(), origin)
    return table


@functools.cache
def _drivers():
    return _load(DRIVER_GROUP, DriverKind)


@functools.cache
def _inputs():
    return _load(INPUT_GROUP, InputKind, named=False)


def driver_kinds():
    """The device drivers, name -> kind (a new dict; the kinds are shared)."""
    return {name: entry.kind for name, entry in _drivers().items()}


def driver_origins():
    """The device drivers, name -> where each comes from (for `hapticgraph devices`)."""
    return {name: entry.origin for name, entry in _drivers().items()}


def input_kinds():
    return tuple(entry.kind for entry in _inputs().values())


def kinds_of(patch):
    """The driver kinds a patch was loaded with (the table's, if it was given none)."""
    return patch.registry.drivers or driver_kinds()


def input_kind(cls):
    """The kind that feeds blocks of type `cls` from outside the patch, or None."""
    return next((k for k in input_kinds() if issubclass(cls, k.feeds)), None)


__all__ = ["DRIVER_GROUP", "INPUT_GROUP", "driver_kinds", "driver_origins", "entry_points", "input_kind",
           "input_kinds", "kinds_of"]
