"""OSC over loopback UDP (python-osc, no mock): osc_in and `map: osc:` follow the messages sent
to the device's port; ProbeSender sends probes at the chosen rate of patch time."""
import time

import numpy as np
import pytest
from hapticgraph.devices import open_drivers
from hapticgraph.devices.osc import ProbeSender
from hapticgraph.graph.engine import ArraySink, Runner, stream
from osc_env import osc_listener
from pythonosc.dispatcher import Dispatcher
from pythonosc.osc_server import BlockingOSCUDPServer
from pythonosc.udp_client import SimpleUDPClient

import hapticgraph

PATCH = """
hapticgraph: 1
rate: 8000
devices:
  ctl: {driver: osc, port: 0}
blocks:
  fader: {type: osc_in, device: ctl, address: /fader/1}
  second: {type: osc_in, device: ctl, address: /xy, index: 1}
  src: {type: constant, value: 1.0}
  amp: {type: gain, gain: 0.0}
  out: {type: audio_out, channels: 1}
connect:
  - src.out -> amp.in
  - amp.out -> out.ch0
map:
  - {param: amp.gain, osc: /volume, min: 1.0, max: 3.0}
"""


def _play_until(session, want, blocks=500):
    seen = []
    for _ in range(blocks):
        time.sleep(session.blocksize / session.rate)
        seen.append(session.process(session.blocksize)[:, :3].copy())
        if want(seen[-1]):
            break
    return np.concatenate(seen)


def test_osc_in_and_map_over_loopback(write_patch):
    patch = hapticgraph.load(write_patch(PATCH))
    drivers = open_drivers(patch)
    session = Runner(patch, probes=["fader.out", "second.out"], drivers=drivers, blocksize=64)
    session.start()
    try:
        client = SimpleUDPClient("127.0.0.1", drivers["ctl"].port)
        before = session.process(64)[:, :3].copy()
        client.send_message("/fader/1", 0.25)
        client.send_message("/xy", [7.0, 0.75])
        client.send_message("/volume", 0.5)
        client.send_message("/other", 9.0)
        rec = _play_until(session, lambda r: r[-1, 0] == 2.0 and r[-1, 1] == 0.25 and r[-1, 2] == 0.75)
    finally:
        session.stop()
    assert np.all(before[:, 0] == 1.0) and np.all(before[:, 1:] == 0.0)   # gain from min; values 0 at first
    assert rec[-1].tolist() == [2.0, 0.25, 0.75]
    assert set(np.unique(rec[:, 1])) <= {0.0, 0.25}     # /other and the first /xy argument never reach it


def test_port_in_use_is_a_clear_error(write_patch):
    busy = BlockingOSCUDPServer(("127.0.0.1", 0), Dispatcher())
    try:
        patch = hapticgraph.load(write_patch(PATCH.replace("port: 0", f"port: {busy.server_address[1]}")))
        drivers = open_drivers(patch)
        with pytest.raises(Exception, match="cannot listen for OSC"):
            Runner(patch, drivers=drivers, blocksize=64).start()
    finally:
        busy.server_close()


def test_probe_sender_rate(write_patch):
    with osc_listener("/src/out", "/amp/out") as osc:
        patch = hapticgraph.load(write_patch(PATCH))
        sender = ProbeSender(ArraySink(), "127.0.0.1", osc.port, rate=100.0)
        stream(patch, 0.5, sender, probes=["src.out", "amp.out"], drivers=open_drivers(patch), chunk=300)
        osc.wait_for(100)
    assert sender.sent == 50                 # 0.5 s of patch time at 100 per second
    assert osc.got["/src/out"] == [1.0] * 50 and osc.got["/amp/out"] == [1.0] * 50
