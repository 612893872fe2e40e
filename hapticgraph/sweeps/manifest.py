"""A sweep's results folder: `manifest.csv` (one row per finished variant, appended and flushed as
each result arrives, so an interrupted sweep keeps every row it finished), `audio/` (one file per
variant that rendered), `sweep.json` (the sweep file's hash: `--resume` refuses a sweep file that
changed) and, when pyarrow is installed, `manifest.parquet` written when the sweep ends.

Columns: id, status (ok, runaway, invalid, timeout, killed, error), error, one per axis, one per
feature, audio (relative to the folder), seconds_compile, seconds_run, worker. A variant run
again (by --resume) gets a new row; its last row is its result."""
import csv
import importlib.util
import json
import math
import os

import soundfile


class SweepError(Exception):
    """A sweep that cannot start as asked (a results folder in use, a changed sweep file)."""

HEAD = ("id", "status", "error")
TAIL = ("audio", "seconds_compile", "seconds_run", "worker")
STATUSES = ("ok", "runaway", "invalid", "timeout", "killed", "error")


def columns_of(spec):
    return list(HEAD) + spec.axis_names + list(spec.features) + list(spec.extra_columns) + list(TAIL)


class Manifest:
    """The results folder of one sweep; only the client writes it."""

    def __init__(self, out, spec, resume=False):
        self.out, self.spec = os.fspath(out), spec
        self.columns = columns_of(spec)
        self.path = os.path.join(self.out, "manifest.csv")
        self.rows = []
        self._last = None          # {id: its last row}, made when first asked
        os.makedirs(os.path.join(self.out, "audio"), exist_ok=True)
        if os.path.exists(self.path):
            self._reopen(resume)
            self.file = open(self.path, "a", newline="", encoding="utf-8")
            self.writer = csv.DictWriter(self.file, self.columns, extrasaction="ignore")
        else:
            _write_json(os.path.join(self.out, "sweep.json"), {"sweep_sha256": spec.digest, "columns": self.columns})
            self.file = open(self.path, "w", newline="", encoding="utf-8")
            self.writer = csv.DictWriter(self.file, self.columns, extrasaction="ignore")
            self.writer.writeheader()
            self.file.flush()

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
        with open(self.path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            if reader.fieldnames != self.columns:
                raise SweepError(f"cannot resume: the columns of {self.path} are not this sweep's")
            self.rows = list(reader)

    def done(self, variant):
        """True if the variant's last row is `ok` and its audio file is whole."""
        if self._last is None:
            self._last = {row["id"]: row for row in self.rows}
        last = self._last.get(variant.id)
        if last is None or last["status"] != "ok":
            return False
        if self.spec.audio == "none":
            return True
        return bool(last["audio"]) and self.whole(os.path.join(self.out, last["audio"]))

    def whole(self, path):
        """True if soundfile reads every frame the variant should have."""
        expected = int(round(self.spec.seconds * self.spec.rate))
        try:
            data, _ = soundfile.read(path, dtype="float32", always_2d=True)
        except (OSError, RuntimeError, soundfile.SoundFileError):
            return False
        return data.shape[0] == expected

    def write(self, variant, row, audio=None):
        """Append a variant's row (its audio file first, complete, so a row never names a partial file)."""
        if audio is not None:
            target = os.path.join(self.out, row["audio"])
            tmp = target + ".part"
            with open(tmp, "wb") as f:
                f.write(audio)
            os.replace(tmp, target)
        full = dict(row)
        full.update({a.name: v for a, v in zip(self.spec.axes, variant.values)})
        self.writer.writerow(full)
        self.file.flush()
        self.rows.append({k: str(full.get(k, "")) for k in self.columns})
        if self._last is not None:
            self._last[row["id"]] = self.rows[-1]

    def close(self):
        self.file.close()
        if importlib.util.find_spec("pyarrow") is not None and importlib.util.find_spec("pandas") is not None:
            import pandas
            pandas.read_csv(self.path).to_parquet(os.path.join(self.out, "manifest.parquet"))

    def table(self):
        """The last row of each of the sweep's variants, in variant order: a pandas DataFrame when
        pandas is installed, else a list of dicts (numbers read as floats)."""
        last = {row["id"]: row for row in self.rows}
        rows = [_typed(last[v.id]) for v in self.spec.variants if v.id in last]
        if importlib.util.find_spec("pandas") is None:
            return rows
        import pandas
        return pandas.DataFrame(rows, columns=self.columns)


def _typed(row):
    out = {}
    for key, value in row.items():
        if key in ("id", "status", "error", "audio", "worker"):
            out[key] = value
            continue
        try:
            out[key] = float(value) if value != "" else math.nan
        except ValueError:
            out[key] = value           # an axis of words (a choice)
    return out


def _write_json(path, data):
    tmp = path + ".part"
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=1)
    os.replace(tmp, path)
