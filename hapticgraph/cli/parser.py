"""The `hapticgraph` command line's arguments: one function per command adds its options, its
description and its examples. Building the parser imports argparse only, so `--help` and a usage
error start at once."""
import argparse
import textwrap

from .. import __version__


def build_parser():
    ap = argparse.ArgumentParser(
        prog="hapticgraph", formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Physical-model haptic instruments from YAML patches, compiled to one kernel.",
        epilog="examples:\n"
               "  hapticgraph check patches/karplus_strong.yaml\n"
               "  hapticgraph run patches/karplus_strong.yaml --seconds 2 --out karplus_strong.wav\n"
               "  hapticgraph COMMAND --help        (each command's options and examples)\n\n"
               "exit status: 0 success, 2 a patch or command-line error, 1 anything else")
    ap.add_argument("--version", action="version", version=f"hapticgraph {__version__}")
    sub = ap.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in (_add_run, _add_play, _add_devices, _add_check, _add_blocks, _add_schema, _add_graph, _add_plot,
                _add_modes, _add_studio):
        add(sub)
    for add in (_add_sweep, _add_fit):      # many renders on Dask (cli/sweep.py)
        add(sub)
    _add_export(sub)                        # the instrument outside Python (cli/export.py)
    _add_hid(sub)                           # HID devices from their descriptors (cli/hid.py)
    return ap


def _command(sub, name, help, description, examples):
    """A subcommand whose --help has a description and examples (shown as written)."""
    epilog = "examples:\n" + "\n".join(f"  {e}" for e in examples)
    return sub.add_parser(name, help=help, description=textwrap.fill(description, 88), epilog=epilog,
                          formatter_class=argparse.RawDescriptionHelpFormatter)


def _overrides(parser):
    parser.add_argument("--set", action="append", default=[], metavar="BLOCK.PARAM=VALUE", dest="overrides",
                        help="override a parameter (repeatable)")


def _device_option(parser):
    parser.add_argument("--device", action="append", default=[], metavar="NAME=DRIVER[,KEY=VALUE...]",
                        help="choose a device's driver (simulated, hid, replay) and settings that override its "
                             "entry's, e.g. finger=hid,profile=haptic_1dof,max_force=2 (repeatable)")


def _add_run(sub):
    run = _command(sub, "run", "render a patch offline to an audio file (and probes to .npz)",
                   "Render a patch offline, as fast as the machine allows, to an audio file (the format "
                   "follows the extension: .wav, .flac, .ogg) and, with --probe, the probed signals to "
                   ".npz. Devices run on their drivers (the simulated device by default).",
                   ["hapticgraph run patches/karplus_strong.yaml --seconds 2 --out karplus_strong.wav",
                    "hapticgraph run patches/karplus_strong.yaml --out ks.flac --set damp.gain=0.99",
                    "hapticgraph run patches/fig8_pluck_damp.yaml --probe tip.force --probe finger.x",
                    "hapticgraph run my_string.yaml --replay take.hgrec"])
    run.add_argument("patch")
    run.add_argument("--seconds", type=float, default=None,
                     help="length to render (default 2; with --replay, the take's length)")
    run.add_argument("--out", help="audio file to write, its format chosen by the extension: .wav, .flac, "
                                    ".ogg, .mp3, .aiff (default: the patch's name, .wav, here)")
    run.add_argument("--probe", action="append", default=[], metavar="BLOCK.PORT",
                     help="record a port (repeatable); a cell's port is name[i, j].port")
    run.add_argument("--probes", metavar="FILE.npz", help="where the probes go (default: beside the WAV)")
    _overrides(run)
    run.add_argument("--engine", choices=("compiled", "python"), default="compiled",
                     help="compiled numba kernel (default) or the reference interpreter")
    _device_option(run)
    run.add_argument("-q", "--quiet", action="store_true",
                     help="print nothing on success: no progress bar, no summary (errors still go to stderr)")
    run.add_argument("--subtype", metavar="PCM_16|PCM_24|FLOAT", type=str.upper,
                     help="sample format of --out, in soundfile's names (default: FLOAT for WAV and "
                          "AIFF, PCM_24 for FLAC)")
    run.add_argument("--replay", metavar="TAKE.hgrec",
                     help="feed every device and live input from a take made by `play --record` "
                          "(--seconds defaults to the take's length)")


def _add_play(sub):
    play = _command(sub, "play", "play a patch in real time through the sound card",
                    "Play a patch in real time: the sound card's clock drives the kernel block by block; "
                    "devices are read on their own threads and every force sent is clamped to the "
                    "device's max_force. Runs until Ctrl-C unless --seconds is given.",
                    ["hapticgraph play patches/karplus_strong.yaml --seconds 2",
                     "hapticgraph play my_string.yaml --device finger=hid,profile=haptic_1dof --blocksize 64",
                     "hapticgraph play my_string.yaml --record take --watch",
                     "hapticgraph play patches/cymatic_sheet.yaml --console",
                     "hapticgraph play patches/fig8_pluck_damp.yaml --probe finger.x --osc-out 127.0.0.1:9001"])
    play.add_argument("patch")
    play.add_argument("--audio-device", metavar="D", help="output device: index or (part of) its name "
                      "(see `hapticgraph devices`; default: the system's default)")
    play.add_argument("--input-device", metavar="D", help="input device for live audio_in blocks (default: the default)")
    play.add_argument("--blocksize", type=int, default=128, metavar="N",
                      help="frames per audio callback, the kernel's block (default 128)")
    play.add_argument("--latency", default="low", metavar="low|high|SECONDS",
                      help="PortAudio's suggested output latency (default low)")
    play.add_argument("--seconds", type=float, default=None, metavar="S",
                      help="stop after S seconds (default: play until Ctrl-C)")
    play.add_argument("--record", metavar="TAKE", help="record the device inputs to TAKE.hgrec and the "
                      "audio to TAKE.wav (replay with `hapticgraph run PATCH --replay TAKE.hgrec`)")
    play.add_argument("--replay", metavar="TAKE.hgrec", help="play a recorded take back through the sound card")
    play.add_argument("--console", action="store_true",
                      help="read edits from standard input while playing: set BLOCK.PARAM VALUE, "
                           "lock/unlock/cut NAME[i, j] (lattices then run on their editable CSR path)")
    play.add_argument("--watch", action="store_true", help="reload the patch when its file changes, keeping "
                      "the state of every block that did not change")
    play.add_argument("--probe", action="append", default=[], metavar="BLOCK.PORT",
                      help="a port sent by --osc-out as /BLOCK/PORT (repeatable)")
    play.add_argument("--osc-out", metavar="[HOST:]PORT",
                      help="send the --probe values over OSC (UDP) to HOST:PORT (default host: this machine)")
    play.add_argument("--osc-rate", type=float, default=30.0, metavar="HZ",
                      help="messages per probe per second of patch time (default 30)")
    _overrides(play)
    _device_option(play)
    play.add_argument("--fade", type=float, default=0.005, metavar="SECONDS", help=argparse.SUPPRESS)


def _add_devices(sub):
    _command(sub, "devices", "list sound cards and HID devices",
             "List the sound cards PortAudio sees (index, name, channels, rate) and the HID devices "
             "hidapi sees (vendor:product id, name, the shipped profile that matches).",
             ["hapticgraph devices", "hapticgraph play PATCH --audio-device 3"])


def _add_check(sub):
    check = _command(sub, "check", "check a patch and report every problem",
                     "Load and check a patch without compiling or running it: every problem is printed "
                     "as FILE:LINE: message (exit 2); a good patch prints ok and its schedule.",
                     ["hapticgraph check patches/karplus_strong.yaml",
                      "hapticgraph check my_string.yaml --set bridge.gain=-0.99"])
    check.add_argument("patch")
    _overrides(check)


def _add_blocks(sub):
    blocks = _command(sub, "blocks", "list the block types (built-in and plugins)",
                      "List every block type: its input ports (* a live parameter, also an input), its "
                      "outputs, its equation and its parameters with units and defaults.",
                      ["hapticgraph blocks", "hapticgraph blocks --markdown > docs/blocks.md",
                       "hapticgraph blocks --patch examples/file_plugin/saturated_string.yaml --json"])
    blocks.add_argument("--json", action="store_true", help="machine-readable")
    blocks.add_argument("--markdown", action="store_true", help="the block reference (docs/blocks.md)")
    blocks.add_argument("--patch", help="also load this patch's plugins")


def _add_schema(sub):
    _command(sub, "schema", "print the JSON Schema of a patch (for editors)",
             "Print the JSON Schema of a patch, assembled from every block's declarations, for an "
             "editor's YAML support (completion and checking of block types and parameters).",
             ["hapticgraph schema > hapticgraph.schema.json"])


def _add_graph(sub):
    graph = _command(sub, "graph", "export the patch graph as Graphviz dot or Mermaid",
                     "Write the patch's blocks and connections as a Graphviz dot or Mermaid graph "
                     "(nothing is compiled).",
                     ["hapticgraph graph patches/karplus_strong.yaml --format mermaid",
                      "hapticgraph graph patches/karplus_strong.yaml -o ks.dot && dot -Tpng ks.dot -o ks.png"])
    graph.add_argument("patch")
    graph.add_argument("--format", choices=("dot", "mermaid"), default="dot", help="default dot")
    graph.add_argument("-o", "--out", metavar="FILE", help="write here instead of standard output")


def _add_plot(sub):
    plot = _command(sub, "plot", "render a patch and draw probe traces and a spectrogram to PNG",
                    "Render a patch and draw each probe against time [s], in its quantity and unit, "
                    "above a spectrogram (frequency [Hz]) of the audio; or, with --mode N, draw mode N "
                    "of a lattice (numbered from 1, the lowest, as `hapticgraph modes` lists them). "
                    "Needs matplotlib: pip install \"hapticgraph[plot]\".",
                    ["hapticgraph plot patches/karplus_strong.yaml --probe loop.out --window 0 0.02 -o ks.png",
                     "hapticgraph plot patches/fig8_pluck_damp.yaml --seconds 1.5 --probe finger.x "
                     "--probe tip.force -o fig8.png",
                     "hapticgraph plot patches/babe_is_sleeping.yaml --lattice cym_a --mode 5 -o mode.png"])
    plot.add_argument("patch")
    plot.add_argument("--probe", action="append", default=[], metavar="BLOCK.PORT", help="a trace to draw (repeatable)")
    plot.add_argument("-o", "--out", required=True, metavar="FILE.png", help="the PNG to write")
    plot.add_argument("--seconds", type=float, default=1.0, help="length to render (default 1)")
    plot.add_argument("--window", nargs=2, type=float, metavar=("T0", "T1"), help="time window of the traces [s]")
    plot.add_argument("--spectrogram", default="audio", metavar="audio|BLOCK.PORT|none",
                      help="what the spectrogram shows (default: the audio)")
    _overrides(plot)
    plot.add_argument("--title", default=None, help="the figure's title (default: the patch's name)")
    plot.add_argument("--mode", type=int, metavar="N",
                      help="draw mode N of a lattice instead of rendering (1: the lowest, as `modes` "
                           "numbers them)")
    plot.add_argument("--lattice", metavar="NAME", help="the lattice or cell block whose mode is drawn "
                      "(default: the first)")


def _add_modes(sub):
    modes = _command(sub, "modes", "predicted modal frequencies of each mass-spring network",
                     "Predict the lowest modal frequencies of each mass-spring network (lossless, with "
                     "the half-step scheme's discrete-time correction), numbered from 1 (the lowest), "
                     "so an instrument can be tuned before it is heard.",
                     ["hapticgraph modes patches/cymatic_string.yaml --count 5",
                      "hapticgraph modes patches/babe_is_sleeping.yaml --json",
                      "hapticgraph plot patches/babe_is_sleeping.yaml --lattice cym_a --mode 5 -o mode.png"])
    modes.add_argument("patch")
    modes.add_argument("--count", type=int, default=20, metavar="N", help="modes per network (default 20)")
    modes.add_argument("--json", action="store_true", help="machine-readable")
    _overrides(modes)


# -- studio (issue 22): the design page --------------------------------------------------------
def _add_studio(sub):
    studio = _command(sub, "studio", "design an instrument in a browser page while it plays",
                      "Serve a local page that shows the patch's instrument moving, shapes it with the mouse "
                      "(lock, cut, join, place microphones and excitations, parameters) while it plays and "
                      "saves every edit back into the patch with its comments kept. The first line printed is "
                      "the page's URL with its token; the WebSocket protocol is in docs/studio.md.",
                      ["hapticgraph studio patches/cymatic_block.yaml",
                       "hapticgraph studio patches/cymatic_sheet.yaml --audio browser --no-browser",
                       "hapticgraph studio my_string.yaml --audio none --port 8765"])
    studio.add_argument("patch")
    studio.add_argument("--host", default="127.0.0.1",
                        help="address to serve on (default 127.0.0.1: this machine only)")
    studio.add_argument("--port", type=int, default=0, help="port (default 0: any free one)")
    studio.add_argument("--no-browser", action="store_true", help="do not open a browser")
    studio.add_argument("--audio", choices=("card", "browser", "none"), default=None,
                        help="card: the sound card paces the sound, as play; browser: paced by the clock and "
                             "played by the page; none: paced by the clock, silent (default: card when a sound "
                             "card opens, else browser)")
    studio.add_argument("--audio-device", metavar="D", help="with --audio card: the output device, as in play")
    studio.add_argument("--blocksize", type=int, default=256, metavar="N", help="samples per block (default 256)")
    studio.add_argument("--fps", type=float, default=60.0, help="most cell frames a second sent to a page (default 60)")
    _device_option(studio)


# -- sweep and fit: many renders on a Dask cluster (cli/sweep.py) ---------------------

def _cluster_options(parser):
    parser.add_argument("--workers", type=int, metavar="N",
                        help="worker processes of the local Dask cluster (default: one per core)")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786")
    parser.add_argument("--scheduler-file", metavar="F", help="a running Dask cluster's scheduler file")
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="print nothing on success: no progress bar, no summary (errors still go to stderr)")


def _add_sweep(sub):
    sweep = _command(sub, "sweep", "render every variant of a sweep file on Dask, with a manifest",
                     "Render every variant of a sweep file (a patch, axes of parameter values, a sampler) "
                     "on a Dask cluster, a local one by default: DIR/manifest.csv gets one row per variant "
                     "(status, features, audio file) as results arrive, audio goes to DIR/audio/. Every "
                     "value is checked before anything runs (FILE:LINE, exit 2); a variant that fails is "
                     "a row. Exit 0 when every variant is ok, 1 otherwise.",
                     ["hapticgraph sweep timbre.yaml --out runs/timbre",
                      "hapticgraph sweep timbre.yaml --out runs/timbre --dry-run",
                      "hapticgraph sweep timbre.yaml --out runs/timbre --resume --limit 100",
                      "hapticgraph sweep timbre.yaml --out runs/timbre --scheduler tcp://10.0.0.5:8786"])
    sweep.add_argument("sweep", metavar="SWEEP.yaml")
    sweep.add_argument("--out", required=True, metavar="DIR", help="the results folder")
    _cluster_options(sweep)
    sweep.add_argument("--resume", action="store_true",
                       help="continue the sweep in DIR: render only the variants with no row yet, or whose "
                            "row says killed or timeout (one row per variant; a re-tried one replaces its row)")
    sweep.add_argument("--retry-failed", action="store_true",
                       help="with --resume, render again the variants whose row says runaway, invalid or error "
                            "too (they give the same answer every time unless something changed)")
    sweep.add_argument("--limit", type=int, metavar="N", help="render at most N of the variants still to do")
    sweep.add_argument("--dry-run", action="store_true", help="check the sweep and print the variant table; render nothing")


def _add_fit(sub):
    fit = _command(sub, "fit", "find the parameter values whose sound matches a recording",
                   "Fit the axes of AXES.yaml (block.param: {min, max}) so that the patch's sound matches "
                   "TAKE.wav: a multi-resolution spectral distance plus feature errors, minimised by "
                   "scipy's differential evolution evaluated in parallel on Dask. Every evaluation is a row of RESULTS/manifest.csv; the "
                   "best patch is written with the found values.",
                   ["hapticgraph fit ks.yaml --target take.wav --axes axes.yaml --out ks_fitted.yaml",
                    "hapticgraph fit ks.yaml --target take.wav --axes axes.yaml --popsize 8 --maxiter 30"])
    fit.add_argument("patch")
    fit.add_argument("--target", required=True, metavar="TAKE.wav", help="the recording to match")
    fit.add_argument("--axes", required=True, metavar="AXES.yaml", help="block.param: {min: …, max: …, scale: linear|log}")
    fit.add_argument("--out", metavar="PATCH.yaml", help="the best patch (default: PATCH_fit.yaml beside PATCH)")
    fit.add_argument("--results", metavar="DIR", help="the folder of the evaluations' manifest (default: PATCH_fit/)")
    fit.add_argument("--seconds", type=float, metavar="S", help="length rendered (default: the target's, at most 2 s)")
    fit.add_argument("--seed", type=int, default=1, help="the optimiser's seed (default 1)")
    fit.add_argument("--popsize", type=int, default=10, help="population per axis (default 10)")
    fit.add_argument("--maxiter", type=int, default=40, help="generations at most (default 40)")
    _cluster_options(fit)


# -- export: the patch's kernel as C, an LV2 plugin or WebAssembly (cli/export.py) -----------------
def _add_export(sub):
    export = _command(sub, "export", "export a patch as C, an LV2 plugin or a WebAssembly module",
                      "Lower the patch's program (the IR its kernel is compiled from) to plain C99 "
                      "(NAME.h, NAME.c: NAME_new(rate), NAME_process, NAME_set, tables of ports and "
                      "parameters), built into an LV2 bundle or a WebAssembly module with an AudioWorklet "
                      "wrapper. Its output equals `hapticgraph run`'s (WebAssembly: within the 1-ulp differences "
                      "of its libm, docs/export.md). A block whose meaning calls Python "
                      "is refused at its FILE:LINE (exit 2).",
                      ["hapticgraph export patches/karplus_strong.yaml --to c --out build/ks",
                       "hapticgraph export patches/karplus_strong.yaml --to lv2 --out build --install",
                       "hapticgraph export patches/karplus_strong.yaml --to wasm --out site/ks"])
    export.add_argument("patch")
    export.add_argument("--to", required=True, choices=("c", "lv2", "wasm"), help="what to write")
    export.add_argument("--out", required=True, metavar="DIR", help="the folder written into")
    export.add_argument("--name", metavar="NAME", help="the C identifier prefix and file name "
                                                       "(default: the patch file's name)")
    _overrides(export)
    export.add_argument("--install", action="store_true", help="with --to lv2: copy the bundle into ~/.lv2")


# -- hid: what a HID device says about itself (cli/hid.py) --------------------------------------------
def _add_hid(sub):
    hid = _command(sub, "hid", "read HID report descriptors: describe a device, write a profile",
                   "Parse a HID report descriptor (raw bytes, a hex dump, or a hid-recorder recording's "
                   "R: line) and name every input from the HID usage tables (x, y, rz, slider, hat_x, "
                   "button1, ...), as a patch's {driver: hid, match: ...} device sees it.",
                   ["hapticgraph hid describe stick.hid",
                    "hapticgraph hid describe stick.hid --json",
                    "hapticgraph hid profile stick.hid > stick.yaml"])
    action = hid.add_subparsers(dest="hid_command", required=True, metavar="ACTION")
    describe = action.add_parser("describe", help="print the inputs and force outputs of a descriptor")
    describe.add_argument("file", metavar="FILE", help="a descriptor: raw bytes, a hex dump or a hid-recorder recording")
    describe.add_argument("--json", action="store_true", help="a JSON list of the fields")
    profile = action.add_parser("profile", help="write a commented device profile from a descriptor, to edit")
    profile.add_argument("device", metavar="DEVICE_OR_FILE",
                         help="a descriptor file, or a connected device as VENDOR:PRODUCT (hex) or its path")
