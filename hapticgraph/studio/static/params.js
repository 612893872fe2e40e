// A control for every numeric parameter of every block, generated from its declaration (the
// `params` of the hello): unit, range, a log slider when the range spans decades, the stability
// bound just inside the top of a lattice's tension (the bottom of its mass). Live parameters
// change the sound while the slider moves; others reload the patch keeping state; driven ones
// are shown. A control always shows the value in effect: a refused one is put back, and said
// beside the control; a slider being dragged keeps its element and its range until released.
import { $, el, fmt } from "./dom.js";

const STEPS = 1000;
const THROTTLE_MS = 80;
const DECADES = 3;               // a log slider without a bound of its own spans value ÷/× 10^3
const INSIDE = 1e-3;             // a slider's end this far (relative) inside a bound that is refused
const DIGITS = 5;                // significant digits of a value the slider sends

// `v` to DIGITS significant digits, rounded toward the inside of [lo, hi]
function inside(v, lo, hi) {
  const r = Number(v.toPrecision(DIGITS));
  if (r > hi || r < lo) {
    const e = 10 ** (Math.floor(Math.log10(Math.abs(v))) - DIGITS + 1);
    return r > hi ? Math.floor(v / e) * e : Math.ceil(v / e) * e;
  }
  return r;
}

// the slider's [lo, hi] and whether it is logarithmic, from a declaration; `anchor`: the value
// the span of a bound-less end is counted from (the value when the control was made, so that
// the range does not move with every step of a drag)
export function sliderRange(p, anchor = p.value) {
  const v = Math.abs(anchor);
  let lo = p.stable_min != null ? Math.max(p.stable_min * (1 + INSIDE), p.min ?? -Infinity) : p.min;
  let hi = p.stable_max != null ? Math.min(p.stable_max * (1 - INSIDE), p.max ?? Infinity) : p.max;
  if (p.exclusive_max && p.stable_max == null && hi != null) hi -= Math.abs(hi) * INSIDE;
  if (p.log) {
    if (p.stable_max == null && v > 0) hi = Math.min(hi ?? Infinity, v * 10 ** DECADES);
    if (!(lo > 0)) lo = v > 0 ? v / 10 ** DECADES : hi * 1e-6;
    else if (p.stable_min == null && v > 0) lo = Math.max(lo, v / 10 ** DECADES);
    return { lo, hi, log: true };
  }
  if (p.exclusive_min && p.stable_min == null && lo != null) lo += Math.max(Math.abs(lo) * INSIDE, 1e-12);
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
  return inside(v, r.lo, r.hi);
}

export class Params {
  constructor(ctx) {
    this.ctx = ctx;
    this.root = $("#tab-params");
    this.controls = new Map();
    this.gestures = 0;
  }

  // the panel is made again only when its rows change (a block added or removed, a parameter
  // driven or not); new bounds and values go into the controls in place
  update(desc) {
    const params = desc.params.filter((p) => typeof p.value === "number");
    const key = JSON.stringify(params.map((p) => [p.block, p.param, p.live, p.driven]));
    if (key !== this.key) { this.key = key; this._build(params, desc); return; }
    for (const p of params) this.controls.get(`${p.block}.${p.param}`).show(p);
  }

  _build(params, desc) {
    const old = this.controls;
    this.root.innerHTML = "";
    this.controls = new Map();
    const types = Object.fromEntries(desc.graph.blocks.map((b) => [b.name, b.type]));
    let group = null, current = null;
    for (const p of params) {
      if (p.block !== current) {
        current = p.block;
        group = el("fieldset", { class: "block" }, el("legend", { text: `${p.block} (${types[p.block] || "?"})` }));
        this.root.append(group);
      }
      const name = `${p.block}.${p.param}`;
      // a control that stays (same declaration) keeps its element: it may be under the pointer
      const kept = old.get(name);
      const c = kept && kept.live === p.live && kept.driven === p.driven ? kept
        : new Control(p, (v, gesture) => this.ctx.send({ cmd: "set", block: p.block, param: p.param, value: v,
          ...(gesture ? { gesture } : {}) }), () => `${++this.gestures}`);
      if (c === kept) c.show(p);
      this.controls.set(name, c);
      group.append(c.row);
    }
  }
}

class Control {
  constructor(p, set, newGesture) {
    this.set = set;
    this.newGesture = newGesture;
    this.live = p.live;
    this.driven = p.driven;
    this.anchor = p.value;
    this.range = sliderRange(p, this.anchor);
    this.dragging = false;
    this.typing = false;
    this.inflight = 0;           // values sent and not yet answered: the thumb stays where it was put
    const id = `param-${p.block}-${p.param}`;
    const unit = p.unit ? ` [${p.unit}]` : "";
    this.slider = el("input", { type: "range", min: 0, max: STEPS, step: 1, id: `${id}-slider`, "data-param": `${p.block}.${p.param}` });
    this.box = el("input", { type: "number", step: "any", id, "data-param": `${p.block}.${p.param}`, class: "value" });
    this.note = el("div", { class: "refusal", hidden: true });
    this.label = el("label", { for: id, text: p.param });
    this.row = el("div", { class: `param${p.live ? "" : " static"}${p.driven ? " driven" : ""}` },
      this.label, this.slider, this.box, el("span", { class: "unit", text: p.unit || "" }), this.note);
    this.unit = unit;
    this._wire();
    this.show(p);
  }

  sliderValue() { return fromSlider(this.range, Number(this.slider.value)); }

  _title(p) {
    const bound = p.stable_max != null ? ` (stable below ${fmt(p.stable_max)})` : p.stable_min != null ? ` (stable above ${fmt(p.stable_min)})` : "";
    const keys = "\nslider: drag, or ←/→ (PgUp/PgDn: larger steps); Ctrl+Z undoes a whole drag";
    return `${p.block}.${p.param}${this.unit}: ${p.doc || ""}\nrange ${fmt(p.min)} … ${fmt(p.max)} ${p.unit || ""}${bound}` +
      `${p.log ? ", log slider" : ""}${p.live ? "" : "\nnot live: setting it reloads the patch, keeping state"}` +
      `${p.driven ? "\ndriven by a connection: shown, not set here" : ""}${keys}`;
  }

  // send `v`; a refused value is put back to the one in effect and said beside the control
  async _send(v, gesture) {
    let reply;
    this.inflight++;
    try { reply = await this.set(v, gesture); } catch { return; } finally { this.inflight--; }
    if (reply.ok) { this.note.hidden = true; this.note.textContent = ""; this.show(this.p); return; }
    this.note.textContent = (reply.errors || [reply.error]).join("\n");
    this.note.hidden = false;
    this.typing = false;
    this.show(this.p, true);
  }

  _wire() {
    let timer = null, pending = null;
    const flush = () => { timer = null; if (pending !== null) { const v = pending; pending = null; this._send(v, this.gesture); } };
    const release = () => {
      if (!this.dragging) return;
      this.dragging = false;
      window.removeEventListener("pointerup", release);
      window.removeEventListener("pointercancel", release);
    };
    this.slider.addEventListener("pointerdown", () => {
      this.dragging = true;
      this.gesture = this.newGesture();
      window.addEventListener("pointerup", release);
      window.addEventListener("pointercancel", release);
    });
    this.slider.addEventListener("input", () => {
      if (!this.gesture) this.gesture = this.newGesture();     // the keyboard: one gesture per key
      const v = this.sliderValue();
      this.box.value = v;
      pending = v;
      if (!timer) timer = setTimeout(flush, THROTTLE_MS);
    });
    this.slider.addEventListener("change", () => {
      clearTimeout(timer); timer = null; pending = null;
      const gesture = this.gesture;
      this.gesture = null;
      release();
      this._send(this.sliderValue(), gesture);
    });
    this.box.addEventListener("input", () => { this.typing = true; });
    this.box.addEventListener("blur", () => { this.typing = false; this.show(this.p); });
    this.box.addEventListener("change", () => {
      this.typing = false;
      if (this.box.value !== "") this._send(Number(this.box.value));
    });
  }

  // the value in effect (`p`, the latest declaration); `force`: even where the designer is at
  show(p, force = false) {
    this.p = p;
    this.slider.disabled = this.box.disabled = !!p.driven;
    this.row.title = this._title(p);
    this.slider.title = this.box.title = this.row.title;
    // the range and the thumb stay under the pointer, and where a key put them until answered
    if ((this.dragging || this.inflight > 0) && !force) return;
    let range = sliderRange(p, this.anchor);
    if (p.value < range.lo || p.value > range.hi) { this.anchor = p.value; range = sliderRange(p, this.anchor); }
    this.range = range;
    if (!this.typing || force) this.box.value = p.value;
    this.slider.value = toSlider(this.range, p.value);
  }
}
