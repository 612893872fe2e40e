"""Where block types come from: the built-ins, installed plugin packages (entry-point group
`hapticgraph.blocks`) and a patch's own `plugins:` (a module name or a `.py` file beside it);
and the device driver kinds a patch's `devices:` entries may name, which graph/ never names
itself: the caller passes them (`Registry(drivers=...)`), or the top floor installs the default
table once with `provide_drivers` (hapticgraph/__init__.py hands over hapticgraph.devices').

A driver kind is an object with
    name        the value of `driver:` that selects it
    default     true for the one kind used by an entry with no `driver:` key
    settings()  the keys of its entry besides `driver`, key -> JSON Schema
    required    keys its entry must have; closed: true if other keys are refused
    check(name, spec, base, problems)   what the schema cannot check (`base`: the patch's folder;
                problems: a Collector); it may attach what it parsed to `spec`
    axes(spec)  the device's extra columns (axes, buttons): output ports of the block bound to it
and optionally
    sections()  top-level sections of a patch it adds, key -> JSON Schema (the controllers' `map:`)
    prepare(doc, registry, problems) -> doc   its checks and shorthands, after the schema and
                the device checks, before the blocks are made (`map:` entries become blocks)
Everything else about a driver (opening it, simulating, replaying) is devices/' business.

Importing this module is light (no block library): the top floor imports it at start-up."""
import hashlib
import importlib
import importlib.util
import os
import sys
import threading
import traceback
from types import ModuleType

ENTRY_POINT_GROUP = "hapticgraph.blocks"
_DRIVER_PROVIDERS = []   # callables returning {name: driver kind}; see provide_drivers


class RegistryError(Exception):
    pass


def provide_drivers(provider):
    """Install `provider()` -> {name: driver kind}: the kinds a Registry made without `drivers`
    knows. Called once by the top floor; the provider is called when a Registry is made."""
    if provider not in _DRIVER_PROVIDERS:
        _DRIVER_PROVIDERS.append(provider)


def default_drivers():
    """The driver kinds every provider offers, by name (empty if none was installed)."""
    kinds = {}
    for provider in _DRIVER_PROVIDERS:
        kinds.update(provider())
    return kinds


def driver_table(drivers):
    """Driver kinds (an iterable, or a name -> kind mapping) by name."""
    return {kind.name: kind for kind in (drivers.values() if isinstance(drivers, dict) else drivers)}


def block_types_in(obj):
    """Block types a plugin offers: a Block subclass itself, or every one a module defines."""
    from ..blocks import Block
    if isinstance(obj, type) and issubclass(obj, Block):
        return [obj]
    if isinstance(obj, ModuleType):
        return [v for v in vars(obj).values()
                if isinstance(v, type) and issubclass(v, Block) and v.__module__ == obj.__name__
                and v.type_name]
    raise RegistryError(f"{obj!r} is neither a module nor a Block subclass")


class Registry:
    """Block types by name; `origin[name]` says where each came from; `drivers`: the device
    driver kinds by name (the given ones, else those installed with provide_drivers)."""

    def __init__(self, entry_points=True, drivers=None):
        from ..blocks import builtin_types
        self.drivers = default_drivers() if drivers is None else driver_table(drivers)
        self.types = dict(builtin_types())
        self.origin = {name: "built-in" for name in self.types}
        self.plugin_files = {}   # absolute path -> how the patch named it: the code a patch runs
        if entry_points:
            import importlib.metadata     # here, not at import: the top floor imports this module at start-up
            for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
                try:
                    module = ep.load()
                    self.add(block_types_in(module), f"entry point {ep.name} ({ep.value})")
                except KeyboardInterrupt:
                    raise
                except BaseException as exc:  # noqa: BLE001 - a broken (or exiting) plugin must not hide the rest
                    print(f"hapticgraph: warning: plugin entry point {ep.name!r} failed to load: "
                          f"{type(exc).__name__}: {exc}", file=sys.stderr)

    def lookup(self, kind):
        """The block type a patch's `type:` value names, or None (unknown, or not text at all: a
        patch may say `type: []`)."""
        return self.types.get(kind) if isinstance(kind, str) else None

    def add(self, types, origin):
        for cls in types:
            known = self.types.get(cls.type_name)
            if known is not None and known is not cls:
                raise RegistryError(f"block type {cls.type_name!r} from {origin} is already defined "
                                    f"by {self.origin[cls.type_name]}")
            self.types[cls.type_name] = cls
            self.origin[cls.type_name] = origin

    def load_plugin(self, spec, base_dir):
        """Load one `plugins:` entry: a `.py` path (relative to the patch) or an importable module."""
        if spec.endswith(".py") or os.sep in spec or "/" in spec:
            path = os.path.normpath(os.path.join(base_dir, spec))
            if not os.path.isfile(path):
                raise RegistryError(f"plugin file {spec!r} not found (looked for {os.path.basename(path)} "
                                    "beside the patch)")
            module = import_file(path)
        else:
            try:
                module = importlib.import_module(spec)
            except ImportError as exc:
                raise RegistryError(f"plugin module {spec!r} cannot be imported: {exc}") from None
            except KeyboardInterrupt:
                raise
            except BaseException as exc:  # noqa: BLE001 - sys.exit() or any error in a plugin is the plugin's fault
                raise RegistryError(f"plugin module {spec!r} failed to import{_where(exc, None)}: "
                                    f"{_describe(exc)}") from None
        types = block_types_in(module)
        if not types:
            raise RegistryError(f"plugin {spec!r} defines no block types")
        self.add(types, f"plugin {spec!r}")
        path = getattr(module, "__file__", None)
        if path:
            self.plugin_files[os.path.realpath(path)] = spec
        return types


def _describe(exc):
    if isinstance(exc, SystemExit):
        return f"it called sys.exit({exc.code!r})"
    return f"{type(exc).__name__}: {exc}"


def _where(exc, path):
    """` (FILE:LINE)`: the innermost frame of the plugin (of `path`, or any file but ours)."""
    frames = traceback.extract_tb(exc.__traceback__)
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    for frame in reversed(frames):
        name = os.path.realpath(frame.filename)
        if (path and name == path) or (not path and not name.startswith(here) and "importlib" not in name):
            return f" ({os.path.basename(name)}:{frame.lineno})"
    return ""


def _digest(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def import_file(path):
    """Import a plugin file under a stable module name, so generated kernels can import it too.

    The name holds only [A-Za-z0-9_]. A file already imported is imported again when its content
    changed (an edited plugin is never served stale, e.g. by `play --watch`). One thread imports
    at a time: the module is in sys.modules while its file runs, and another thread (a Dask worker
    of two threads loading the same patch) must not take it half made.
    """
    with _IMPORTING:
        return _import_file(path)


_IMPORTING = threading.RLock()      # a plugin's file may load another (RLock: the same thread again)


def _import_file(path):
    path = os.path.realpath(path)
    stem = os.path.splitext(os.path.basename(path))[0]
    digest = hashlib.sha1(path.encode("utf-8", "surrogatepass")).hexdigest()[:10]
    name = f"hapticgraph_plugin_{''.join(c if c.isascii() and c.isalnum() else '_' for c in stem)}_{digest}"
    try:
        content = _digest(path)
    except OSError as exc:
        raise RegistryError(f"plugin file {os.path.basename(path)!r} cannot be read: {exc.strerror or exc}") from None
    module = sys.modules.get(name)
    if (module is not None and getattr(module, "__file__", None) == path
            and getattr(module, "__hapticgraph_digest__", None) == content):
        return module
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    module.__hapticgraph_digest__ = content
    previous = sys.modules.get(name)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except KeyboardInterrupt:
        _restore(name, previous)
        raise
    except BaseException as exc:  # noqa: BLE001 - sys.exit() or any error in a plugin is the plugin's fault
        _restore(name, previous)
        raise RegistryError(f"plugin file {os.path.basename(path)!r} failed to import{_where(exc, path)}: "
                            f"{_describe(exc)}") from None
    return module


def _restore(name, previous):
    if previous is None:
        sys.modules.pop(name, None)
    else:
        sys.modules[name] = previous
