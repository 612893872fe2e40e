"""Module and function sizes: every module over MAX_MODULE lines and every function over
MAX_FUNCTION lines in the given folders (default: blocks/, graph/, devices/, hapticgraph/).

    python tools/sizes.py                 # the over-limit list; exit 1 when there is one
    python tools/sizes.py --all devices   # every module and its longest function, largest first

A function's length is its source lines from `def` (decorators excluded) to its last line,
docstring and comments included: what a reader has to take in at once.
"""
import argparse
import ast
import pathlib
import sys

MAX_MODULE = 400
MAX_FUNCTION = 50
ROOT = pathlib.Path(__file__).resolve().parent.parent
FOLDERS = ("blocks", "graph", "devices", "hapticgraph")


def module_lines(path):
    return len(path.read_text(encoding="utf-8").splitlines())


def functions(path):
    """(qualified name, first line, length) of every function and method in a module."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found = []

    def walk(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = f"{prefix}{child.name}"
                found.append((name, child.lineno, child.end_lineno - child.lineno + 1))
                walk(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                walk(child, f"{prefix}{child.name}.")
            else:
                walk(child, prefix)

    walk(tree, "")
    return found


def modules(folders, root=ROOT):
    for folder in folders:
        yield from sorted((root / folder).rglob("*.py"))


def over_limits(folders=FOLDERS, root=ROOT, max_module=MAX_MODULE, max_function=MAX_FUNCTION):
    """Lists of (path, lines) for modules and (path:line name, lines) for functions over the limits."""
    big_modules, big_functions = [], []
    for path in modules(folders, root):
        rel = path.relative_to(root).as_posix()
        lines = module_lines(path)
        if lines > max_module:
            big_modules.append((rel, lines))
        for name, line, length in functions(path):
            if length > max_function:
                big_functions.append((f"{rel}:{line} {name}", length))
    return big_modules, big_functions


def table(folders, root=ROOT):
    """Every module with its line count and its longest function, largest module first."""
    rows = []
    for path in modules(folders, root):
        longest = max(functions(path), key=lambda f: f[2], default=("-", 0, 0))
        rows.append((module_lines(path), path.relative_to(root).as_posix(), longest[0], longest[2]))
    return sorted(rows, reverse=True)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="*", default=list(FOLDERS))
    parser.add_argument("--all", action="store_true", help="list every module and its longest function")
    args = parser.parse_args(argv)
    if args.all:
        for lines, rel, name, length in table(args.folders):
            print(f"{lines:5d}  {rel:32s} {length:4d}  {name}")
        return 0
    big_modules, big_functions = over_limits(args.folders)
    for rel, lines in big_modules:
        print(f"module   {lines:5d} lines  {rel}  (limit {MAX_MODULE})")
    for where, lines in big_functions:
        print(f"function {lines:5d} lines  {where}  (limit {MAX_FUNCTION})")
    return 1 if big_modules or big_functions else 0


if __name__ == "__main__":
    sys.exit(main())
