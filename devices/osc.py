"""OSC over UDP with python-osc: in (`driver: osc`, block osc_in) and out (probes at a chosen rate).

    devices:
      ctl: {driver: osc, port: 9000}               # listens on 127.0.0.1:9000 (host: 0.0.0.0 for the network)
    blocks:
      fader: {type: osc_in, device: ctl, address: /fader/1}

A server thread receives every message; each is timestamped as it arrives and placed within the
audio block like a live MIDI event (hapticgraph.devices.events). An osc_in block holds the number
(argument `index`) of the last message sent to its exact `address`; True and False count as 1
and 0; other arguments are ignored.

OSC out: `ProbeSender(sink, host, port, rate)` wraps a sink of hapticgraph.graph.engine.stream (or
is used alone, as `play --probe P --osc-out HOST:PORT --osc-rate R` does) and sends each probe's
value as `/BLOCK/PORT value` at `rate` messages per second of the patch's time, so a visualizer
can follow the model.
"""
import threading

from .errors import DeviceError
from .events import Hub, Tap



class OscHub(Hub):
    """The driver of a `driver: osc` device entry: a UDP server on its own thread."""

    def __init__(self, name, spec):
        super().__init__(name)
        self.host, self.port = spec.get("host", "127.0.0.1"), int(spec.get("port", 9000))
        self.server = self.thread = None

    def start(self, rate):
        super().start(rate)
        if self.server is not None:
            return
        from pythonosc.dispatcher import Dispatcher
        from pythonosc.osc_server import BlockingOSCUDPServer
        dispatcher = Dispatcher()
        dispatcher.set_default_handler(lambda address, *args: self.post((address, args)))
        try:
            self.server = BlockingOSCUDPServer((self.host, self.port), dispatcher)
        except OSError as exc:
            raise DeviceError(f"device {self.name!r}: cannot listen for OSC on {self.host}:{self.port}: {exc}") from None
        self.port = self.server.server_address[1]         # the one given, or the one chosen for port 0
        self.thread = threading.Thread(target=self.server.serve_forever, kwargs={"poll_interval": 0.05},
                                       name=f"osc-{self.name}", daemon=True)
        self.thread.start()

    def stop(self):
        server, self.server = self.server, None
        if server is not None:
            server.shutdown()
            server.server_close()
            self.thread.join(timeout=2.0)

    def tap(self, inst):
        return OscTap(self, inst)


class OscTap(Tap):
    """osc_in: the number at `index` of the last message to `address`."""

    columns = ("osc_value",)

    def __init__(self, hub, inst):
        self.address, self.index = inst.values["address"], int(inst.values.get("index", 0))
        super().__init__(hub, inst)

    def apply(self, message):
        address, args = message
        if address == self.address and len(args) > self.index:
            value = args[self.index]
            if isinstance(value, (int, float)):
                self.row[0] = float(value)


class ProbeSender:
    """Sends the probes of a stream as OSC (`/BLOCK/PORT value`, one message per probe) to
    host:port, `rate` times per second of patch time (the value at each tick), then hands the
    block on to `sink` if one is given.

    `write` only picks the values: a thread of its own builds and sends the messages, so the
    audio callback of `play` never waits on the network (python-osc's SimpleUDPClient). `close()`
    sends what is queued and stops the thread."""

    def __init__(self, sink=None, host="127.0.0.1", port=9001, rate=30.0):
        import queue

        from pythonosc.udp_client import SimpleUDPClient
        self.sink, self.client, self.every = sink, SimpleUDPClient(host, int(port)), None
        self.send_rate = float(rate)
        self.sent = 0
        self.queue = queue.SimpleQueue()
        self.thread = threading.Thread(target=self._send_loop, name="osc-out", daemon=True)
        self.thread.start()

    def start(self, rate, channels, probes, total):
        self.channels, self.addresses = channels, ["/" + p.replace(".", "/") for p in probes]
        self.every, self.t, self.next = max(1, round(rate / self.send_rate)), 0, 0
        if self.sink is not None:
            self.sink.start(rate, channels, probes, total)

    def write(self, block):
        n, first, last = block.shape[0], self.channels, self.channels + len(self.addresses)
        while self.next < self.t + n:
            self.queue.put(block[self.next - self.t, first:last].tolist())
            self.sent += 1
            self.next += self.every
        self.t += n
        if self.sink is not None:
            self.sink.write(block)

    def _send_loop(self):
        while True:
            values = self.queue.get()
            if values is None:
                return
            for address, value in zip(self.addresses, values):
                try:
                    self.client.send_message(address, float(value))
                except OSError:
                    pass          # nobody listening, or the network went away: the model plays on

    def close(self):
        if self.thread.is_alive():
            self.queue.put(None)
            self.thread.join(timeout=5.0)

    def result(self, streamed):
        self.close()
        return self.sink.result(streamed) if self.sink is not None else None


def parse_target(text):
    """`--osc-out`'s HOST:PORT (or PORT alone: this machine) as (host, port); ValueError if not."""
    host, _, port = str(text).rpartition(":")
    try:
        number = int(port)
    except ValueError:
        raise ValueError(f"--osc-out {text!r}: expected HOST:PORT or PORT (e.g. 127.0.0.1:9001)") from None
    if not 0 < number < 65536:
        raise ValueError(f"--osc-out {text!r}: the port must be from 1 to 65535")
    return host or "127.0.0.1", number


__all__ = ["OscHub", "OscTap", "ProbeSender", "parse_target"]
