// A scope (uPlot: drag to zoom, double-click to unzoom) and a scrolling spectrogram (linear or
// log frequency) on any signal `--probe` accepts; both freeze. Both count in the session's time
// (the sample index each probe frame carries), as the header's `t` does. The last seconds of the
// probed signal are kept for the modes panel's measured spectrum.
import uPlot from "./vendor/uplot/uPlot.esm.js";
import { $, el } from "./dom.js";
import { spectrumDb } from "./fft.js";
import { AXIS_FONT, label } from "./axis.js";
import { Spectrogram } from "./spectrogram.js";

const KEEP_S = 4;           // seconds of signal kept
const POINTS = 1500;        // the scope draws at most this many min/max pairs
const TICK = 10, GAP = 5, SLACK = 6;   // uPlot's tick length and label gap; room to spare [px]

// the room a value axis needs for its widest label (uPlot otherwise clips what does not fit)
function axisSize(u, values) {
  const g = axisSize.g || (axisSize.g = document.createElement("canvas").getContext("2d"));
  g.font = AXIS_FONT;
  const widest = Math.max(0, ...(values || []).map((s) => g.measureText(s).width));
  return Math.ceil(widest) + TICK + GAP + SLACK;
}

export class Scopes {
  constructor(ctx) {
    this.ctx = ctx;
    ctx.studio.scopes = this;   // the scripting door (tests read the axes)
    this.rate = 44100;
    this.buf = new Float32Array(KEEP_S * this.rate);
    this.len = 0;               // samples in buf
    this.end = 0;               // the session's sample index just after buf's last sample
    this.probeId = null;
    this.signal = null;
    this.labels = { x: [], y: [] };
    const keep = (axis) => (u, ticks) => (this.labels[axis] = ticks.map(label));
    this.plot = new uPlot({ width: 520, height: 200, scales: { x: { time: false } },
      series: [{ label: "t [s]" }, { label: "value", stroke: "#3388ff", width: 1 }],
      axes: [{ stroke: "#aaa", font: AXIS_FONT, values: keep("x"), label: "session time t [s]", labelSize: 18, labelFont: AXIS_FONT },
        { stroke: "#aaa", font: AXIS_FONT, values: keep("y"), size: axisSize }] },
    [[0], [0]], $("#scope"));
    this.spectrogram = new Spectrogram($("#spectrogram"));
    ctx.link.on("probe", (f) => { if (f.id === this.probeId) this._take(f); });
    $("#probe-go").onclick = () => this.probe($("#probe-signal").value);
    $("#probe-signal").addEventListener("keydown", (e) => { if (e.key === "Enter") this.probe(e.target.value); });
    for (const id of ["#spec-log", "#spec-top"]) $(id).addEventListener("change", () => this.spectrogram.draw(this._specOptions()));
    setInterval(() => this._draw(), 50);
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
    this.len = 0;
    this.spectrogram.reset(this.rate);
    return r;
  }

  get frozen() { return $("#scope-freeze").checked; }

  _take(f) {
    if (this.frozen) return;
    const d = f.data, cap = this.buf.length;
    // a gap in the sample index (frames the server dropped) starts the kept signal again
    if (this.len && f.sample !== this.end) this.len = 0;
    if (this.len + d.length > cap) {
      const drop = this.len + d.length - cap;
      this.buf.copyWithin(0, drop, this.len);
      this.len -= drop;
    }
    this.buf.set(d, this.len);
    this.len += d.length;
    this.end = f.sample + d.length;
    const shown = !$("#tab-scope").hidden && !document.hidden;
    this.spectrogram.take(this.buf, this.len, this.end, shown);
  }

  _specOptions() {
    return { top: Math.min(Number($("#spec-top").value), this.rate / 2), log: $("#spec-log").checked };
  }

  _draw() {
    if (this.frozen || !this.len || document.hidden || $("#tab-scope").hidden) return;
    const width = $("#scope").clientWidth;
    if (width && width !== this.plot.width) this.plot.setSize({ width, height: 200 });
    const n = Math.min(this.len, Math.round(Number($("#scope-window").value) * this.rate));
    const start = this.len - n, per = Math.max(1, Math.ceil(n / POINTS)), t0 = (this.end - n) / this.rate;
    const xs = [], ys = [];
    for (let i = 0; i < n; i += per) {
      let lo = Infinity, hi = -Infinity;
      for (let j = i; j < Math.min(n, i + per); j++) { const v = this.buf[start + j]; if (v < lo) lo = v; if (v > hi) hi = v; }
      const t = t0 + i / this.rate;
      xs.push(t, t + per / (2 * this.rate)); ys.push(lo, hi);
    }
    this.plot.setData([xs, ys]);
    this.spectrogram.draw(this._specOptions());
  }

  // the measured spectrum of the last `n` samples (for the modes panel): {hz per bin, db}
  spectrum(n = 16384) {
    while (n > this.len && n > 1024) n /= 2;
    if (this.len < n) return null;
    return { binHz: this.rate / n, db: spectrumDb(this.buf, this.len, n), signal: this.signal };
  }
}
