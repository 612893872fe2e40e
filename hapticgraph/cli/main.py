"""The `hapticgraph` command line.

Exit status: 0 on success, 2 for a patch error (one `FILE:LINE: message` line per problem on
standard error, never a traceback), 1 for any other failure.

The arguments are declared in cli/parser.py; each command's body lives with the commands it
belongs with: cli/run.py (run: offline to files), cli/play.py (play, devices: the sound card and the
devices), cli/inspect.py (check, blocks, schema, graph, modes, plot), cli/studio.py (studio),
cli/sweep.py (sweep, fit); cli/common.py holds what they share. A command's module is imported after the
arguments are parsed, so `--help` (and a usage error) never imports numpy, numba or the blocks.
"""
import gc
import importlib
import os
import sys

# light: the engine is imported once a command runs
from .common import UsageError
from .parser import build_parser as _parser
from ..graph.errors import PatchError

# command -> (module of this package, function): imported when the command runs
COMMANDS = {
    "run": ("run", "cmd_run"),
    "play": ("play", "cmd_play"),
    "devices": ("play", "cmd_devices"),
    "check": ("inspect", "cmd_check"),
    "blocks": ("inspect", "cmd_blocks"),
    "schema": ("inspect", "cmd_schema"),
    "graph": ("inspect", "cmd_graph"),
    "plot": ("inspect", "cmd_plot"),
    "modes": ("inspect", "cmd_modes"),
    "studio": ("studio", "cmd_studio"),
    "sweep": ("sweep", "cmd_sweep"),
    "fit": ("sweep", "cmd_fit"),
    "export": ("export", "cmd_export"),
    "hid": ("hid", "cmd_hid"),
}


def _command(name):
    module, function = COMMANDS[name]
    return getattr(importlib.import_module(f".{module}", __package__), function)


# commands whose work calls no BLAS routine (the kernel never does): numpy need not start its
# BLAS library's thread pool when it is imported (0.09 s of `import numpy` on the 2-core VM),
# unless the user chose a thread count
NO_BLAS = ("run", "play", "check")


def _compile_notice(text):
    print(f"hapticgraph: {text}", file=sys.stderr, flush=True)


def main(argv=None):
    """Run the command line `argv` (None: this process's, which then ends when main returns); its
    exit status."""
    code = _main(argv, argv is None)
    if argv is None:
        # the process ends now: its last garbage collection need not walk every object numba made
        # (0.2-0.6 s after a compile); every file was closed by the command
        gc.freeze()
    return code


def _main(argv, whole_process):
    args = _parser().parse_args(argv)
    if whole_process and args.command in NO_BLAS:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    told = args.command in ("run", "play", "plot", "check") and not getattr(args, "quiet", False)
    if told:
        from ..graph import kernel
        kernel.set_notice(_compile_notice)     # a cold compile says so at once; a cache hit says nothing
    try:
        return _command(args.command)(args)
    except PatchError as exc:
        for problem in exc.problems:
            print(problem, file=sys.stderr)
        return 2
    except UsageError as exc:
        print(f"hapticgraph: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("hapticgraph: interrupted", file=sys.stderr)
        return 1
    except BrokenPipeError:          # e.g. `hapticgraph modes P | head`: the reader has gone
        sys.stderr.close()
        return 0
    except Exception as exc:  # noqa: BLE001 - the CLI never shows a traceback unless asked
        if os.environ.get("HAPTICGRAPH_DEBUG"):
            raise
        print(f"hapticgraph: error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    finally:
        if told:
            kernel.set_notice(None)


__all__ = ["COMMANDS", "PatchError", "UsageError", "main"]
