"""Edits while playing, typed on standard input (`hapticgraph play --console`):

    set BLOCK.PARAM VALUE      a live parameter (e.g. `set plate.mass 0.002`)
    lock NAME[i, j]            a cell stops moving        unlock NAME[i, j]   it moves again
    cut NAME[i, j]             a cell leaves its lattice, with its springs

Each command is checked by the playing hapticgraph.Session, then queued and applied by the audio
thread at the next block boundary, without a recompile. Mistakes are reported and change nothing.
"""
import re
import sys
import threading

from .graph.errors import name_list, suggest

HELP = "commands: set BLOCK.PARAM VALUE | lock NAME[i, j] | unlock NAME[i, j] | cut NAME[i, j] | help"


def submit(line, session, done=None):
    """Ask `session` (a hapticgraph.Session) for the change one command line says; its text, or
    None for a blank line. ValueError with a message if the command is wrong or refused."""
    words = line.strip().split(None, 1)
    if not words:
        return None
    verb, rest = words[0].lower(), (words[1] if len(words) > 1 else "")
    if verb == "set":
        m = re.fullmatch(r"\s*([A-Za-z_]\w*)(?:\.([A-Za-z_]\w*))?\s*=?\s*(\S+)\s*", rest)
        if not m:
            raise ValueError("set BLOCK.PARAM VALUE")
        block, name, raw = m.groups()
        _check_live(session.program, block, name)
        try:
            value = float(raw)
        except ValueError:
            raise ValueError(f"{raw!r} is not a number") from None
        session.set(block, name, value, done)
        return f"{block}.{name} = {value:g}"
    cells = {"lock": session.lock, "unlock": session.unlock, "cut": session.cut}
    if verb in cells:
        if not rest.strip():
            raise ValueError(f"{verb} NAME[i, j]")
        cells[verb](rest, done)
        return f"{verb} {rest.strip()}"
    if verb == "help":
        raise ValueError(HELP)
    raise ValueError(f"unknown command {verb!r}; {HELP}")


def _check_live(prog, block, name):
    """ValueError naming what `set BLOCK.PARAM` may name when `block` is no block, `name` is
    missing (a block without its parameter) or not one of the block's live parameters."""
    bp = prog.by_name.get(block)
    if bp is None:
        raise ValueError(f"no block named {block!r}{suggest(block, prog.by_name)}; its blocks: "
                         f"{name_list(prog.by_name)}")
    live = [n for n, p in bp.cls.params.items() if p.live]
    has = f"block {block!r} ({bp.cls.type_name}) has the live parameters: {name_list(live)}"
    if name is None:
        raise ValueError(f"set BLOCK.PARAM VALUE; {has}")
    if name not in live:
        raise ValueError(f"{block}.{name} is not a live parameter{suggest(name, live)}; {has}")


class Console(threading.Thread):
    """Reads commands from `stream` and queues them on the Session `current()` returns (the one
    playing now: --watch may have swapped another in). `applied` lists what was applied."""

    def __init__(self, current, stream=None, out=None):
        super().__init__(daemon=True, name="hapticgraph-console")
        self.current, self.stream, self.out = current, stream or sys.stdin, out or sys.stderr
        self.applied = []

    def _done(self, text, error):
        # on the audio thread: checked when typed, refused only if the patch changed since
        self.applied.append(text if error is None else f"refused: {error}")

    def submit(self, line):
        try:
            text = submit(line, self.current(), self._done)
        except ValueError as exc:
            print(f"hapticgraph: {exc}", file=self.out)
            return False
        if text is None:
            return False
        print(f"hapticgraph: {text}", file=self.out)
        return True

    def run(self):
        for line in self.stream:
            self.submit(line)
