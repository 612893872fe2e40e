"""Special cases: string literals in the given folders that equal a built-in block type's name or
a port name (docstrings aside). `python tools/literals.py graph` — issue "One IR" wants none in
graph/ outside block declarations."""
import ast
import pathlib
import sys


def names():
    from hapticgraph.blocks import builtin_types
    types = builtin_types()
    ports = {p.name for cls in types.values() for p in list(cls.inputs) + list(cls.outputs)}
    return set(types), ports | {"position", "velocity", "force"}


def hits(folders):
    types, ports = names()
    out = []
    for folder in folders:
        for path in sorted(pathlib.Path(folder).glob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            docs = {id(n.body[0].value) for n in ast.walk(tree)
                    if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef)) and n.body
                    and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)}
            out += [(str(path), n.lineno, n.value) for n in ast.walk(tree)
                    if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docs
                    and (n.value in types or n.value in ports)]
    return out


if __name__ == "__main__":
    found = hits(sys.argv[1:] or ["graph"])
    for path, line, text in found:
        print(f"{path}:{line}: {text!r}")
    print(f"{len(found)} literal(s)")
