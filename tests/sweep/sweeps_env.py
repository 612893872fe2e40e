"""Patches and sweep files the sweep tests write into their tmp_path."""
import pathlib
import shutil
import textwrap

DATA = pathlib.Path(__file__).resolve().parent / "data"
ROOT = pathlib.Path(__file__).resolve().parents[2]


def write(folder, name, text):
    path = pathlib.Path(folder) / name
    path.write_text(textwrap.dedent(text).lstrip("\n"), encoding="utf-8")
    return path


def karplus(folder, name="ks.yaml"):
    path = pathlib.Path(folder) / name
    shutil.copy(ROOT / "patches" / "karplus_strong.yaml", path)
    return path


def crash_patch(folder):
    """Karplus-Strong with the crash plugin between the loop and the microphone."""
    shutil.copy(DATA / "crash.py", pathlib.Path(folder) / "crash.py")
    return write(folder, "crash.yaml", """
        hapticgraph: 1
        plugins: [crash.py]
        blocks:
          pick: {type: pluck, time: 0.0, force: 1.0, duration: 0.0005}
          loop: {type: delay, length: 99}
          damp: {type: lowpass, coeffs: [0.25, 0.5, 0.25], gain: 0.996}
          boom: {type: crash, die: 0.0}
          out:  {type: audio_out, channels: 1}
        connect:
          - pick.out -> loop.in
          - damp.out -> loop.in
          - loop.out -> damp.in
          - damp.out -> boom.in
          - boom.out -> out.ch0
        """)


def lattice(folder, name="string.yaml", cells=100):
    return write(folder, name, f"""
        hapticgraph: 1
        name: string of {cells} cells
        blocks:
          s:    {{type: lattice, shape: [{cells}], mass: 0.001, tension: 100000.0, damping: 0.0001}}
          pick: {{type: pluck, time: 0.0, force: 1.0, duration: 0.001}}
          out:  {{type: audio_out, channels: 1}}
        connect:
          - pick.out -> s[30].force
          - s[33].position -> out.ch0
        """)
