"""Patch problems: every one names a file, a line and the thing at fault."""

MAX_PROBLEMS = 100   # reported per file; past it the loader stops (docs/limits.md)


class Problem:
    """One problem in a patch, printed as `FILE:LINE: message`."""

    __slots__ = ("file", "line", "message")

    def __init__(self, file, line, message):
        self.file, self.line, self.message = str(file), int(line or 1), message

    def __str__(self):
        return f"{self.file}:{self.line}: {self.message}"

    def __repr__(self):
        return f"Problem({str(self)!r})"


class PatchError(Exception):
    """A patch that must not run; `problems` lists everything found, in file order (then, if some
    were not shown, one more line that says so)."""

    def __init__(self, problems, summary=None):
        unique = {(p.file, p.line, p.message): p for p in problems}
        self.problems = sorted(unique.values(), key=lambda p: (p.file, p.line))
        if summary is not None:
            self.problems.append(summary)
        super().__init__("\n".join(str(p) for p in self.problems))


class PlanError(Exception):
    """A checked patch cannot be run as asked: a probe or a device it cannot supply, a live edit
    it refuses (hapticgraph.PlanError)."""


class Collector:
    """Gathers problems for one file, so a check can report them all at once. It keeps at most
    `limit`; past that it only counts, and `full` tells the loader to stop reading."""

    def __init__(self, file, limit=MAX_PROBLEMS):
        self.file, self.limit = file, limit
        self.problems = []
        self.suppressed = 0        # problems past the limit that were counted, not kept
        self.first_suppressed = None
        self.stopped_at = None     # the line where the loader stopped reading, if it did
        self.folds = []            # (line, message) -> message: e.g. voice copies told as their template

    @property
    def full(self):
        return len(self.problems) >= self.limit

    def add(self, line, message):
        if self.full:
            self.suppressed += 1
            if self.first_suppressed is None:
                self.first_suppressed = line
            return
        for fold in self.folds:
            message = fold(line, message)
        self.problems.append(Problem(self.file, line, message))

    def stop(self, line):
        """The loader stops here: the limit is reached and what follows is not read."""
        if self.stopped_at is None:
            self.stopped_at = line

    def summary(self):
        if self.stopped_at is not None:
            more = f"{self.suppressed:,} more problem(s) and the rest of the file not checked" \
                if self.suppressed else "the rest of the file not checked"
            return Problem(self.file, self.stopped_at, f"stopped after {self.limit} problems: {more}")
        if self.suppressed:
            return Problem(self.file, self.first_suppressed,
                           f"{self.suppressed:,} more problem(s) not shown (at most {self.limit} are reported)")
        return None

    def raise_if_any(self):
        if self.problems:
            raise PatchError(self.problems, self.summary())


def suggest(word, choices):
    """' (did you mean X?)' for the closest of choices, or ''."""
    import difflib
    close = difflib.get_close_matches(word, list(choices), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def name_list(names, most=20):
    names = list(names)
    shown = ", ".join(names[:most])
    return shown + (f", … ({len(names) - most} more)" if len(names) > most else "") if names else "none"
