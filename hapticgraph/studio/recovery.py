"""The designer's unsaved edits kept beside the patch (docs/studio.md, "Unsaved edits"): after
every accepted edit the text is written atomically to `.NAME.yaml.studio~` in the patch's folder,
which a save removes; the next studio of the patch offers it.

The file is the edited patch text after three comment lines (so that it stays a patch a person
can open and use):

    # hapticgraph studio recovery: 3 unsaved edits of NAME.yaml (delete these 3 lines to use it as a patch)
    # base: sha256:<the patch file's text the edits were made on>
    # text: sha256:<the text below>

It is offered only if it looks like one the studio wrote: a regular file (not a link) of this user,
writable by no one else (both on POSIX systems, where the studio writes it 0600), at most
MAX_BYTES, UTF-8, these three lines, its text matching its checksum. Taking it (`recover`) then
sends the text through the loader like any other edit."""
import difflib
import hashlib
import os
import re
import stat
import tempfile

POSIX = os.name == "posix"     # owners and permission bits (Windows has ACLs: its st_mode says little)
MAX_BYTES = 8 << 20        # a patch is kilobytes; per-cell overrides of 100 000 cells about 5 MB
HEADER = re.compile(r"# hapticgraph studio recovery: (\d+) unsaved edits? of (.*) "
                    r"\(delete these 3 lines to use it as a patch\)\n"
                    r"# base: sha256:([0-9a-f]{64})\n"
                    r"# text: sha256:([0-9a-f]{64})\n")


def path_of(patch):
    """The recovery file of the patch file `patch`."""
    folder, name = os.path.split(os.fspath(patch))
    return os.path.join(folder, f".{name}.studio~")


def digest(text):
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def edits_text(count):
    return f"{count} unsaved edit{'' if count == 1 else 's'}"


def write_atomic(target, data, mode=None):
    """`data` (bytes) into `target`: a temporary file in the same folder, synced, then renamed
    over it, so that a reader (or a crash) sees the old file or the new one, never a part.
    `mode`: the new file's permissions (default: the temporary file's, 0600)."""
    fd, tmp = tempfile.mkstemp(prefix=".hapticgraph-studio-", suffix=".tmp",
                               dir=os.path.dirname(os.path.abspath(target)))
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        if mode is not None:
            os.chmod(tmp, mode)
        os.replace(tmp, target)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write(patch, text, base, edits):
    """Keep `text` (made by `edits` accepted edits from the file's text `base`)."""
    header = (f"# hapticgraph studio recovery: {edits_text(edits)} of {os.path.basename(patch)} "
              f"(delete these 3 lines to use it as a patch)\n"
              f"# base: sha256:{digest(base)}\n# text: sha256:{digest(text)}\n")
    write_atomic(path_of(patch), (header + text).encode("utf-8"))


def remove(patch):
    """The recovery file removed, if there is one (one that cannot be: left, and offered no more
    once its text is the file's)."""
    try:
        os.unlink(path_of(patch))
    except OSError:
        pass


class Offer:
    """Unsaved edits found beside the patch: `text` made by `edits` edits, kept in `file` at
    `written` (seconds since the epoch); `patch_changed` when the file's text is no longer the
    one they were made on."""

    def __init__(self, file, text, edits, written, patch_changed, saved, path):
        self.file, self.text, self.edits, self.written = file, text, edits, written
        self.patch_changed, self.saved, self.path = patch_changed, saved, path

    def event(self):
        """The `recovery` event that offers it (docs/studio.md)."""
        diff = "".join(difflib.unified_diff(self.saved.splitlines(True), self.text.splitlines(True),
                                            fromfile=self.path, tofile=f"{self.file} (unsaved edits)"))
        return {"type": "recovery", "offered": True, "edits": self.edits, "file": self.file,
                "written": self.written, "patch_changed": self.patch_changed, "text": self.text, "diff": diff}

    def note(self):
        changed = "; the patch file has changed since" if self.patch_changed else ""
        return (f"{self.file} holds {edits_text(self.edits)} of {os.path.basename(self.path)} that an earlier "
                f"studio did not save{changed}: the page offers them (or send recover, or discard_recovery)")


class Refused(Exception):
    """A recovery file that is not offered (the message says why)."""


def _read(file):
    """The recovery file's (edits, base digest, text, mtime); Refused if it is not one the studio wrote."""
    if os.path.islink(file):
        raise Refused("a link, not a file the studio wrote")
    try:
        fd = os.open(file, os.O_RDONLY | (os.O_NOFOLLOW if POSIX else 0))
    except OSError as exc:
        raise Refused(f"cannot be read ({exc.strerror or exc})") from None
    with os.fdopen(fd, "rb") as f:
        info = os.fstat(f.fileno())
        if not stat.S_ISREG(info.st_mode):
            raise Refused("not a regular file")
        if POSIX and info.st_uid != os.geteuid():
            raise Refused("it belongs to another user")
        if POSIX and info.st_mode & 0o022:
            raise Refused("others could have written it (its permissions let them)")
        data = f.read(MAX_BYTES + 1)
    if len(data) > MAX_BYTES:
        raise Refused(f"larger than {MAX_BYTES >> 20} MB")
    try:
        content = data.decode("utf-8")
    except UnicodeDecodeError:
        raise Refused("not UTF-8 text") from None
    m = HEADER.match(content)
    if m is None:
        raise Refused("its first 3 lines are not those the studio writes")
    text = content[m.end():]
    if digest(text) != m.group(4):
        raise Refused("its text is not the one its checksum names (changed since the studio wrote it)")
    return int(m.group(1)), m.group(3), text, info.st_mtime


def find(patch, saved, note):
    """The Offer of the patch's recovery file, or None; `note(message)` says why one is not offered.
    A recovery file whose text is the patch file's (nothing unsaved) is removed."""
    file = path_of(patch)
    if not os.path.lexists(file):
        return None
    try:
        edits, base, text, written = _read(file)
    except Refused as exc:
        note(f"{file}: not offered: {exc}; the next edit replaces it")
        return None
    if text == saved:
        remove(patch)
        return None
    offer = Offer(file, text, edits, written, base != digest(saved), saved, os.fspath(patch))
    note(offer.note())
    return offer
