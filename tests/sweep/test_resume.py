"""--resume keeps one row per variant (issue 33, item 1). A runaway, an `invalid` or a worker's
`error` gives the same answer every time: resume keeps it unless --retry-failed; a `killed` or
`timeout` variant is rendered again. A re-tried variant's row replaces its old one by an atomic
rewrite (the file on disk is always whole), and manifest.parquet mirrors manifest.csv."""
import csv
import os

import pyarrow.parquet
import pytest

import hapticgraph
from hapticgraph.cli import main
from hapticgraph.sweeps import load_spec
from hapticgraph.sweeps.manifest import Manifest
from sweeps_env import karplus, write

GRID = """
    sweep: 1
    patch: ks.yaml
    seconds: 0.1
    axes:
      loop.length: [49, 99, 199]
      damp.gain: [0.99, 0.998, 1.5]      # 1.5: the loop gains, a runaway
    features: [rms]
    audio: wav
    """


def _rows(folder):
    with open(os.path.join(folder, "manifest.csv"), newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _records(folder):
    """Every record of manifest.csv as the csv module reads it (the header first)."""
    with open(os.path.join(folder, "manifest.csv"), newline="", encoding="utf-8") as f:
        return list(csv.reader(f))


def _stamps(folder):
    """Each audio file's inode and mtime: a file rendered again is a new file (written, then renamed)."""
    audio = os.path.join(folder, "audio")
    return {name: (os.stat(os.path.join(audio, name)).st_ino, os.stat(os.path.join(audio, name)).st_mtime_ns)
            for name in sorted(os.listdir(audio))}


def _rewrite(folder, rows):
    with open(os.path.join(folder, "manifest.csv"), "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def test_resume_of_a_grid_with_three_runaways_renders_nothing_and_keeps_nine_rows(tmp_path, dask_client, capsys):
    karplus(tmp_path)
    sweep = write(tmp_path, "s.yaml", GRID)
    out = tmp_path / "out"
    command = ["sweep", str(sweep), "--out", str(out), "--scheduler", dask_client.scheduler.address, "--quiet"]
    assert main(command) == 1                                   # not every variant is ok
    first = _rows(out)
    assert len(first) == 9 and len({r["id"] for r in first}) == 9
    assert sorted(r["status"] for r in first) == ["ok"] * 6 + ["runaway"] * 3
    manifest, stamps = (out / "manifest.csv").read_bytes(), _stamps(out)
    assert len(stamps) == 6
    capsys.readouterr()

    assert main(command + ["--resume"]) == 1
    note = capsys.readouterr().err
    assert (out / "manifest.csv").read_bytes() == manifest      # 9 rows, not 12: nothing appended
    assert _stamps(out) == stamps                               # no audio file written again
    assert "0 variant(s)" in note and "9 kept from the manifest (6 ok, 3 runaway)" in note, note
    table = pyarrow.parquet.read_table(out / "manifest.parquet").to_pydict()
    assert table["id"] == [r["id"] for r in first] and table["status"] == [r["status"] for r in first]

    assert main(command + ["--resume", "--retry-failed"]) == 1
    note = capsys.readouterr().err
    again = _rows(out)
    assert [r["id"] for r in again] == [r["id"] for r in first]        # each id once, in its place
    assert [r["status"] for r in again] == [r["status"] for r in first]
    assert "3 variant(s)" in note and "3 runaway" in note and "6 kept from the manifest (6 ok)" in note, note
    assert _stamps(out) == stamps                                       # the ok variants were not rendered
    assert not [name for name in os.listdir(out) if name.endswith(".part")]
    table = pyarrow.parquet.read_table(out / "manifest.parquet")
    assert table.num_rows == 9 and str(table.schema.field("id").type) == "string"
    assert table.column("id").to_pylist() == [r["id"] for r in again]
    rms = table.column("rms").to_pylist()
    assert [value is None for value in rms] == [r["status"] == "runaway" for r in again]
    assert all(value > 0 for value in rms if value is not None)


def test_retry_failed_without_resume_is_a_usage_error(tmp_path, capsys):
    karplus(tmp_path)
    sweep = write(tmp_path, "s.yaml", GRID)
    assert main(["sweep", str(sweep), "--out", str(tmp_path / "out"), "--retry-failed"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("hapticgraph: error: --retry-failed") and "--resume" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()
    with pytest.raises(ValueError, match="resume=True"):
        hapticgraph.sweep(sweep, tmp_path / "out", retry_failed=True)


def test_resume_renders_killed_and_timeout_rows_again_and_keeps_the_others(tmp_path, dask_client):
    """Seven rendered variants, six of their rows made failures by hand (their audio removed): only
    the killed, the timed-out and the one the cluster lost (an error no worker gave) are rendered
    again, each replacing its row; --retry-failed renders the rest."""
    karplus(tmp_path)
    sweep = write(tmp_path, "s.yaml", """
        sweep: 1
        patch: ks.yaml
        seconds: 0.1
        axes:
          damp.gain: [0.99, 0.991, 0.992, 0.993, 0.994, 0.995, 0.996]
        features: [rms]
        audio: wav
        """)
    out = tmp_path / "out"
    hapticgraph.sweep(sweep, out, client=dask_client, report=lambda text: None)
    rows = _rows(out)
    ids = [r["id"] for r in rows]
    failures = [("ok", "tcp://w"), ("killed", ""), ("timeout", "tcp://w"), ("runaway", "tcp://w"),
                ("invalid", "tcp://w"), ("error", "tcp://w"), ("error", "")]
    for row, (status, worker) in zip(rows[1:], failures[1:]):
        os.remove(out / row["audio"])
        row.update(status=status, error=f"made {status}", audio="", worker=worker, rms="")
    _rewrite(out, rows)
    kept = _stamps(out)

    notes = []
    table = hapticgraph.sweep(sweep, out, client=dask_client, resume=True, report=notes.append)
    after = _rows(out)
    assert [r["id"] for r in after] == ids
    assert [r["status"] for r in after] == ["ok", "ok", "ok", "runaway", "invalid", "error", "ok"]
    assert len(table) == 7 and dict(zip(table["id"], table["status"])) == {r["id"]: r["status"] for r in after}
    assert [bool(r["audio"]) for r in after] == [True, True, True, False, False, False, True]
    assert all((out / r["audio"]).exists() for r in after if r["audio"])
    assert _stamps(out)[f"{ids[0]}.wav"] == kept[f"{ids[0]}.wav"]
    assert "3 variant(s)" in notes[-1] and "3 ok" in notes[-1], notes[-1]
    assert "4 kept from the manifest (1 error, 1 invalid, 1 ok, 1 runaway)" in notes[-1], notes[-1]

    table = hapticgraph.sweep(sweep, out, client=dask_client, resume=True, retry_failed=True, report=notes.append)
    after = _rows(out)
    assert [r["id"] for r in after] == ids and [r["status"] for r in after] == ["ok"] * 7
    assert list(table["status"]) == ["ok"] * 7 and len(table) == 7
    assert "3 variant(s)" in notes[-1] and "4 kept from the manifest (4 ok)" in notes[-1], notes[-1]


def test_a_variant_listed_twice_is_rendered_once_and_has_one_row(tmp_path, dask_client):
    karplus(tmp_path)
    sweep = write(tmp_path, "s.yaml", """
        sweep: 1
        patch: ks.yaml
        seconds: 0.1
        axes:
          damp.gain: [0.99, 0.995, 0.99]
        audio: none
        """)
    notes = []
    table = hapticgraph.sweep(sweep, tmp_path / "out", client=dask_client, report=notes.append)
    rows = _rows(tmp_path / "out")
    # the file holds the rows as they were rendered (two workers: either first), the table in variant order
    assert len(rows) == 2 and len(table) == 2 and sorted(table["id"]) == sorted(r["id"] for r in rows)
    assert list(table["damp.gain"]) == [0.99, 0.995]
    assert "2 variant(s)" in notes[-1], notes[-1]


def _spec(tmp_path, audio="none"):
    karplus(tmp_path)
    return load_spec(write(tmp_path, "s.yaml", f"""
        sweep: 1
        patch: ks.yaml
        seconds: 0.1
        axes:
          damp.gain: [0.99, 0.995, 0.998]
        features: [rms]
        audio: {audio}
        """))


def _row(variant, status, rms=""):
    return {"id": variant.id, "status": status, "error": "" if status == "ok" else f"made {status}",
            "rms": rms, "audio": "", "seconds_compile": 0.25, "seconds_run": 0.5, "worker": "tcp://127.0.0.1:1"}


def test_a_row_replaced_is_an_atomic_rewrite_and_a_failed_rewrite_leaves_the_old_file(tmp_path, monkeypatch):
    spec = _spec(tmp_path)
    a, b, c = spec.variants
    out = tmp_path / "out"
    manifest = Manifest(out, spec)
    manifest.write(a, _row(a, "ok", 0.5))
    manifest.write(b, _row(b, "killed"))
    manifest.close()
    before = (out / "manifest.csv").read_bytes()
    inode = os.stat(out / "manifest.csv").st_ino

    manifest = Manifest(out, spec, resume=True)

    def broken(src, dst):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(os, "replace", broken)
    with pytest.raises(OSError):
        manifest.write(b, _row(b, "ok", 0.25))
    monkeypatch.undo()
    assert (out / "manifest.csv").read_bytes() == before              # whole, as it was
    assert sorted(os.listdir(out)) == ["audio", "manifest.csv", "manifest.parquet", "sweep.json"]

    manifest.write(b, _row(b, "ok", 0.25))
    manifest.write(c, _row(c, "runaway"))
    manifest.close()
    records = _records(out)
    assert [r[:2] for r in records[1:]] == [[a.id, "ok"], [b.id, "ok"], [c.id, "runaway"]]
    assert os.stat(out / "manifest.csv").st_ino != inode              # a new file put in place


def test_an_unfinished_row_and_rows_written_twice_are_mended_when_a_sweep_resumes(tmp_path):
    spec = _spec(tmp_path)
    a, b, c = spec.variants
    out = tmp_path / "out"
    manifest = Manifest(out, spec)
    manifest.write(a, _row(a, "killed"))
    manifest.write(b, _row(b, "ok", 0.25))
    manifest.close()
    with open(out / "manifest.csv", "a", newline="", encoding="utf-8") as f:
        csv.DictWriter(f, manifest.columns).writerow(_row(a, "ok", 0.5))     # an older version's second row
        f.write(f"{c.id},ok,,0.998,0.")                                      # the client killed mid-line

    manifest = Manifest(out, spec, resume=True)
    assert manifest.settled(a) and manifest.settled(b) and not manifest.settled(c)
    records = _records(out)                                                  # mended on disk at once
    assert [r[:2] for r in records[1:]] == [[a.id, "ok"], [b.id, "ok"]]
    assert all(len(r) == len(manifest.columns) for r in records)
    assert any("unfinished" in note for note in manifest.notes) and any("twice" in note for note in manifest.notes)
    manifest.write(c, _row(c, "ok", 0.125))
    manifest.close()
    records = _records(out)
    assert [r[:2] for r in records[1:]] == [[a.id, "ok"], [b.id, "ok"], [c.id, "ok"]]
    assert all(len(r) == len(manifest.columns) for r in records)


def test_manifest_parquet_has_one_row_per_id_with_the_csv_types(tmp_path):
    spec = _spec(tmp_path)
    a, b, c = spec.variants
    c.id = "0012345678901234"          # an id of digits only is still an id, not a number
    out = tmp_path / "out"
    manifest = Manifest(out, spec)
    manifest.write(a, _row(a, "ok", 0.5))
    manifest.write(b, _row(b, "timeout"))
    manifest.write(c, _row(c, "ok", 0.125))
    manifest.close()
    manifest = Manifest(out, spec, resume=True)
    manifest.write(b, _row(b, "ok", 0.25))
    manifest.close()
    table = pyarrow.parquet.read_table(out / "manifest.parquet")
    assert table.column_names == manifest.columns
    assert table.column("id").to_pylist() == [a.id, b.id, "0012345678901234"]
    assert table.column("status").to_pylist() == ["ok", "ok", "ok"]
    assert table.column("rms").to_pylist() == [0.5, 0.25, 0.125]
    assert table.column("damp.gain").to_pylist() == [0.99, 0.995, 0.998]
    assert str(table.schema.field("worker").type) == "string"
    assert not [name for name in os.listdir(out) if name.endswith(".part")]


def test_quiet_says_nothing_when_every_variant_is_ok_and_the_note_when_one_failed(tmp_path, dask_client, capsys):
    """`-q` prints nothing on success (issue 33, item 2); when a variant failed (exit 1) the
    closing note still goes to standard error."""
    karplus(tmp_path)
    good = write(tmp_path, "good.yaml", GRID.replace("[0.99, 0.998, 1.5]", "[0.99]"))
    command = ["sweep", str(good), "--out", str(tmp_path / "good"), "--scheduler", dask_client.scheduler.address]
    assert main(command + ["-q"]) == 0
    said = capsys.readouterr()
    assert (said.out, said.err) == ("", "")
    bad = write(tmp_path, "bad.yaml", GRID)
    assert main(["sweep", str(bad), "--out", str(tmp_path / "bad"), "--scheduler", dask_client.scheduler.address,
                 "-q"]) == 1
    said = capsys.readouterr()
    assert said.out == "" and "runaway" in said.err and "variant(s)" in said.err, said.err
