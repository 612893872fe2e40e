// The WebSocket to the studio (docs/studio.md): JSON commands with an id, each answered by one
// reply; events (hello, changed, problem, status, recovery); binary frames of cells, audio and
// probes. A socket that closes after its hello is opened again by itself (the same studio back
// after a dropped connection: a laptop's sleep, a message over the server's limit), after
// RETRY_FIRST_MS, then twice as long each time up to RETRY_MAX_MS, for as long as the page is open.
const KIND_CELLS = 1, KIND_AUDIO = 2, KIND_PROBE = 3;
const RETRY_FIRST_MS = 250, RETRY_MAX_MS = 5000;

export class Link {
  constructor(url) {
    this.url = url;
    this.next = 1;
    this.waiting = new Map();
    // hello: each hello after the first (a connection opened again); close: a connection lost;
    // retry: a try to open it again failed (the number of tries so far)
    this.handlers = { hello: [], event: [], cells: [], audio: [], probe: [], close: [], retry: [] };
    this.received = 0;         // cell frames received (one per frame counter, however many lattices)
    this.lastCounter = -1;
    this.opened = 0;           // connections that got their hello
    this.attempts = 0;         // tries to open it again since the last connection was lost
    this.retryMs = RETRY_FIRST_MS;
  }

  on(what, fn) { this.handlers[what].push(fn); }

  // a Promise of the first hello; a first connection that cannot be opened is not tried again
  // (the page was opened with a wrong URL), one lost later is
  open() {
    return new Promise((resolve, reject) => { this._connect(resolve, reject); });
  }

  _connect(resolve, reject) {
    const ws = new WebSocket(this.url);
    ws.binaryType = "arraybuffer";
    this.ws = ws;
    let greeted = false;
    ws.onmessage = (m) => {
      if (typeof m.data !== "string") { this._binary(m.data); return; }
      const msg = JSON.parse(m.data);
      if (!greeted && msg.type === "hello") {
        greeted = true;
        this.opened++;
        this.attempts = 0;
        this.retryMs = RETRY_FIRST_MS;
        if (this.opened === 1) resolve(msg);
        else this.handlers.hello.forEach((f) => f(msg));
        return;
      }
      this._text(msg);
    };
    ws.onclose = () => {
      for (const [, w] of this.waiting) w.reject(new Error("studio: connection closed"));
      this.waiting.clear();
      if (this.opened === 0) { reject(new Error("studio: the WebSocket could not be opened")); return; }
      if (greeted) this.handlers.close.forEach((f) => f());
      else this.handlers.retry.forEach((f) => f(this.attempts));
      this.attempts++;
      setTimeout(() => this._connect(resolve, reject), this.retryMs);
      this.retryMs = Math.min(RETRY_MAX_MS, 2 * this.retryMs);
    };
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
