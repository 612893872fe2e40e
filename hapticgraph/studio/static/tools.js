// The luthier's tools: select cells (click, shift+drag for a box), lock, unlock, cut, join two
// cells, edit mass/damping (per cell) and tension (per part) of the selection, place or move a
// microphone or an excitation on any cell (a block's inner cells too), a microphone's pan.
import { $, el, fmt } from "./dom.js";
import { unflatten, cellName } from "./layout.js";

const EDITS = ["#edit-mass", "#edit-damping", "#edit-tension"];
// fields where keys type text: the one-key shortcuts leave them alone
export const TYPED = "textarea, select, input:not([type=range]):not([type=checkbox]):not([type=radio]):not([type=button])";

export class Tools {
  constructor(ctx) {
    this.ctx = ctx;
    this.selection = [];        // [{lattice, flat}]
    this.joinFirst = null;
    this.waiting = false;       // an edit is being applied: the stage takes no click meanwhile
    this.placed = null;         // a new microphone or excitation just asked for: chosen once it exists
    this._pointer();
    $("#tool").addEventListener("change", () => { this.joinFirst = null; this._fillWhich(); });
    $("#place-which").addEventListener("change", () => this._showPan());
    $("#remove").onclick = () => this.ctx.send({ cmd: "remove", block: $("#place-which").value });
    $("#lock").onclick = () => this._cells("lock");
    $("#unlock").onclick = () => this._cells("unlock");
    $("#cut").onclick = () => this._cells("cut");
    $("#join").onclick = () => this._join(this.selection[0], this.selection[1]);
    $("#clear-selection").onclick = () => this.select([]);
    $("#look").addEventListener("change", (e) => this.ctx.view.look(e.target.value));
    $("#layer").addEventListener("change", (e) => this._layer(e.target.value));
    $("#edit-apply").onclick = () => this._edit();
    $("#join-tension").addEventListener("input", (e) => { e.target.dataset.touched = "1"; });
    for (const id of EDITS) $(id).addEventListener("keydown", (e) => { if (e.key === "Enter") this._edit(); });
    document.addEventListener("keydown", (e) => this._key(e));
    for (const id of EDITS) $(id).addEventListener("input", (e) => { e.target.dataset.touched = "1"; });
    const pan = $("#mic-pan");
    pan.addEventListener("input", () => { $("#mic-pan-value").textContent = pan.value; });
    pan.addEventListener("change", () => this.ctx.send({ cmd: "set", block: $("#place-which").value, param: "pan", value: Number(pan.value) }));
  }

  update(desc) {
    this.desc = desc;
    this._forLattices(desc.lattices.length > 0);
    this._joinDefault();
    this._fillLayers();
    this.selection = this.selection.filter((c) => desc.byId[c.lattice] && !desc.byId[c.lattice].cutFlat.includes(c.flat));
    this.select(this.selection);
    this._fillWhich();
  }

  // a patch without a lattice or cell (waveguides): the tools that act on cells are off, and say so
  _forLattices(any) {
    this.none = !any;
    $("#tools-note").hidden = any;
    $("#join-tension-row").hidden = $("#join-why").hidden = !any;
    $("#cell-edit").hidden = !any;
    for (const id of ["#tool", "#place-which", "#clear-selection", "#edit-mass", "#edit-damping", "#edit-tension"]) $(id).disabled = !any;
    if (!any && $("#tool").value !== "select") { $("#tool").value = "select"; this.joinFirst = null; }
  }

  // the next join's tension, until the designer types one: the patch's last join's (its bridge),
  // else the softest lattice's (a join as stiff as the mean of two parts can be ten times the
  // patch's own bridge); said beside the field
  _joinDefault() {
    const field = $("#join-tension"), joins = this.desc.joins.filter((j) => typeof j.tension === "number");
    const parts = this.desc.params.filter((p) => p.param === "tension" && p.type === "lattice");
    let value = 100, why = "the spring's default";
    if (joins.length) { const j = joins[joins.length - 1]; value = j.tension; why = `as the patch's join ${j.block}`; }
    else if (parts.length) {
      const p = parts.reduce((a, b) => (b.value < a.value ? b : a));
      value = p.value; why = `as the softer part, ${p.block}`;
    }
    this.joinDefault = value;
    $("#join-why").textContent = field.dataset.touched ? "" : `default ${fmt(value)} N/m: ${why}`;
    if (!field.dataset.touched) field.value = value;
  }

  joinTension() {
    const v = Number($("#join-tension").value);
    return $("#join-tension").value !== "" && Number.isFinite(v) && v >= 0 ? v : this.joinDefault;
  }

  // the layer choice: every block's layers along its first axis
  _fillLayers() {
    const sel = $("#layer"), keep = sel.value;
    sel.innerHTML = "";
    sel.append(el("option", { value: "", text: "all cells" }));
    for (const l of this.desc.lattices) {
      if (l.shape.length !== 3) continue;
      for (let i = 0; i < l.shape[0]; i++) sel.append(el("option", { value: `${l.id}:${i}`, text: `${l.name}[${i}, :, :]` }));
    }
    sel.hidden = sel.options.length === 1;
    sel.value = [...sel.options].some((o) => o.value === keep) ? keep : "";
    this._layer(sel.value);
  }

  _layer(value) {
    const [id, layer] = value ? value.split(":").map(Number) : [null, null];
    this.ctx.view.setLayer(id, layer);
  }

  name(c) { const l = this.desc.byId[c.lattice]; return cellName(l.name, l.shape, c.flat); }

  _fillWhich() {
    const tool = $("#tool").value, which = $("#place-which"), keep = which.value;
    which.innerHTML = "";
    const list = tool === "mic" ? this.desc.microphones : tool === "excite" ? this.desc.excitations : [];
    for (const x of list) which.append(el("option", { value: x.block, text: `${x.block} @ ${x.cell || "—"}` }));
    if (tool === "mic") which.append(el("option", { value: "", text: "+ new microphone" }));
    if (tool === "excite") for (const t of ["pluck", "wavetable", "noise"]) which.append(el("option", { value: `+${t}`, text: `+ new ${t}` }));
    which.hidden = !(tool === "mic" || tool === "excite");
    $("#remove").hidden = which.hidden;
    if ([...which.options].some((o) => o.value === keep)) which.value = keep;
    // after "+ new": the one just placed, so that the next click moves it rather than adds another
    if (this.placed && [...which.options].some((o) => o.value === this.placed)) { which.value = this.placed; this.placed = null; }
    this._showPan();
  }

  // the tools' one-key shortcuts (the help overlay lists them), outside fields where text is typed
  _key(e) {
    if (e.ctrlKey || e.metaKey || e.altKey || e.target.matches(TYPED) || document.querySelector("dialog[open]")) return;
    if (this.none) return;
    const tool = { v: "select", escape: "select", m: "mic", e: "excite", j: "join" }[e.key.toLowerCase()];
    if (tool) {
      if ($("#tool").value !== tool) { $("#tool").value = tool; $("#tool").dispatchEvent(new Event("change")); }
      return;
    }
    const button = { l: "#lock", u: "#unlock", x: "#cut", c: "#clear-selection" }[e.key.toLowerCase()];
    if (button && !$(button).disabled) { e.preventDefault(); $(button).click(); }
  }

  // an edit pending (on) or landed: the tools that edit wait for it
  busy(on) {
    this.waiting = on;
    if (this.desc) { this.select(this.selection); this._showPan(); }
  }

  _showPan() {
    $("#remove").disabled = this.waiting || !$("#place-which").value || $("#place-which").value.startsWith("+");
    const mic = this.desc.microphones.find((m) => m.block === $("#place-which").value && $("#tool").value === "mic");
    $("#mic-pan-row").hidden = !mic;
    if (mic) { $("#mic-pan-name").textContent = mic.block; $("#mic-pan").value = mic.pan; $("#mic-pan-value").textContent = fmt(mic.pan); }
  }

  _pointer() {
    const canvas = this.ctx.view.canvas, box = $("#box");
    let start = null;
    canvas.addEventListener("pointerdown", (e) => {
      if (e.button !== 0) return;
      if (e.shiftKey) { start = { x: e.clientX, y: e.clientY }; this.ctx.view.controls.enabled = false; canvas.setPointerCapture(e.pointerId); }
      else start = { x: e.clientX, y: e.clientY, click: true };
    });
    canvas.addEventListener("pointermove", (e) => {
      if (!start || start.click) return;
      const r = canvas.parentElement.getBoundingClientRect();
      Object.assign(box.style, { left: `${Math.min(start.x, e.clientX) - r.left}px`, top: `${Math.min(start.y, e.clientY) - r.top}px`,
        width: `${Math.abs(e.clientX - start.x)}px`, height: `${Math.abs(e.clientY - start.y)}px` });
      box.hidden = false;
    });
    canvas.addEventListener("pointerup", (e) => {
      if (!start) return;
      const s = start; start = null; box.hidden = true; this.ctx.view.controls.enabled = true;
      const moved = Math.hypot(e.clientX - s.x, e.clientY - s.y);
      if (!s.click) { this.select(this._merge(this.ctx.view.cellsIn(s.x, s.y, e.clientX, e.clientY), e.ctrlKey)); return; }
      if (moved < 5) this.click(e.clientX, e.clientY, e.ctrlKey || e.metaKey);
    });
  }

  _merge(cells, add) {
    if (!add) return cells;
    const seen = new Set(this.selection.map((c) => `${c.lattice}:${c.flat}`));
    return this.selection.concat(cells.filter((c) => !seen.has(`${c.lattice}:${c.flat}`)));
  }

  // a click at client coordinates, with the current tool
  click(x, y, add = false) {
    const tool = $("#tool").value;
    if (this.waiting && tool !== "select") {
      $("#selection-info").textContent = "wait: the last edit is being applied";
      return null;
    }
    const cell = this.ctx.view.pick(x, y);
    if (!cell) { if (!add) this.select([]); return null; }
    if (tool === "mic" || tool === "excite") return this._place(tool, cell);
    if (tool === "join") {
      if (!this.joinFirst) { this.joinFirst = cell; this.select([cell]); return null; }
      const first = this.joinFirst; this.joinFirst = null;
      return this._join(first, cell);
    }
    this.select(this._merge([cell], add));
    return null;
  }

  select(cells) {
    this.selection = cells;
    this.ctx.view.setSelection(cells);
    const n = cells.length;
    $("#selection-info").textContent = n === 0 ? "" : n === 1 ? this.name(cells[0]) : `${n} cells`;
    $("#cell-edit-what").textContent = n === 0 ? "none" : $("#selection-info").textContent;
    $("#join").disabled = n !== 2 || this.waiting || this.none;
    for (const id of ["lock", "unlock", "cut", "edit-apply"]) $(`#${id}`).disabled = n === 0 || this.waiting || this.none;
    this._fillEdit();
  }

  _fillEdit() {
    const c = this.selection[0];
    if (!c) return;
    const l = this.desc.byId[c.lattice], p = (param) => this.desc.params.find((x) => x.block === l.name && x.param === param);
    const own = l.cells.find((x) => x.index.join() === unflatten(l.shape, c.flat).join()) || {};
    $("#edit-mass").value = own.mass ?? p("mass")?.value ?? "";
    $("#edit-damping").value = own.damping ?? p("damping")?.value ?? "";
    $("#edit-tension").value = p("tension")?.value ?? "";
    for (const id of EDITS) delete $(id).dataset.touched;
  }

  async _place(tool, cell) {
    const which = $("#place-which").value, name = this.name(cell);
    if (which !== "" && !which.startsWith("+")) return this.ctx.send({ cmd: "place", block: which, cell: name });
    const type = which === "" ? "mic" : which.slice(1), block = this._fresh(type);
    this.placed = block;
    const r = await this.ctx.send({ cmd: "place", block, type, cell: name, ...(type === "mic" ? { params: { pan: 0 } } : {}) });
    if (!r.ok) this.placed = null;
    else this._fillWhich();
    return r;
  }

  _fresh(stem) {
    const used = new Set(this.desc.graph.blocks.map((b) => b.name));
    let i = 1;
    while (used.has(`${stem}${i}`)) i++;
    return `${stem}${i}`;
  }

  _cells(cmd) {
    if (!this.selection.length) return null;
    const cells = this.selection.map((c) => this.name(c));
    if (cmd === "cut") this.select([]);
    return this.ctx.send({ cmd, cells });
  }

  _join(a, b) {
    if (!a || !b) return null;
    return this.ctx.send({ cmd: "join", a: this.name(a), b: this.name(b), tension: this.joinTension() });
  }

  // the typed values to the patch; a refused one is said under the fields, which go back to the
  // values in effect
  async _edit() {
    const r = await this._send();
    const note = $("#cell-edit-refusal");
    note.hidden = r.ok;
    note.textContent = r.ok ? "" : (r.errors || [r.error]).join("\n");
    if (!r.ok) this._fillEdit();
    return r;
  }

  async _send() {
    const byPart = new Map();
    for (const c of this.selection) {
      const l = this.desc.byId[c.lattice];
      if (!byPart.has(l.name)) byPart.set(l.name, []);
      byPart.get(l.name).push(unflatten(l.shape, c.flat));
    }
    // only what was typed: the others keep their values (and the patch its text)
    const num = (id) => ($(id).value === "" || !$(id).dataset.touched ? undefined : Number($(id).value));
    const mass = num("#edit-mass"), damping = num("#edit-damping"), tension = num("#edit-tension");
    for (const [block, cells] of byPart) {
      const one = this.desc.lattices.find((l) => l.name === block);
      const change = {};
      if (mass !== undefined) change.mass = mass;
      if (damping !== undefined) change.damping = damping;
      if (Object.keys(change).length && one.type === "lattice") {
        const r = await this.ctx.send({ cmd: "cells", block, cells, ...change });
        if (!r.ok) return r;
      }
      const t = this.desc.params.find((x) => x.block === block && x.param === "tension");
      if (tension !== undefined && t && t.value !== tension) {
        const r = await this.ctx.send({ cmd: "set", block, param: "tension", value: tension });
        if (!r.ok) return r;
      }
    }
    return { ok: true };
  }
}
