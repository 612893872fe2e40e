"""The exported C under AddressSanitizer and UndefinedBehaviorSanitizer: no read or write outside
an array, no signed overflow, no misaligned or null access, while it gives the Python run's bits.
Six patches stand for the shapes of code the translator writes: a waveguide with a device
(Fig. 7), MIDI voices (poly_strings), a 2-D stencil (cymatic_sheet), a 4-D lattice (hyper_4d), the
nonlinear links' loops (string_rattle) and a hammer's contact (piano_hammer). (All 20 shipped
patches were run so once by hand, with the same result.)"""
import pytest

import hapticgraph
from project_env import ROOT
from test_c_waveguides import midi_events, python_run

SANITIZE = ("-g", "-fsanitize=address,undefined", "-fno-sanitize-recover=all")


@pytest.mark.parametrize("name", ["fig7_bowed_string", "poly_strings", "cymatic_sheet", "hyper_4d", "string_rattle",
                                  "piano_hammer"])
def test_sanitized_run_gives_the_python_runs_bits(name, c_export, monkeypatch, same_bits):
    monkeypatch.setenv("ASAN_OPTIONS", "detect_leaks=0")        # the test's driver keeps its buffers to the end
    path = ROOT / "patches" / f"{name}.yaml"
    built = c_export(path, extra=SANITIZE)
    audio, forces, inputs, rate = python_run(path, built.lowered, 0.2, 500)
    got = built.run(rate, len(audio), block=500, inputs=inputs, midi=midi_events(hapticgraph.load(path), rate))
    channels = audio.shape[1]
    assert same_bits(got[:, :channels], audio) and same_bits(got[:, channels:], forces)
