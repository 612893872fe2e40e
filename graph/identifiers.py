"""What may reach a kernel's source as text: identifiers, literals and comments (code generation's
bottom layer; graph/ir.py, graph/codegen.py and every schedule item spell their code with these).

The source holds no text from a patch: only identifiers the compiler makes (slot numbers, names
reduced to [A-Za-z0-9_] and made unique), names of Python modules, classes and functions (each
matched whole as an identifier), numbers it formats, and comments reduced to [A-Za-z0-9_]. A
file name or block name cannot become code.
"""
import builtins
import keyword
import math
import re

_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_DOTTED = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*")
_BUILTINS = frozenset(dir(builtins))


class KernelSourceError(TypeError):
    """A name that would reach the generated source is not a plain identifier."""


def ident(name, what):
    """`name` if it is an ASCII identifier matched whole, else KernelSourceError."""
    if not isinstance(name, str) or not _IDENT.fullmatch(name):
        raise KernelSourceError(f"{what} {name!r} is not a plain identifier; it cannot be compiled")
    return name


def dotted(name, what):
    """`name` if it is a dotted name of identifiers (a module, a nested class), else KernelSourceError."""
    if not isinstance(name, str) or not _DOTTED.fullmatch(name):
        raise KernelSourceError(f"{what} {name!r} is not a dotted identifier; it cannot be compiled")
    return name


def note(text, limit=60):
    """Text for a comment of the kernel: every character outside [A-Za-z0-9_] becomes `_`."""
    return "".join(c if c.isascii() and (c.isalnum() or c == "_") else "_" for c in str(text)[:limit])


def comment(text, limit=80):
    """Text for a comment the compiler composes (`loop: line ring mask`): as `note`, but spaces
    and `:,.=-` are kept; nothing can end the line."""
    return "".join(c if c.isascii() and (c.isalnum() or c in "_ :,.=-") else "_" for c in str(text)[:limit])


def lit(v):
    """A Python literal for a static value (numba reads it as a compile-time constant)."""
    if isinstance(v, bool):
        return "True" if v else "False"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "math.nan"
        if math.isinf(v):
            return "math.inf" if v > 0 else "-math.inf"
        return repr(v)
    if isinstance(v, str):
        # spelled as code points, so no text of a patch is pasted into the source
        return '"' + "".join(f"\\U{ord(c):08x}" for c in v) + '"'
    if isinstance(v, tuple):
        return "(" + "".join(lit(float(x)) + ", " for x in v) + ")"
    raise TypeError(f"no literal for {v!r}")


# names the kernel module defines or reads besides the patch's locals
KERNEL_NAMES = frozenset({"math", "np", "numba", "kernel", "t", "t0", "i", "n", "state", "live", "coef",
                          "rec", "ext", "jit", "collections", "kernel_guard"})


def _reserved(name):
    return keyword.iskeyword(name) or keyword.issoftkeyword(name) or name in _BUILTINS


def sanitize(text, limit=40):
    """An identifier made of `text`: every character outside [A-Za-z0-9_] becomes `_`; prefixed
    with `b_` if it is empty, starts with a digit, or is a keyword, a builtin or a kernel name."""
    name = note(text, limit)
    if not name or name[0].isdigit() or _reserved(name) or name in KERNEL_NAMES:
        name = "b_" + name
    return ident(name, "sanitized name")


class Names:
    """The kernel's names: a prefix per block (sanitized, unique among blocks) and locals built
    from it, each unique in the kernel (suffix _2, _3, ... on a clash) and never a reserved name."""

    def __init__(self, reserved=()):
        self.taken = set(KERNEL_NAMES) | set(reserved)
        self.prefixes = set()
        self.known = {}

    @staticmethod
    def _unique(base, taken):
        name, k = base, 2
        while name in taken or keyword.iskeyword(name) or name in _BUILTINS:
            name, k = f"{base}_{k}", k + 1
        taken.add(name)
        return name

    def prefix(self, key, text):
        """The identifier block `key` (named `text` in the patch) prefixes its locals with."""
        if ("prefix", key) not in self.known:
            self.known[("prefix", key)] = self._unique(sanitize(text), self.prefixes)
        return self.known[("prefix", key)]

    def local(self, key, prefix, attr):
        """The local `prefix_attr` (attr comes from Python declarations), the same for one key."""
        if key not in self.known:
            base = f"{ident(prefix, 'name prefix')}_{ident(attr, 'attribute')}"
            self.known[key] = self._unique(base, self.taken)
        return self.known[key]
