"""Where block types come from: the built-ins, installed plugin packages (entry-point group
`hapticgraph.blocks`) and a patch's own `plugins:` (a module name or a `.py` file beside it)."""
import hashlib
import importlib
import importlib.metadata
import importlib.util
import inspect
import os
import sys

from ..blocks import Block, builtin_types

ENTRY_POINT_GROUP = "hapticgraph.blocks"


class RegistryError(Exception):
    pass


def block_types_in(obj):
    """Block types a plugin offers: a Block subclass itself, or every one a module defines."""
    if isinstance(obj, type) and issubclass(obj, Block):
        return [obj]
    if inspect.ismodule(obj):
        return [v for v in vars(obj).values()
                if isinstance(v, type) and issubclass(v, Block) and v.__module__ == obj.__name__
                and v.type_name]
    raise RegistryError(f"{obj!r} is neither a module nor a Block subclass")


class Registry:
    """Block types by name; `origin[name]` says where each came from."""

    def __init__(self, entry_points=True):
        self.types = dict(builtin_types())
        self.origin = {name: "built-in" for name in self.types}
        if entry_points:
            for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
                try:
                    self.add(block_types_in(ep.load()), f"entry point {ep.name} ({ep.value})")
                except Exception as exc:  # noqa: BLE001 - a broken installed plugin must not hide the rest
                    print(f"hapticgraph: warning: plugin entry point {ep.name!r} failed to load: {exc}",
                          file=sys.stderr)

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
        types = block_types_in(module)
        if not types:
            raise RegistryError(f"plugin {spec!r} defines no block types")
        self.add(types, f"plugin {spec!r}")
        return types


def import_file(path):
    """Import a plugin file under a stable module name, so generated kernels can import it too."""
    path = os.path.realpath(path)
    stem = os.path.splitext(os.path.basename(path))[0]
    digest = hashlib.sha1(path.encode()).hexdigest()[:10]
    name = f"hapticgraph_plugin_{''.join(c if c.isalnum() else '_' for c in stem)}_{digest}"
    module = sys.modules.get(name)
    if module is not None and getattr(module, "__file__", None) == path:
        return module
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except Exception as exc:
        del sys.modules[name]
        raise RegistryError(f"plugin file {os.path.basename(path)!r} failed to import: "
                            f"{type(exc).__name__}: {exc}") from None
    return module
