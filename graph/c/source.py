"""The Python source the C translator reads: the syntax tree of a function or a lambda, with the
lines of the file it is written in (a block's module, a plugin file), so that everything refused
is told at its FILE:LINE."""
import ast
import functools
import linecache

from .values import Refused


@functools.lru_cache(maxsize=32)
def _module_tree(filename, text):
    try:
        return ast.parse(text, filename=filename)
    except (SyntaxError, ValueError):
        return None


def where(fn):
    """(file, first line) of a Python function."""
    code = fn.__code__
    return code.co_filename, code.co_firstlineno


def tree_of(fn):
    """The `def` or `lambda` node of fn in its file's syntax tree (file line numbers); Refused
    when its source cannot be read."""
    code = getattr(fn, "__code__", None)
    if code is None:
        raise Refused("?", 1, f"{fn!r} is not a Python function; its source cannot be translated")
    linecache.checkcache(code.co_filename)
    lines = linecache.getlines(code.co_filename, fn.__globals__)
    if not lines and code.co_filename.startswith("<"):
        raise Refused(code.co_filename, code.co_firstlineno,
                      f"{fn.__qualname__} is made at run time from text that is not kept (linecache): "
                      "there is no source to translate")
    tree = _module_tree(code.co_filename, "".join(lines)) if lines else None
    if tree is None:
        raise Refused(code.co_filename, code.co_firstlineno, f"the source of {fn.__qualname__} cannot be read")
    names = code.co_varnames[:code.co_argcount]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name == code.co_name:
            first = min([node.lineno] + [d.lineno for d in node.decorator_list])
            if code.co_firstlineno in (first, node.lineno):
                found.append(node)
        elif isinstance(node, ast.Lambda) and code.co_name == "<lambda>" and node.lineno == code.co_firstlineno:
            if tuple(a.arg for a in node.args.args) == names:
                found.append(node)
    if len(found) != 1:
        raise Refused(code.co_filename, code.co_firstlineno,
                      f"{fn.__qualname__}: {'no' if not found else 'more than one'} matching definition on this line")
    node = found[0]
    if isinstance(node, ast.AsyncFunctionDef):
        raise Refused(code.co_filename, node.lineno, "an async function")
    return node


def argument_names(node):
    """The positional arguments of a def or lambda; Refused for *args, **kwargs, keyword-only ones."""
    a = node.args
    if a.vararg or a.kwarg or a.kwonlyargs or a.posonlyargs:
        raise ValueError("*args, **kwargs, keyword-only or positional-only arguments")
    return [x.arg for x in a.args], len(a.defaults)


__all__ = ["argument_names", "tree_of", "where"]
