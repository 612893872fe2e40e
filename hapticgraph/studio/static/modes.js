// The lowest modes of every mass-spring network (`modes`), listed; a mode's shape drawn on the
// instrument (`mode_shape`, swinging at a visible rate instead of the live frames); the predicted
// frequencies drawn as lines over the measured spectrum of the probed signal.
import { $, el, fmt } from "./dom.js";
import { stringLayout } from "./waveguide.js";

const SWING_HZ = 0.8;
const SILENT_DB = -200;          // |X|² below 1e-20: nothing to compare with

export class Modes {
  constructor(ctx) {
    this.ctx = ctx;
    this.shown = new Map();       // lattice id -> Float32Array shape while a mode is shown
    this.networks = [];
    $("#modes-go").onclick = () => this.compute();
    $("#modes-live").onclick = () => this.live();
    setInterval(() => this._swing(), 33);
    setInterval(() => this.drawSpectrum(), 500);
  }

  update(desc) {
    this.desc = desc;
    if (!desc.lattices.length) this._noLattice(desc);
  }

  // A patch without a mass-spring network: what the tab can say (its longest delay loop's length)
  _noLattice(desc) {
    const lengths = Object.fromEntries(desc.params.filter((p) => p.type === "delay" && p.param === "length").map((p) => [p.block, p.value]));
    const string = stringLayout(desc.graph, lengths), rate = desc.patch.rate, list = $("#modes-list");
    list.innerHTML = "";
    list.append(el("p", { text: "Modes are computed for mass-spring lattices (cells joined by springs); this patch has none." }));
    if (!string) return;
    const { loop, samples } = string;
    const others = [...new Set(loop.filter((b) => !lengths[b]))];
    const names = loop.concat(loop[0]).join(" → ");
    list.append(el("p", { class: "loop", text: `Its longest loop through delay lines, ${names}, holds ${samples} samples in its delay lines`
      + `${others.length ? `, and ${others.join(", ")} on it can only add to them` : ""}: a round trip of at least ${fmt(samples / rate * 1000)} ms, `
      + `so its fundamental is at most ${fmt(rate)}/${samples} = ${fmt(rate / samples)} Hz.` }));
  }

  showing(id) { return this.shown.has(id); }

  async compute() {
    if (!this.desc.lattices.length) { this._noLattice(this.desc); return { ok: true, result: { networks: [] } }; }
    const count = Number($("#modes-count").value) || 10;
    const r = await this.ctx.send({ cmd: "modes", count });
    if (!r.ok) return r;
    this.networks = r.result.networks;
    const list = $("#modes-list");
    list.innerHTML = "";
    for (const net of this.networks) {
      const rows = net.frequencies.map((f, i) => el("tr", { class: "mode", "data-mode": i + 1, onclick: () => this.show(net, i + 1) },
        el("td", { text: String(i + 1) }), el("td", { text: `${fmt(f)} Hz` })));
      list.append(el("div", { class: "network" }, el("b", { text: `${net.name} (${net.cells} cells${net.rigid ? `, ${net.rigid} rigid` : ""})` }),
        el("table", {}, ...rows), ...(net.notes || []).map((n) => el("div", { class: "note", text: n }))));
    }
    this.drawSpectrum();
    return r;
  }

  async show(net, mode) {
    const lattices = this.desc.lattices.filter((l) => (net.members || [net.name]).includes(l.name));
    const shapes = new Map();
    for (const l of lattices) {
      const r = await this.ctx.send({ cmd: "mode_shape", lattice: l.name, mode });
      if (!r.ok) return r;
      shapes.set(l.id, Float32Array.from(r.result.values, (v) => (v === null ? NaN : v)));
    }
    this.shown = shapes;
    this.picked = net.frequencies[mode - 1];
    this.t0 = performance.now();
    $("#modes-live").hidden = false;
    for (const tr of document.querySelectorAll("#modes-list tr.mode")) tr.classList.toggle("on", tr.dataset.mode === String(mode));
    return { ok: true };
  }

  live() {
    this.picked = null;
    for (const id of this.shown.keys()) { const part = this.ctx.view.parts[id]; if (part) part.peak = 1e-12; }
    this.shown = new Map();
    $("#modes-live").hidden = true;
    for (const tr of document.querySelectorAll("#modes-list tr.on")) tr.classList.remove("on");
  }

  _swing() {
    if (!this.shown.size) return;
    const s = Math.sin((2 * Math.PI * SWING_HZ * (performance.now() - this.t0)) / 1000);
    for (const [id, shape] of this.shown) this.ctx.view.take(id, shape.map((v) => (Number.isNaN(v) ? 0 : v * s)));
  }

  // measured spectrum (dB, log frequency) with the predicted mode frequencies over it
  drawSpectrum() {
    const canvas = $("#modes-spectrum"), g = canvas.getContext("2d"), w = canvas.width, h = canvas.height;
    if ($("#tab-modes").hidden) return;
    const sp = this.ctx.panels?.scopes?.spectrum();
    // up to a little past the highest predicted mode (or 5 kHz), so both can be compared
    const predicted = this.networks.flatMap((n) => n.frequencies).filter((f) => f > 0);
    const nyquist = sp ? sp.binHz * (sp.db.length - 1) : 22050, lo = 20;
    const top = Math.min(nyquist, predicted.length ? Math.max(4 * Math.max(...predicted), 1000) : 5000);
    const xOf = (f) => (Math.log(f / lo) / Math.log(top / lo)) * w;
    g.fillStyle = "#101317"; g.fillRect(0, 0, w, h);
    let peak = -Infinity;
    if (sp) for (const d of sp.db) peak = Math.max(peak, d);
    if (sp && peak < SILENT_DB) { g.fillStyle = "#8fb3ff"; g.fillText(`${sp.signal} is silent (Restart strikes again)`, 6, 12); }
    else if (sp) {
      g.strokeStyle = "#8fb3ff"; g.beginPath(); g.moveTo(0, h);
      for (let k = 1; k < sp.db.length; k++) {
        const f = k * sp.binHz;
        if (f < lo || f > top) continue;
        const y = h * Math.min(1, (peak - sp.db[k]) / 90);
        g.lineTo(xOf(f), y);
      }
      g.stroke();
      g.fillStyle = "#8fb3ff"; g.fillText(`measured: ${sp.signal}`, 6, 12);
    }
    g.strokeStyle = "#ff5a4a"; g.fillStyle = "#ff5a4a";
    for (const net of this.networks) {
      for (const f of net.frequencies) {
        if (!(f > lo && f < top)) continue;
        const mine = f === this.picked;        // the mode drawn on the instrument
        g.lineWidth = mine ? 3 : 1; g.strokeStyle = mine ? "#ffd000" : "#ff5a4a";
        g.beginPath(); g.moveTo(xOf(f), 16); g.lineTo(xOf(f), h); g.stroke();
      }
    }
    g.lineWidth = 1; g.fillStyle = "#ff5a4a";
    if (this.networks.length) g.fillText("predicted modes", w - 100, 12);
    g.fillStyle = "#9aa6b5";
    for (const f of [50, 100, 200, 500, 1000, 2000, 5000, 10000, 20000]) if (f > lo && f < top) g.fillText(f >= 1000 ? `${f / 1000}k` : String(f), xOf(f) + 2, h - 3);
  }
}
