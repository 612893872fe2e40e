"""An OSC listener for tests: a python-osc UDP server on a free loopback port, on its own thread."""
import contextlib
import threading
import time

from pythonosc.dispatcher import Dispatcher
from pythonosc.osc_server import BlockingOSCUDPServer


class Listener:
    """`port`; `got[address]`: the first argument of every message received there, in order."""

    def __init__(self, addresses):
        self.got = {address: [] for address in addresses}
        dispatcher = Dispatcher()
        for address in addresses:
            dispatcher.map(address, lambda addr, value: self.got[addr].append(value))
        self.server = BlockingOSCUDPServer(("127.0.0.1", 0), dispatcher)
        self.port = self.server.server_address[1]

    def wait_for(self, count, timeout=10.0):
        """Until `count` messages have come in all (or the timeout)."""
        deadline = time.monotonic() + timeout
        while sum(map(len, self.got.values())) < count and time.monotonic() < deadline:
            time.sleep(0.01)


@contextlib.contextmanager
def osc_listener(*addresses):
    listener = Listener(addresses)
    threading.Thread(target=listener.server.serve_forever, kwargs={"poll_interval": 0.02}, daemon=True).start()
    try:
        yield listener
    finally:
        listener.server.shutdown()
        listener.server.server_close()
