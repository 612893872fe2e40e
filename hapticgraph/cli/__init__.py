"""The `hapticgraph` command line: `main(argv)` runs it and returns the exit status.

One module per family of commands: run.py (run), play.py (play, devices), inspect.py (check,
blocks, schema, graph, modes, plot), studio.py (studio), sweep.py (sweep, fit); parser.py declares
every argument, common.py holds what they share, main.py dispatches. A command's module is
imported once its arguments are parsed. The command line uses the packages below it (the
session, the studio, the sweeps); none of them imports it.
"""
from .main import COMMANDS, main

__all__ = ["COMMANDS", "main"]
