"""The system's C compiler, as an export builds with it: `$CC` (default `cc`), C99, -O2,
`-ffp-contract=off` so that no multiply-add is fused (the kernel's arithmetic rounds as numba's
does, operation by operation), and `-fno-math-errno`: the same numbers, but a `sin` of a value
that does not change in the loop may be computed once, as numba's LLVM computes it."""
import os
import shlex
import shutil
import subprocess

FLAGS = ("-std=c99", "-O2", "-ffp-contract=off", "-fno-math-errno")


class ExportError(Exception):
    """An export that could not be built (no compiler, a compiler error, no LV2 headers)."""


def compiler():
    """The C compiler's command (a list): $CC, else `cc`; ExportError if there is none."""
    command = shlex.split(os.environ.get("CC") or "cc")
    if not command or shutil.which(command[0]) is None:
        raise ExportError(f"no C compiler: {command[0] if command else '$CC'!r} is not on PATH (set CC, or install one: "
                          "apt-get install gcc)")
    return command


def build(sources, output, extra=(), shared=False):
    """Compile `sources` into `output` (a shared library when `shared`); ExportError with the
    compiler's message if it fails."""
    command = compiler() + list(FLAGS) + (["-shared", "-fPIC"] if shared else []) + [str(s) for s in sources]
    command += ["-o", str(output)] + list(extra) + ["-lm"]
    proc = subprocess.run(command, capture_output=True, text=True)
    if proc.returncode != 0:
        raise ExportError(f"{' '.join(command)} failed:\n{proc.stderr.strip()}")
    return output


def write_sources(folder, files):
    """Write {file name: text} into `folder` (made if needed); their paths, in that order."""
    os.makedirs(folder, exist_ok=True)
    paths = []
    for file, text in files.items():
        path = os.path.join(folder, file)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        paths.append(path)
    return paths


__all__ = ["ExportError", "FLAGS", "build", "compiler", "write_sources"]
