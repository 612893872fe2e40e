// The gesture-mapping dialog (Cymatic's joystick dialog, seed 001 §2.6): one row per live
// parameter bound to a MIDI controller (cc) or an OSC address, written as the patch's `map:`.
import { $, el } from "./dom.js";

const FIELDS = ["param", "source", "address", "device", "min", "max", "curve", "smooth"];
const TITLES = ["the live parameter the controller moves", "a MIDI controller (cc) or an OSC address",
  "the MIDI cc number (0 … 127) or the OSC address (/…)", "the MIDI port or OSC listener (empty: the first)",
  "the parameter's value at the controller's bottom [its unit]", "the parameter's value at the controller's top [its unit]",
  "how the controller's travel maps to the value", "smoothing time [s]", "remove this row"];

export class Mapping {
  constructor(ctx) {
    this.ctx = ctx;
    $("#mapping-open").onclick = () => this.open();
    $("#mapping-add").onclick = () => this.row({});
    $("#mapping-write").onclick = () => this.write();
    $("#mapping-cancel").onclick = () => $("#mapping-dialog").close();
  }

  update(desc) { this.desc = desc; }

  open() {
    $("#mapping-table tbody").innerHTML = "";
    for (const m of this.desc.map || []) this.row(m);
    if (!(this.desc.map || []).length) this.row({});
    $("#mapping-dialog").showModal();
  }

  row(m) {
    const live = this.desc.params.filter((p) => p.live && typeof p.value === "number").map((p) => `${p.block}.${p.param}`);
    const param = el("select", { name: "param" }, ...live.map((p) => el("option", { value: p, text: p })));
    if (m.param) param.value = m.param;
    const source = el("select", { name: "source" }, el("option", { value: "cc", text: "MIDI cc" }), el("option", { value: "osc", text: "OSC" }));
    source.value = m.osc ? "osc" : "cc";
    const num = (name, v) => el("input", { name, type: "number", step: "any", value: v ?? "" });
    const curve = el("select", { name: "curve" }, el("option", { value: "linear", text: "linear" }), el("option", { value: "exponential", text: "exponential" }));
    curve.value = m.curve || "linear";
    const cells = [param, source, el("input", { name: "address", value: m.osc ?? m.cc ?? "" }),
      el("input", { name: "device", value: m.device ?? "" }), num("min", m.min), num("max", m.max), curve, num("smooth", m.smooth),
      el("button", { text: "×", onclick: () => tr.remove() })];
    cells.forEach((c, i) => c.setAttribute("title", TITLES[i]));
    const tr = el("tr", { "data-entry": JSON.stringify(m) }, ...cells.map((c) => el("td", {}, c)));
    $("#mapping-table tbody").append(tr);
  }

  // the rows as map: entries; a row read from the patch keeps its keys' order and the fields the
  // dialog does not show (channel), so writing it back changes only what was edited
  entries() {
    return [...document.querySelectorAll("#mapping-table tbody tr")].map((tr) => {
      const v = Object.fromEntries(FIELDS.map((f) => [f, tr.querySelector(`[name=${f}]`).value.trim()]));
      const was = JSON.parse(tr.dataset.entry || "{}");
      const e = { param: v.param };
      if (v.source === "osc") e.osc = v.address; else e.cc = parseInt(v.address, 10);
      if (v.device) e.device = v.device;
      if (was.channel !== undefined) e.channel = was.channel;
      for (const k of ["min", "max", "smooth"]) if (v[k] !== "") e[k] = Number(v[k]);
      if (v.curve !== "linear" || was.curve) e.curve = v.curve;
      const order = Object.keys(was).filter((k) => k in e).concat(Object.keys(e).filter((k) => !(k in was)));
      return Object.fromEntries(order.map((k) => [k, e[k]]));
    });
  }

  async write() {
    const r = await this.ctx.send({ cmd: "map", entries: this.entries() });
    if (r.ok) $("#mapping-dialog").close();
    return r;
  }
}
