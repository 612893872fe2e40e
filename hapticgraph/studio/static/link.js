// The WebSocket to the studio (docs/studio.md): JSON commands with an id, each answered by one
// reply; events (hello, changed, problem, status); binary frames of cells, audio and probes.
const KIND_CELLS = 1, KIND_AUDIO = 2, KIND_PROBE = 3;

export class Link {
  constructor(url) {
    this.url = url;
    this.next = 1;
    this.waiting = new Map();
    this.handlers = { event: [], cells: [], audio: [], probe: [], close: [] };
    this.received = 0;         // cell frames received (one per frame counter, however many lattices)
    this.lastCounter = -1;
  }

  on(what, fn) { this.handlers[what].push(fn); }

  open() {
    return new Promise((resolve, reject) => {
      const ws = new WebSocket(this.url);
      ws.binaryType = "arraybuffer";
      this.ws = ws;
      let first = true;
      ws.onmessage = (m) => {
        if (typeof m.data !== "string") { this._binary(m.data); return; }
        const msg = JSON.parse(m.data);
        if (first && msg.type === "hello") { first = false; resolve(msg); }
        this._text(msg);
      };
      ws.onerror = () => reject(new Error("studio: the WebSocket could not be opened"));
      ws.onclose = () => {
        for (const [, w] of this.waiting) w.reject(new Error("studio: connection closed"));
        this.waiting.clear();
        this.handlers.close.forEach((f) => f());
      };
    });
  }

  // a command object without id -> a Promise of its reply (resolved whether ok or not)
  send(command) {
    const id = this.next++;
    return new Promise((resolve, reject) => {
      if (!this.ws || this.ws.readyState !== WebSocket.OPEN) { reject(new Error("studio: not connected")); return; }
      this.waiting.set(id, { resolve, reject });
      this.ws.send(JSON.stringify({ ...command, id }));
    });
  }

  _text(msg) {
    if (msg.type === "reply") {
      const w = this.waiting.get(msg.id);
      if (w) { this.waiting.delete(msg.id); w.resolve(msg); }
      return;
    }
    this.handlers.event.forEach((f) => f(msg));
  }

  _binary(buf) {
    const head = new DataView(buf);
    const kind = head.getUint8(0);
    if (kind === KIND_CELLS) {
      const ndim = head.getUint8(1), off = 16 + 4 * ndim, counter = head.getUint32(4, true);
      if (counter !== this.lastCounter) { this.received++; this.lastCounter = counter; }
      const frame = { lattice: head.getUint16(2, true), counter,
        sample: Number(head.getBigUint64(8, true)), values: new Float32Array(buf, off) };
      this.handlers.cells.forEach((f) => f(frame));
    } else if (kind === KIND_AUDIO || kind === KIND_PROBE) {
      const frame = { channels: head.getUint8(1), id: head.getUint16(2, true), counter: head.getUint32(4, true),
        sample: Number(head.getBigUint64(8, true)), rate: head.getUint32(16, true),
        frames: head.getUint32(20, true), data: new Float32Array(buf, 24) };
      this.handlers[kind === KIND_AUDIO ? "audio" : "probe"].forEach((f) => f(frame));
    }
  }
}
