"""The static import graph of the four packages (hapticgraph/, blocks/, graph/, devices/): every
import statement, those inside functions included, read from the source (nothing is imported).

    python tools/imports.py            # cycles and cross-module `_private` imports; exit 1 if any
    python tools/imports.py --edges    # every edge between our modules as well

A cycle is a strongly connected component of the graph of our modules (more than one module, or
one that imports itself). A private import is a name starting with one underscore (not a dunder)
that a module takes from another of our modules (`from .kcache import _compile`), or reads as an
attribute of one it imported (`kernel._loaded`). An alias (`import x as _x`) is the importer's
own name and is not counted.
"""
import argparse
import ast
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
# folder -> package name (pyproject.toml's package-dir)
PACKAGES = {"hapticgraph": "hapticgraph", "blocks": "hapticgraph.blocks", "graph": "hapticgraph.graph",
            "devices": "hapticgraph.devices"}


def module_files(root=ROOT, packages=PACKAGES):
    """{module name: path} of every module of the packages (subpackages included)."""
    out = {}
    for folder, package in packages.items():
        base = root / folder
        for path in sorted(base.rglob("*.py")):
            parts = list(path.relative_to(base).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join([package] + parts)] = path
    return out


def _is_package(path):
    return path.name == "__init__.py"


def _resolve(importer, is_package, level, module):
    """The absolute name of `from <level dots><module> import ...` in `importer`."""
    if level == 0:
        return module
    base = importer.split(".") if is_package else importer.split(".")[:-1]
    base = base[:len(base) - (level - 1)]
    return ".".join(base + ([module] if module else []))


def _private(name):
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def imports(name, path, known):
    """[(imported module, line, [names taken])] of one module, and the module aliases it binds
    ({local name: module}) for attribute reads."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found, aliases = [], {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                target = a.name
                while target and target not in known:
                    target = target.rpartition(".")[0]
                if target:
                    found.append((target, node.lineno, []))
                    if a.asname:
                        aliases[a.asname] = a.name
        elif isinstance(node, ast.ImportFrom):
            source = _resolve(name, _is_package(path), node.level, node.module)
            for a in node.names:
                sub = f"{source}.{a.name}"
                if sub in known:           # `from . import kernel`: the submodule
                    found.append((sub, node.lineno, []))
                    aliases[a.asname or a.name] = sub
                elif source in known:
                    found.append((source, node.lineno, [a.name]))
    return found, aliases, tree


def _attribute_reads(tree, aliases, known):
    """(module, line, attribute) of every `alias._private` read of one of our modules."""
    out = []
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                and aliases.get(node.value.id) in known and _private(node.attr)):
            out.append((aliases[node.value.id], node.lineno, node.attr))
    return out


def graph(root=ROOT, packages=PACKAGES):
    """({module: {imported module: first line}}, [(importer, line, module, private name)])."""
    files = module_files(root, packages)
    edges, private = {m: {} for m in files}, []
    for name, path in files.items():
        found, aliases, tree = imports(name, path, files)
        for target, line, names in found:
            if target != name:
                edges[name].setdefault(target, line)
            private += [(name, line, target, n) for n in names if _private(n) and target != name]
        private += [(name, line, target, attr) for target, line, attr in _attribute_reads(tree, aliases, files)
                    if target != name]
    return edges, private


def cycles(edges):
    """Strongly connected components with more than one module (Tarjan's algorithm), each sorted."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        todo = [(v, iter(sorted(edges.get(v, ()))))]
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        while todo:
            node, children = todo[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    todo.append((w, iter(sorted(edges.get(w, ())))))
                    break
                if w in on:
                    low[node] = min(low[node], index[w])
            else:
                todo.pop()
                if todo:
                    low[todo[-1][0]] = min(low[todo[-1][0]], low[node])
                if low[node] == index[node]:
                    scc = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        scc.append(w)
                        if w == node:
                            break
                    if len(scc) > 1:
                        out.append(sorted(scc))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return sorted(out)


def package_of(module, packages=PACKAGES):
    """The one of our packages a module belongs to (the longest matching name)."""
    names = sorted(packages.values(), key=len, reverse=True)
    return next(p for p in names if module == p or module.startswith(p + "."))


def report(root=ROOT, packages=PACKAGES):
    """{package: {"cycles": [[modules]], "private": [(importer, line, module, name)]}}: a cycle is
    told under every package one of its modules belongs to."""
    edges, private = graph(root, packages)
    out = {p: {"cycles": [], "private": []} for p in packages.values()}
    for scc in cycles(edges):
        for p in sorted({package_of(m, packages) for m in scc}):
            out[p]["cycles"].append(scc)
    for item in private:
        out[package_of(item[0], packages)]["private"].append(item)
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--edges", action="store_true", help="list every edge between our modules")
    args = parser.parse_args(argv)
    if args.edges:
        edges, _ = graph()
        for a in sorted(edges):
            for b, line in sorted(edges[a].items()):
                print(f"{a}:{line} -> {b}")
    bad = 0
    for package, found in report().items():
        mods = sorted({m for scc in found["cycles"] for m in scc if package_of(m) == package})
        print(f"{package}: {len(found['cycles'])} cycle(s) through {len(mods)} of its modules, "
              f"{len(found['private'])} private import(s)")
        for scc in found["cycles"]:
            print("  cycle: " + " ".join(scc))
        for importer, line, module, attr in found["private"]:
            print(f"  private: {importer}:{line} takes {module}.{attr}")
        bad += len(found["cycles"]) + len(found["private"])
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
