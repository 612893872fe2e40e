"""The `hapticgraph` command line.

Exit status: 0 on success, 2 for a patch error (one `FILE:LINE: message` line per problem on
standard error, never a traceback), 1 for any other failure, 130 when Ctrl-C stopped it (128 + the
signal's number: 143 for SIGTERM, 129 for SIGHUP, where a command takes them).

Ctrl-C at any moment, from the first line of `main` to the process's end, is one line on stderr
and no traceback (cli/common.py's Interrupt): a command running its patch stops at the next block
and says what it kept; elsewhere KeyboardInterrupt is raised once and `main` says
`hapticgraph: interrupted`; after that the process ends with os._exit, waiting for no thread. A
Ctrl-C once the command has finished ends the process at once with the command's status, and is
ignored in the interpreter's last moments (after its exit functions). Before `main` runs (the
interpreter starting, `import hapticgraph.cli`) Python's own handler reports it.

The arguments are declared in cli/parser.py; each command's body lives with the commands it
belongs with: cli/run.py (run: offline to files), cli/play.py (play, devices: the sound card and the
devices), cli/inspect.py (check, blocks, schema, graph, modes, plot), cli/studio.py (studio),
cli/sweep.py (sweep, fit); cli/common.py holds what they share. A command's module is imported after the
arguments are parsed, so `--help` (and a usage error) never imports numpy, numba or the blocks.
"""
import atexit
import gc
import importlib
import os
import signal
import sys

# light: the engine is imported once a command runs
from .common import Interrupt, UsageError
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
    interrupt = Interrupt()
    if argv is None:
        atexit.register(interrupt.settle)     # first registered: run last
    try:
        # taken inside the try: a signal the moment its handler is in place is caught below
        interrupt.take(signal.SIGINT)
        code = _main(argv, argv is None, interrupt)
    except KeyboardInterrupt:        # raised once (Interrupt): nothing interrupts this
        print("hapticgraph: interrupted", file=sys.stderr)
        code = interrupt.status()
    except SystemExit as exc:        # argparse: --help, --version or a usage error, printed already
        if argv is not None:
            raise
        code = 0 if exc.code is None else exc.code
    except Exception:
        # the KeyboardInterrupt, raised inside an import of a C extension (numpy's, the first
        # moments of `play`), came out as that import's ImportError: still the interrupt
        if not interrupt.raised:
            raise
        print("hapticgraph: interrupted", file=sys.stderr)
        code = interrupt.status()
    finally:
        if argv is not None:
            interrupt.give_back()
    if argv is None:
        _end(code, interrupt)
    return code


def _end(code, interrupt):
    """The end of the process: its output flushed, then — interrupted — os._exit at once (a thread
    still running is not waited for), else back to the interpreter with every later signal an
    os._exit of `code` (see Interrupt.finished)."""
    # the last garbage collection need not walk every object numba made (0.2-0.6 s after a
    # compile); every file was closed by the command
    gc.freeze()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):     # the reader has gone (a closed pipe): nothing to tell
            pass
    if interrupt.signum is not None:
        os._exit(code)
    interrupt.finished(code)


def _main(argv, whole_process, interrupt):
    args = _parser().parse_args(argv)
    args.interrupt = interrupt
    if whole_process and args.command in NO_BLAS:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    told = args.command in ("run", "play", "plot", "check") and not getattr(args, "quiet", False)
    if told:
        from ..graph import kernel
        kernel.set_notice(_compile_notice)     # a cold compile says so at once; a cache hit says nothing
    try:
        return _run(args)
    except PatchError as exc:
        for problem in exc.problems:
            print(problem, file=sys.stderr)
        return 2
    except UsageError as exc:
        print(f"hapticgraph: error: {exc}", file=sys.stderr)
        return 2
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


def _run(args):
    """The command's exit status. A failure once a signal has raised KeyboardInterrupt is that
    interrupt: Python hands some on as another exception (one raised in `__set_name__` becomes a
    RuntimeError), and what it left half done may fail after."""
    try:
        return _command(args.command)(args)
    except Exception:
        if args.interrupt.raised:
            raise KeyboardInterrupt from None
        raise


__all__ = ["COMMANDS", "PatchError", "UsageError", "main"]
