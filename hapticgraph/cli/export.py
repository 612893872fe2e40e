"""`hapticgraph export PATCH --to c|lv2|wasm --out DIR [--name NAME] [--set B.P=V] [--install]`:
the patch lowered to C99 (NAME.h, NAME.c), built into an LV2 bundle DIR/NAME.lv2/, or into
DIR/NAME.wasm with its AudioWorklet NAME.js and a page index.html (docs/export.md). A block that
cannot be lowered is refused at its FILE:LINE (exit 2, from main's PatchError); a wrong name is a
usage error (exit 2); a failed build one line on stderr (exit 1)."""
import re
import sys

from .common import UsageError
from ..export import ExportError, export


def cmd_export(args):
    if args.name is not None and not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", args.name):
        raise UsageError(f"--name {args.name!r}: a C identifier is expected (letters, digits, _)")
    if args.install and args.to != "lv2":
        raise UsageError("--install copies an LV2 bundle: use it with --to lv2")
    try:
        written = export(args.patch, args.to, args.out, name=args.name, overrides=args.overrides,
                         install=args.install)
    except ExportError as exc:
        print(f"hapticgraph: error: {exc}", file=sys.stderr)
        return 1
    for path in written:
        print(path)
    return 0


__all__ = ["cmd_export"]
