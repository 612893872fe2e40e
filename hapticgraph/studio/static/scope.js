// A scope (uPlot: drag to zoom, double-click to unzoom) and a scrolling spectrogram (linear or
// log frequency) on any signal `--probe` accepts; both freeze. The last seconds of the probed
// signal are kept for the modes panel's measured spectrum.
import uPlot from "./vendor/uplot/uPlot.esm.js";
import { $, el, fmt } from "./dom.js";
import { spectrumDb } from "./fft.js";

const KEEP_S = 4;           // seconds of signal kept
const POINTS = 1500;        // the scope draws at most this many min/max pairs
const HOP = 512, NFFT = 4096, RANGE_DB = 70, PEAK_FALL_DB = 0.5;   // per column: the top of the scale falls slowly

// dark blue - purple - orange - pale yellow
function heat(v) {
  return [Math.round(255 * Math.min(1, 1.6 * v)), Math.round(255 * Math.max(0, 1.4 * v - 0.4)), Math.round(60 + 120 * Math.sin(Math.PI * Math.min(1, v * 1.2))), 255];
}

export class Scopes {
  constructor(ctx) {
    this.ctx = ctx;
    this.rate = 44100;
    this.buf = new Float32Array(KEEP_S * this.rate);
    this.len = 0;               // samples in buf
    this.total = 0;             // samples received since the probe started
    this.lastColumn = 0;
    this.probeId = null;
    this.signal = null;
    this.plot = new uPlot({ width: 520, height: 200, scales: { x: { time: false } },
      series: [{ label: "t [s]" }, { label: "value", stroke: "#3388ff", width: 1 }], axes: [{ stroke: "#aaa" }, { stroke: "#aaa", size: 70, values: (u, ticks) => ticks.map(fmt) }] },
    [[0], [0]], $("#scope"));
    ctx.link.on("probe", (f) => { if (f.id === this.probeId) this._take(f); });
    $("#probe-go").onclick = () => this.probe($("#probe-signal").value);
    $("#probe-signal").addEventListener("keydown", (e) => { if (e.key === "Enter") this.probe(e.target.value); });
    this.spec = $("#spectrogram").getContext("2d");
    setInterval(() => this._drawScope(), 50);
  }

  update(desc) {
    const list = $("#probe-signals");
    list.innerHTML = "";
    const names = [];
    for (const m of desc.microphones) names.push(`${m.block}.left`, `${m.block}.right`, m.cell && `${m.cell}.${m.port || "velocity"}`);
    for (const e of desc.excitations) names.push(`${e.block}.out`, e.cell && `${e.cell}.position`);
    for (const n of names) if (n) list.append(el("option", { value: n }));
    this.first = desc.microphones.length ? `${desc.microphones[0].block}.left` : null;
  }

  // the first microphone is probed when a panel that shows a signal is first opened (a probe
  // streams the signal at the full rate: not asked for while nobody looks)
  wake() {
    if (!this.signal && this.first) this.probe(this.first, true);
  }

  async probe(signal, quiet = false) {
    signal = (signal || "").trim();
    if (!signal) return null;
    const r = await (quiet ? this.ctx.link.send({ cmd: "probe", signal }) : this.ctx.send({ cmd: "probe", signal }));
    if (!r.ok) return r;
    if (this.probeId !== null && this.probeId !== r.result.probe) this.ctx.link.send({ cmd: "unprobe", probe: this.probeId }).catch(() => {});
    this.probeId = r.result.probe;
    this.signal = signal;
    $("#probe-signal").value = signal;
    if (r.result.rate !== this.rate) { this.rate = r.result.rate; this.buf = new Float32Array(KEEP_S * this.rate); }
    this.len = 0; this.total = 0; this.lastColumn = 0; this.top = undefined;
    return r;
  }

  get frozen() { return $("#scope-freeze").checked; }

  _take(f) {
    if (this.frozen) return;
    const d = f.data, cap = this.buf.length;
    if (this.len + d.length > cap) {
      const drop = this.len + d.length - cap;
      this.buf.copyWithin(0, drop, this.len);
      this.len -= drop;
    }
    this.buf.set(d, this.len);
    this.len += d.length;
    this.total += d.length;
    const shown = !$("#tab-scope").hidden && !document.hidden;
    while (this.total - this.lastColumn >= HOP) {
      this.lastColumn += HOP;
      if (shown) this._column(this.len - (this.total - this.lastColumn));
    }
  }

  _drawScope() {
    if (this.frozen || !this.len || document.hidden || $("#tab-scope").hidden) return;
    const n = Math.min(this.len, Math.round(Number($("#scope-window").value) * this.rate));
    const start = this.len - n, per = Math.max(1, Math.ceil(n / POINTS)), t0 = (this.total - n) / this.rate;
    const xs = [], ys = [];
    for (let i = 0; i < n; i += per) {
      let lo = Infinity, hi = -Infinity;
      for (let j = i; j < Math.min(n, i + per); j++) { const v = this.buf[start + j]; if (v < lo) lo = v; if (v > hi) hi = v; }
      const t = t0 + i / this.rate;
      xs.push(t, t + per / (2 * this.rate)); ys.push(lo, hi);
    }
    this.plot.setData([xs, ys]);
  }

  // one column of the spectrogram, ending at sample `end` of buf
  _column(end) {
    const canvas = this.spec.canvas, w = canvas.width, h = canvas.height;
    if (end < NFFT) return;
    const db = spectrumDb(this.buf, end, NFFT);
    this.spec.drawImage(canvas, -1, 0);
    const top = Math.min(Number($("#spec-top").value), this.rate / 2), log = $("#spec-log").checked;
    // one scale for the columns (a fading peak), so a decaying sound is seen to decay
    let peak = -Infinity;
    for (let k = 1; k < db.length; k++) peak = Math.max(peak, db[k]);
    this.top = Math.max(peak, (this.top ?? peak) - PEAK_FALL_DB);
    const img = this.spec.createImageData(1, h);
    for (let y = 0; y < h; y++) {
      const u = 1 - y / (h - 1);
      const f = log ? 20 * (top / 20) ** u : u * top;
      const v = Math.min(1, Math.max(0, (db[Math.min(db.length - 1, Math.round((f * NFFT) / this.rate))] - this.top + RANGE_DB) / RANGE_DB));
      img.data.set(heat(v), 4 * y);
    }
    this.spec.putImageData(img, w - 1, 0);
  }

  // the measured spectrum of the last `n` samples (for the modes panel): {hz per bin, db}
  spectrum(n = 16384) {
    while (n > this.len && n > 1024) n /= 2;
    if (this.len < n) return null;
    return { binHz: this.rate / n, db: spectrumDb(this.buf, this.len, n), signal: this.signal };
  }
}
