"""The thinnest path (issue 31): patches/karplus_strong.yaml exported to C99 runs, in a host's C
driver, to the same bits as hapticgraph.render — at the patch's rate, at another rate (derive
recomputed in C), with a live parameter changed at a block boundary — and the C is plain C99,
with no writable global: any number of instances."""
import re
import subprocess

import numpy as np

import hapticgraph
from hapticgraph.export.compiler import compiler
from hapticgraph.graph.patch import load
from project_env import ROOT

KS = ROOT / "patches" / "karplus_strong.yaml"


def test_karplus_strong_in_c_gives_the_bits_of_render(c_export, same_bits):
    built = c_export(KS)
    expected = hapticgraph.render(KS, seconds=1.0).audio
    got = built.run(44100, 44100, block=1000)
    assert np.abs(expected).max() > 0.1            # it sounds
    assert same_bits(got, expected)
    assert same_bits(built.run(44100, 44100, block=441), expected)     # the block size changes nothing


def test_another_rate_recomputes_what_derive_makes(c_export, same_bits):
    """Exported at 44.1 kHz, run at 48 kHz: the pluck's width (duration·fs) and every other value
    derive makes are the ones a patch written at 48 kHz gets from Python."""
    built = c_export(KS)
    text = KS.read_text(encoding="utf-8")
    at48 = load(KS, text=re.sub(r"(?m)^rate: 44100$", "rate: 48000", text))
    assert at48.rate == 48000.0
    expected = hapticgraph.render(at48, seconds=0.5).audio
    got = built.run(48000, 24000)
    assert same_bits(got, expected)
    assert not same_bits(got, built.run(44100, 24000))      # the rate matters


def test_a_live_parameter_set_at_a_block_boundary(c_export, same_bits):
    built = c_export(KS)
    with hapticgraph.Session.open(KS, blocksize=1000) as s:
        blocks = []
        for k in range(30):
            if k == 12:
                s.set("damp", "gain", 0.9)
                s.set("mic", "pan", 0.25)
            blocks.append(np.array(s.audio_of(s.process(1000))))
    expected = np.concatenate(blocks)
    sets = [(12000, built.param("damp.gain"), 0.9), (12000, built.param("mic.pan"), 0.25)]
    got = built.run(44100, 30000, sets=sets)
    assert same_bits(got, expected)
    assert not same_bits(got[12000:], built.run(44100, 30000)[12000:])     # the change was heard


def test_the_host_rate_is_refused_where_the_patch_refuses_it(c_export):
    built = c_export(KS)
    for rate in (50.0, 2e6, float("nan")):
        built.run(rate, 10, expect=3)          # NAME_new returned NULL
    assert built.refusal(50.0) == ["rate 50 Hz: outside the 100 to 1e+06 Hz a patch may run at"]
    built.run(100.0, 10)                       # the schema's bounds are inclusive
    built.run(1e6, 10)


def test_set_refuses_what_is_not_a_live_parameter_or_out_of_range(c_export):
    built = c_export(KS)
    built.run(44100, 10, sets=[(0, built.param("pick.time"), 0.5)], expect=4)     # not live
    built.run(44100, 10, sets=[(0, built.param("mic.pan"), 1.5)], expect=4)       # pan is within [-1, 1]
    built.run(44100, 10, sets=[(0, 99, 0.0)], expect=4)                            # no such parameter
    built.run(44100, 10, sets=[(0, built.param("mic.pan"), 1.0)])


def test_plain_c99_without_a_writable_global(c_export, tmp_path):
    built = c_export(KS)
    source = built.exe.parent / "karplus_strong.c"
    obj = tmp_path / "ks.o"
    proc = subprocess.run(compiler() + ["-std=c99", "-pedantic-errors", "-Wall", "-Werror", "-O2", "-c",
                                        str(source), "-I", str(source.parent), "-o", str(obj)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    symbols = subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout
    kinds = {line.split()[-1]: line.split()[-2] for line in symbols.splitlines() if len(line.split()) >= 2}
    tables = {"karplus_strong_ports", "karplus_strong_params"}     # const tables of pointers (.data.rel.ro)
    assert not [s for s, k in kinds.items() if k in "BbDdCGgSs" and s not in tables], symbols
    header = (source.parent / "karplus_strong.h").read_text(encoding="utf-8")
    assert all(f"extern const karplus_strong_{t}" in header for t in ("port karplus_strong_ports",
                                                                       "param karplus_strong_params"))
    exported = sorted(s for s, k in kinds.items() if k in "TRD")
    assert exported == sorted(f"karplus_strong_{f}" for f in ("new", "refused", "free", "reset", "process",
                                                              "process_float", "set", "get", "midi", "ports",
                                                              "params"))
    undefined = {s for s, k in kinds.items() if k == "U"}
    assert undefined <= {"calloc", "free", "memcpy", "memset", "sin", "cos", "floor", "nearbyint", "exp", "fmod",
                         "copysign", "pow", "sqrt", "log", "fabs", "sincos", "vsnprintf"}, undefined


def test_the_midi_driver_is_plain_c99_without_a_writable_global(c_export, tmp_path):
    """poly_strings: six voices and their allocator (hapticgraph.devices.midi_c) in the instance."""
    built = c_export(ROOT / "patches" / "poly_strings.yaml")
    source = built.exe.parent / "poly_strings.c"
    obj = tmp_path / "ps.o"
    proc = subprocess.run(compiler() + ["-std=c99", "-pedantic-errors", "-Wall", "-Wextra", "-Wno-unused-parameter",
                                        "-Werror", "-O2", "-c", str(source), "-I", str(source.parent), "-o", str(obj)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    symbols = subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout
    kinds = {line.split()[-1]: line.split()[-2] for line in symbols.splitlines() if len(line.split()) >= 2}
    assert not [s for s, k in kinds.items() if k in "BbDdCGgSs" and not s.endswith(("_ports", "_params"))], symbols
    assert "#define POLY_STRINGS_MIDI 1" in (built.exe.parent / "poly_strings.h").read_text(encoding="utf-8")


def test_a_check_that_fails_at_the_host_rate_refuses_it(c_export, write_patch, same_bits):
    """A velocity estimator's cutoff must stay below half the rate (its block's `check`, translated):
    exported at 44.1 kHz with a 9.5 kHz cutoff, NAME_new(18000) is refused, NAME_new(19500) runs."""
    path = write_patch("""
        hapticgraph: 1
        rate: 44100
        blocks:
          osc: {type: wavetable, frequency: 220.0, amplitude: 0.001}
          est: {type: velocity_estimator, cutoff: 9500.0}
          out: {type: audio_out, channels: 1}
        connect:
          - osc.out -> est.in
          - est.out -> out.ch0
        """)
    built = c_export(path)
    built.run(18000, 100, expect=3)
    assert built.refusal(18000) == [f"{path.name}:5: block 'est' (velocity_estimator): its check refuses 18000 Hz "
                                    "(hapticgraph check at that rate says why)"]
    text = path.read_text(encoding="utf-8").replace("rate: 44100", "rate: 19500")
    expected = hapticgraph.render(load(path, text=text), seconds=0.1).audio
    assert np.abs(expected).max() > 0.0
    assert same_bits(built.run(19500, 1950), expected)

