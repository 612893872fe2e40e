"""A sweep's results folder: `manifest.csv` (one row per variant id, a new id appended as one line
and flushed as its result arrives, so an interrupted sweep keeps every row it finished), `audio/`
(one file per variant that rendered), `sweep.json` (the sweep file's hash: `--resume` refuses a
sweep file that changed) and, when pyarrow is installed, `manifest.parquet` (the same rows, typed)
written when the sweep ends.

Columns: id, status (ok, runaway, invalid, timeout, killed, error), error, one per axis, one per
feature, audio (relative to the folder), seconds_compile, seconds_run, worker.

A variant rendered again (by --resume) replaces its row in place: the whole file is written to a
temporary file beside it and renamed over it, so the file on disk is always whole. A resumed
manifest is mended first, the same way: a last line cut short (the client died while writing it)
is dropped, and of the rows of an id written more than once (older versions appended them) the
last one is kept."""
import contextlib
import csv
import importlib.util
import io
import json
import math
import os

import soundfile


class SweepError(Exception):
    """A sweep that cannot start as asked (a results folder in use, a changed sweep file)."""

HEAD = ("id", "status", "error")
TAIL = ("audio", "seconds_compile", "seconds_run", "worker")
TEXT = HEAD + ("audio", "worker")
STATUSES = ("ok", "runaway", "invalid", "timeout", "killed", "error")
# The same answer each time the variant is rendered: kept by --resume unless --retry-failed. A
# `killed` or `timeout` row depends on the cluster and its load, and is rendered again.
SAME_EACH_TIME = ("runaway", "invalid", "error")


def columns_of(spec):
    return list(HEAD) + spec.axis_names + list(spec.features) + list(spec.extra_columns) + list(TAIL)


def distinct(variants):
    """The variants with one of each id (the first), in order: two points that make the same
    overrides (a value listed twice, a step that rounds two points together) are one variant."""
    seen, out = set(), []
    for variant in variants:
        if variant.id not in seen:
            seen.add(variant.id)
            out.append(variant)
    return out


class Manifest:
    """The results folder of one sweep; only the client writes it. `rows`: one per id, in the
    order the ids were first written; `notes`: what mending a resumed manifest did."""

    def __init__(self, out, spec, resume=False):
        self.out, self.spec = os.fspath(out), spec
        self.columns = columns_of(spec)
        self.path = os.path.join(self.out, "manifest.csv")
        self.rows, self.lines, self.index, self.notes = [], [], {}, []
        os.makedirs(os.path.join(self.out, "audio"), exist_ok=True)
        if os.path.exists(self.path):
            self._reopen(resume)
        else:
            _write_json(os.path.join(self.out, "sweep.json"), {"sweep_sha256": spec.digest, "columns": self.columns})
            self._rewrite()

    def _reopen(self, resume):
        if not resume:
            raise SweepError(f"{self.path} exists: --resume continues that sweep, or choose another --out")
        try:
            with open(os.path.join(self.out, "sweep.json"), encoding="utf-8") as f:
                began = json.load(f)
        except (OSError, ValueError) as exc:
            raise SweepError(f"cannot resume: {os.path.join(self.out, 'sweep.json')} is unreadable ({exc})") from None
        if began.get("sweep_sha256") != self.spec.digest:
            raise SweepError(f"cannot resume: {self.spec.file} changed since {self.path} was begun; "
                             "sweep it into another --out")
        try:
            with open(self.path, newline="", encoding="utf-8") as f:
                text = f.read()
            records = list(csv.reader(io.StringIO(text, newline="")))
        except (UnicodeDecodeError, csv.Error) as exc:
            raise SweepError(f"cannot resume: {self.path} is not a manifest ({exc})") from None
        if not records or records[0] != self.columns:
            raise SweepError(f"cannot resume: the columns of {self.path} are not this sweep's")
        body = records[1:]
        if body and not text.endswith("\n"):
            body[-1] = []              # a last line with no line ending was cut short
        whole = [r for r in body if self._whole(r)]
        for record in whole:
            self._put(dict(zip(self.columns, record)))
        cut, twice = len(body) - len(whole), len(whole) - len(self.rows)
        if cut:
            self.notes.append(f"dropped {cut} unfinished row(s) of {self.path} (a write cut short)")
        if twice:
            self.notes.append(f"{self.path}: kept the last row of each id written twice ({twice} older row(s) dropped)")
        if cut or twice:
            self._rewrite()

    def _whole(self, record):
        return len(record) == len(self.columns) and record[1] in STATUSES

    def _put(self, row):
        """Set the row of its id: in place if the id has one, else after the others."""
        line = _line(row[c] for c in self.columns)
        at = self.index.get(row["id"])
        if at is None:
            self.index[row["id"]] = len(self.rows)
            self.rows.append(row)
            self.lines.append(line)
        else:
            self.rows[at], self.lines[at] = row, line

    def row_of(self, variant):
        """The variant's row, or None."""
        at = self.index.get(variant.id)
        return None if at is None else self.rows[at]

    def settled(self, variant, retry_failed=False):
        """True if --resume leaves the variant as its row says: `ok` with a whole audio file, or a
        runaway, `invalid` or a worker's `error` (unless `retry_failed`). A variant with no row, a
        `killed` or `timeout` one, and an `error` no worker gave (the cluster lost the task: the
        scheduler gone, the task cancelled) are rendered again."""
        row = self.row_of(variant)
        if row is None:
            return False
        if row["status"] == "ok":
            return self.spec.audio == "none" or (bool(row["audio"]) and
                                                 self.whole(os.path.join(self.out, row["audio"])))
        if row["status"] == "error" and not row["worker"]:
            return False
        return row["status"] in SAME_EACH_TIME and not retry_failed

    def whole(self, path):
        """True if soundfile reads every frame the variant should have."""
        expected = int(round(self.spec.seconds * self.spec.rate))
        try:
            data, _ = soundfile.read(path, dtype="float32", always_2d=True)
        except (OSError, RuntimeError, soundfile.SoundFileError):
            return False
        return data.shape[0] == expected

    def write(self, variant, row, audio=None):
        """Write a variant's row, its audio file first (complete, so a row never names a partial
        file). A new id's row is appended as one line; a row that replaces one rewrites the file."""
        if audio is not None:
            target = os.path.join(self.out, row["audio"])
            tmp = target + ".part"
            with open(tmp, "wb") as f:
                f.write(audio)
            os.replace(tmp, target)
        full = dict(row)
        full.update({a.name: v for a, v in zip(self.spec.axes, variant.values)})
        full = {k: _text(full.get(k)) for k in self.columns}
        if self.row_of(variant) is None:
            with open(self.path, "a", newline="", encoding="utf-8") as f:
                f.write(_line(full[c] for c in self.columns))
                f.flush()
                os.fsync(f.fileno())
            self._put(full)
            return
        old = self.rows[self.index[variant.id]]
        self._put(full)
        try:
            self._rewrite()
        except BaseException:
            self._put(old)             # as the file on disk still says
            raise

    def _rewrite(self):
        """Write the header and every row to a temporary file in the folder and rename it over
        manifest.csv: a reader (or a crash) sees the old file or the new one, whole."""
        _replace(self.path, lambda f: f.write(_line(self.columns) + "".join(self.lines)), "w")

    def close(self):
        """Write manifest.parquet (when pyarrow is installed) from the rows, one per id."""
        if importlib.util.find_spec("pyarrow") is None:
            return
        import pyarrow
        import pyarrow.parquet
        columns = _typed_columns(self.rows, self.columns)
        table = pyarrow.table({name: pyarrow.array(values, type=pyarrow.float64() if numbers else pyarrow.string())
                               for name, (numbers, values) in columns.items()})
        _replace(os.path.join(self.out, "manifest.parquet"), lambda f: pyarrow.parquet.write_table(table, f), "wb")

    def table(self):
        """The row of each of the sweep's variants (one per id), in variant order: a pandas
        DataFrame when pandas is installed, else a list of dicts (numbers read as floats; an empty
        cell of a column of numbers is NaN)."""
        rows = [self.row_of(v) for v in distinct(self.spec.variants) if v.id in self.index]
        columns = _typed_columns(rows, self.columns)
        typed = [{name: values[i] if values[i] is not None else math.nan for name, (_, values) in columns.items()}
                 for i in range(len(rows))]
        if importlib.util.find_spec("pandas") is None:
            return typed
        import pandas
        return pandas.DataFrame(typed, columns=self.columns)


def _text(value):
    return "" if value is None else str(value)


def _line(cells):
    """One CSV record, its line ending included."""
    buf = io.StringIO(newline="")
    csv.writer(buf).writerow(list(cells))
    return buf.getvalue()


def _typed_columns(rows, columns):
    """{column: (True if numbers, values)}: a column whose every cell is a number or empty holds
    floats (None where empty); id, status, error, audio, worker and any column of words hold text."""
    out = {}
    for name in columns:
        cells = [row[name] for row in rows]
        if name not in TEXT:
            try:
                out[name] = (True, [float(c) if c != "" else None for c in cells])
                continue
            except ValueError:
                pass                   # an axis of words (a choice)
        out[name] = (False, cells)
    return out


def _replace(path, fill, mode):
    """Write a file by `fill(f)` into a temporary file beside `path`, flushed to disk, then
    renamed over `path`; on any failure the temporary file is removed and `path` is untouched."""
    tmp = f"{path}.{os.getpid()}.part"
    try:
        with open(tmp, mode, **({} if "b" in mode else {"newline": "", "encoding": "utf-8"})) as f:
            fill(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(tmp)
        raise


def _write_json(path, data):
    _replace(path, lambda f: json.dump(data, f, indent=1), "w")
