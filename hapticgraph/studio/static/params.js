// A control for every numeric parameter of every block, generated from its declaration (the
// `params` of the hello): unit, range, a log slider when the range spans decades, the stability
// bound as the top of a lattice's tension (the bottom of its mass). Live parameters change the
// sound while the slider moves; others reload the patch keeping state; driven ones are shown.
import { $, el, fmt } from "./dom.js";

const STEPS = 1000;
const THROTTLE_MS = 80;
const DECADES = 3;               // a log slider without a bound of its own spans value ÷/× 10^3

// the slider's [lo, hi] and whether it is logarithmic, from a declaration
export function sliderRange(p) {
  const v = Math.abs(p.value);
  let lo = p.stable_min ?? p.min, hi = p.stable_max ?? p.max;
  if (p.log) {
    if (p.stable_max == null && v > 0) hi = Math.min(hi ?? Infinity, v * 10 ** DECADES);
    if (!(lo > 0)) lo = v > 0 ? v / 10 ** DECADES : hi * 1e-6;
    else if (p.stable_min == null && v > 0) lo = Math.max(lo, v / 10 ** DECADES);
    return { lo, hi, log: true };
  }
  const span = Math.max(v * 10, 1);
  lo = lo == null ? -span : Math.max(lo, -span);
  hi = hi == null ? span : Math.min(hi, Math.max(span, lo + 1));
  return { lo, hi, log: false };
}

export function toSlider(r, v) {
  const u = r.log ? Math.log(Math.max(v, r.lo) / r.lo) / Math.log(r.hi / r.lo) : (v - r.lo) / (r.hi - r.lo);
  return Math.round(Math.min(1, Math.max(0, u)) * STEPS);
}

export function fromSlider(r, s) {
  const u = s / STEPS;
  const v = r.log ? r.lo * (r.hi / r.lo) ** u : r.lo + u * (r.hi - r.lo);
  return Number(v.toPrecision(5));
}

export class Params {
  constructor(ctx) {
    this.ctx = ctx;
    this.root = $("#tab-params");
    this.controls = new Map();
  }

  update(desc) {
    const params = desc.params.filter((p) => typeof p.value === "number");
    const key = JSON.stringify(params.map((p) => [p.block, p.param, p.live, p.driven, p.stable_max, p.stable_min]));
    if (key !== this.key) { this.key = key; this._build(params, desc); return; }
    for (const p of params) this.controls.get(`${p.block}.${p.param}`).show(p);
  }

  _build(params, desc) {
    this.root.innerHTML = "";
    this.controls.clear();
    const types = Object.fromEntries(desc.graph.blocks.map((b) => [b.name, b.type]));
    let group = null, current = null;
    for (const p of params) {
      if (p.block !== current) {
        current = p.block;
        group = el("fieldset", { class: "block" }, el("legend", { text: `${p.block} (${types[p.block] || "?"})` }));
        this.root.append(group);
      }
      const c = new Control(p, (v) => this.ctx.send({ cmd: "set", block: p.block, param: p.param, value: v }));
      this.controls.set(`${p.block}.${p.param}`, c);
      group.append(c.row);
    }
  }
}

class Control {
  constructor(p, set) {
    this.set = set;
    this.range = sliderRange(p);
    const id = `param-${p.block}-${p.param}`;
    this.slider = el("input", { type: "range", min: 0, max: STEPS, step: 1, id: `${id}-slider`, "data-param": `${p.block}.${p.param}` });
    this.box = el("input", { type: "number", step: "any", id, "data-param": `${p.block}.${p.param}`, class: "value" });
    const bound = p.stable_max != null ? ` (stable below ${fmt(p.stable_max)})` : p.stable_min != null ? ` (stable above ${fmt(p.stable_min)})` : "";
    const title = `${p.doc || ""}\nrange ${fmt(p.min)} … ${fmt(p.max)} ${p.unit || ""}${bound}${p.log ? ", log slider" : ""}${p.live ? "" : "\nnot live: setting it reloads the patch, keeping state"}`;
    this.row = el("div", { class: `param${p.live ? "" : " static"}${p.driven ? " driven" : ""}`, title },
      el("label", { for: id, text: p.param }), this.slider, this.box, el("span", { class: "unit", text: p.unit || "" }));
    this._wire();
    this.show(p);
  }

  _wire() {
    let timer = null, pending = null;
    const flush = () => { timer = null; if (pending !== null) { const v = pending; pending = null; this.set(v); } };
    this.slider.addEventListener("input", () => {
      const v = fromSlider(this.range, Number(this.slider.value));
      this.box.value = v;
      pending = v;
      if (!timer) timer = setTimeout(flush, THROTTLE_MS);
    });
    this.slider.addEventListener("change", () => { clearTimeout(timer); timer = null; pending = null; this.set(fromSlider(this.range, Number(this.slider.value))); });
    this.box.addEventListener("change", () => { if (this.box.value !== "") this.set(Number(this.box.value)); });
  }

  show(p) {
    const active = document.activeElement;
    this.slider.disabled = this.box.disabled = !!p.driven;
    if (active !== this.box) this.box.value = p.value;
    if (active !== this.slider) this.slider.value = toSlider(this.range, p.value);
  }
}
