"""Patch problems: every one names a file, a line and the thing at fault."""


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
    """A patch that must not run; `problems` lists everything found, in file order."""

    def __init__(self, problems):
        unique = {(p.file, p.line, p.message): p for p in problems}
        self.problems = sorted(unique.values(), key=lambda p: (p.file, p.line))
        super().__init__("\n".join(str(p) for p in self.problems))


class Collector:
    """Gathers problems for one file, so a check can report them all at once."""

    def __init__(self, file):
        self.file = file
        self.problems = []

    def add(self, line, message):
        self.problems.append(Problem(self.file, line, message))

    def raise_if_any(self):
        if self.problems:
            raise PatchError(self.problems)
