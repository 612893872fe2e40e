// The 3-D view: every lattice of the patch side by side, rotated and zoomed with OrbitControls,
// excitations as green rings and microphones as vertical blue lines through their cells (named
// above them), joins as orange lines between the two cells, as in Cymatic's Virtual Luthiery
// (seed 001 §2.5); a patch without lattices as the string its delay lines make (waveguide.js).
// A legend in the corner says what each colour and marker means.
import * as THREE from "three";
import { OrbitControls } from "./vendor/three/OrbitControls.js";
import { Part } from "./part.js";
import { SPACING, flatten } from "./layout.js";
import { stringLayout, stringScene } from "./waveguide.js";
import { legend } from "./legend.js";

const GAP = 3 * SPACING;
const MARGIN = 16;                   // px kept free around the framed parts
const LABEL_ROOM = 28;               // px above them for the parts' names
const MARKER_REACH = 1.5 * SPACING;  // a microphone's line stands this far above and below its cell

function rendererName() {
  const gl = document.createElement("canvas").getContext("webgl2");
  const info = gl && gl.getExtension("WEBGL_debug_renderer_info");
  return info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : "";
}

export class Instrument {
  constructor(canvas) {
    this.canvas = canvas;
    // a software rasteriser (SwiftShader: headless, VMs) gets no multisampling: it would cost
    // more than the whole lattice update
    this.software = /swiftshader|llvmpipe|software/i.test(rendererName());
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: !this.software });
    this.renderer.setPixelRatio(this.software ? 1 : window.devicePixelRatio || 1);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x15181d);
    this.camera = new THREE.PerspectiveCamera(45, 1, 0.1, 5000);
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.enableDamping = false;
    this.controls.zoomToCursor = true;     // the wheel zooms toward the point under the cursor
    this.cameras = {};        // by look ("3d", "top"): where the designer left the camera
    // a still picture is not drawn again: only new cells, a camera move or an edit redraw it
    this.dirty = true;
    this.controls.addEventListener("change", () => { this.dirty = true; });
    this.parts = [];          // by lattice id
    this.markers = new THREE.Group();
    this.scene.add(this.markers);
    this.raycaster = new THREE.Raycaster();
    this.drawn = 0;           // frames drawn with new cell data (for fps)
    this.micLabels = [];
    this.legend = legend(this.legendKind = "lattice");
    canvas.parentElement.append(this.legend);
  }

  // The panel protocol: what the describe object says beyond the lattices' shapes (the masses
  // edited cell by cell).
  update(desc) {
    for (const l of desc.lattices) {
      const part = this.parts[l.id];
      const base = desc.params.find((p) => p.block === l.name && p.param === "mass");
      if (!part || !base) continue;
      const masses = {};
      for (const c of l.cells || []) if (typeof c.mass === "number" && c.mass !== base.value) masses[flatten(l.shape, c.index)] = c.mass;
      part.setMasses(masses, base.value);
    }
    const lengths = Object.fromEntries(desc.params.filter((p) => p.type === "delay" && p.param === "length").map((p) => [p.block, p.value]));
    this.setWaveguide(desc.lattices.length ? null : stringLayout(desc.graph, lengths));
    const kind = this.waveguide ? "waveguide" : "lattice";
    if (kind !== this.legendKind) this.legend.replaceWith(this.legend = legend(kind));
    this.legendKind = kind;
    this.dirty = true;
  }

  // a waveguide's delay lines and blocks (waveguide.js), framed when they change; null: none
  setWaveguide(layout) {
    const key = JSON.stringify(layout);
    if (key === this.waveguideKey) return;
    this.waveguideKey = key;
    if (this.waveguide) { this.scene.remove(this.waveguide.group); this.waveguide.labels.forEach((l) => l.el.remove()); }
    this.waveguide = null;
    if (!layout) return;
    const { group, labels } = stringScene(layout, this.canvas.parentElement);
    this.scene.add(group);
    this.waveguide = { layout, group, labels };
    this.cameras = {};
    this.frameAll();
  }

  // lattices as the server's hello describes them; keeps the camera when the shapes did not change
  build(lattices) {
    const key = JSON.stringify(lattices.map((l) => [l.name, l.shape]));
    this.dirty = true;
    if (key === this.key) { lattices.forEach((l) => this.parts[l.id].setCells(l.lockedFlat, l.cutFlat)); return; }
    this.key = key;
    this.parts.forEach((p) => p && (this.scene.remove(p.group), p.label.remove()));
    this.parts = [];
    let x = 0;
    for (const l of lattices) {
      const part = new Part({ name: l.name, shape: l.shape, locked: l.lockedFlat, cut: l.cutFlat });
      part.id = l.id;
      part.group.position.x = x + part.size[0] / 2;
      x += part.size[0] + GAP;
      this.parts[l.id] = part;
      this.scene.add(part.group);
      part.label = Object.assign(document.createElement("div"), { className: "label", textContent: `${l.name} [${l.shape.join(" × ")}]` });
      this.canvas.parentElement.append(part.label);
    }
    this.parts.forEach((p) => { p.group.position.x -= (x - GAP) / 2; });
    this.scene.updateMatrixWorld();
    this.cameras = {};        // another instrument: every look framed again
    this.frameAll();
    this.dirty = true;
  }

  // "3d" (above-front) or "top" (straight down: rows and columns of a sheet line up with the
  // screen). Each look keeps the camera the designer left it at; a look not seen yet is framed.
  look(from) {
    if (from === this.from) return;
    this.cameras[this.from || "3d"] = this._camera();
    this.from = from;
    const kept = this.cameras[from];
    if (kept) {
      this.camera.position.copy(kept.position);
      this.controls.target.copy(kept.target);
      this.controls.update();
      this.camera.updateMatrixWorld();    // picking and screenOf right away, before the next frame
    } else this.frameAll();
    this.dirty = true;
  }

  _camera() { return { position: this.camera.position.clone(), target: this.controls.target.clone() }; }

  // The part of the canvas nothing covers: below the toolbar, and either above the boxes in the
  // bottom corners (the selection, the legend) or between them (whichever leaves the larger
  // square), in canvas pixels with a margin.
  _free() {
    const c = this.canvas.getBoundingClientRect(), up = this.canvas.parentElement;
    const rect = (sel) => { const e = up.querySelector(sel), r = e && e.getBoundingClientRect(); return r && r.width ? r : null; };
    const bar = rect("#toolbar"), box = rect("#cell-edit"), key = rect(".legend:not(.folded)");
    const top = Math.max(0, (bar ? bar.bottom - c.top : 0)) + LABEL_ROOM;
    const above = { left: MARGIN, right: c.width - MARGIN, top, bottom: Math.min(c.height, ...[box, key].filter(Boolean).map((r) => r.top - c.top)) - MARGIN };
    const between = { left: (box ? box.right - c.left : 0) + MARGIN, right: (key ? key.left - c.left : c.width) - MARGIN, top, bottom: c.height - MARGIN };
    const side = (r) => Math.min(r.right - r.left, r.bottom - r.top);
    return side(between) >= side(above) ? between : above;
  }

  // Every cell in the free part of the canvas, as large as fits: the camera from the look's
  // direction, then moved sideways and along its axis until the projected box of the parts (and
  // the room their markers take) fills the free rectangle.
  frameAll() {
    const box = new THREE.Box3();
    this.parts.forEach((p) => p && box.expandByObject(p.group));
    if (this.waveguide) box.expandByObject(this.waveguide.group);
    if (box.isEmpty()) return;
    box.expandByVector(new THREE.Vector3(0, MARKER_REACH, 0));
    this._resize();
    const c = box.getCenter(new THREE.Vector3()), s = box.getSize(new THREE.Vector3());
    const free = this._free(), w = this.w || 1, h = this.h || 1;
    const half = THREE.MathUtils.degToRad(this.camera.fov / 2);
    const dir = this.from === "top" ? new THREE.Vector3(0, 1, 1e-4).normalize() : new THREE.Vector3(0.15, 0.75, 0.8).normalize();
    const target = c.clone(), right = new THREE.Vector3(), upv = new THREE.Vector3(), corner = new THREE.Vector3();
    let dist = 1.02 * Math.max(s.length() / 2, 2 * SPACING) / Math.sin(half);
    for (let i = 0; i < 8; i++) {
      this.camera.position.copy(target).addScaledVector(dir, dist);
      this.camera.lookAt(target);
      this.camera.updateMatrixWorld();
      let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
      for (let k = 0; k < 8; k++) {
        corner.set(k & 1 ? box.max.x : box.min.x, k & 2 ? box.max.y : box.min.y, k & 4 ? box.max.z : box.min.z).project(this.camera);
        const px = (corner.x + 1) / 2 * w, py = (1 - corner.y) / 2 * h;
        x0 = Math.min(x0, px); x1 = Math.max(x1, px); y0 = Math.min(y0, py); y1 = Math.max(y1, py);
      }
      const scale = Math.max((x1 - x0) / (free.right - free.left), (y1 - y0) / (free.bottom - free.top));
      const perPx = 2 * dist * Math.tan(half) / h;          // world units per pixel at the target
      right.setFromMatrixColumn(this.camera.matrixWorld, 0);
      upv.setFromMatrixColumn(this.camera.matrixWorld, 1);
      target.addScaledVector(right, -((free.left + free.right) / 2 - (x0 + x1) / 2) * perPx);
      target.addScaledVector(upv, ((free.top + free.bottom) / 2 - (y0 + y1) / 2) * perPx);
      dist *= Math.max(0.5, Math.min(2, scale));
    }
    this.camera.position.copy(target).addScaledVector(dir, dist);
    this.controls.target.copy(target);
    this.controls.update();
    this.camera.updateMatrixWorld();
  }

  take(id, values) { const p = this.parts[id]; if (p) p.take(values); }

  // draws; returns true when new cell data was shown
  draw() {
    this._resize();
    let fresh = false;
    for (const p of this.parts) if (p && p.fresh) { p.paint(); fresh = true; }
    if (!fresh && !this.dirty) return false;
    this.dirty = false;
    if (fresh) this._moveMarkers();
    this.renderer.render(this.scene, this.camera);
    this._labels();
    if (fresh) this.drawn++;
    return fresh;
  }

  // each part's name above the far edge of its rest shape
  _labels() {
    const v = new THREE.Vector3(), r = this.canvas.getBoundingClientRect(), up = this.canvas.parentElement.getBoundingClientRect();
    for (const p of this.parts) {
      if (!p) continue;
      v.set(0, p.size[1] / 2 + 0.8 * SPACING, -p.size[2] / 2 - 0.8 * SPACING);
      p.group.localToWorld(v).project(this.camera);
      const hide = v.z > 1 || Math.abs(v.x) > 1.2 || Math.abs(v.y) > 1.2;
      p.label.style.display = hide ? "none" : "";
      p.label.style.left = `${r.left - up.left + (v.x + 1) / 2 * r.width}px`;
      p.label.style.top = `${r.top - up.top + (1 - v.y) / 2 * r.height}px`;
    }
    for (const { el, at } of this.waveguide ? this.waveguide.labels : []) {
      v.copy(at).project(this.camera);
      el.style.display = v.z > 1 || Math.abs(v.x) > 1.2 || Math.abs(v.y) > 1.2 ? "none" : "";
      el.style.left = `${r.left - up.left + (v.x + 1) / 2 * r.width}px`;
      el.style.top = `${r.top - up.top + (1 - v.y) / 2 * r.height}px`;
    }
    // a microphone's name above the top of its line
    for (const { label, item } of this.micLabels) {
      this.parts[item.lattice].cellWorld(item.flat, v);
      v.y += MARKER_REACH;
      v.project(this.camera);
      label.style.display = v.z > 1 || Math.abs(v.x) > 1.2 || Math.abs(v.y) > 1.2 ? "none" : "";
      label.style.left = `${r.left - up.left + (v.x + 1) / 2 * r.width}px`;
      label.style.top = `${r.top - up.top + (1 - v.y) / 2 * r.height - 2}px`;
    }
  }

  _resize() {
    const w = this.canvas.clientWidth, h = this.canvas.clientHeight;
    if (w && h && (this.w !== w || this.h !== h)) {
      this.w = w; this.h = h;
      this.renderer.setSize(w, h, false);
      this.camera.aspect = w / h;
      this.camera.updateProjectionMatrix();
      this.dirty = true;
    }
  }

  // excitations, microphones and joins as the server lists them (with lattice ids and flat cells)
  setMarkers(excitations, microphones, joins) {
    this.markers.clear();
    this.markerList = [];
    this.micLabels.forEach((m) => m.label.remove());
    this.micLabels = microphones.filter((m) => m.lattice != null && this.parts[m.lattice]).map((m) => {
      const label = Object.assign(document.createElement("div"), { className: "label mic", textContent: m.block });
      this.canvas.parentElement.append(label);
      return { label, item: m };
    });
    const ring = new THREE.TorusGeometry(0.42 * SPACING, 0.07 * SPACING, 8, 24);
    for (const e of excitations) this._mark(e, new THREE.Mesh(ring, new THREE.MeshBasicMaterial({ color: 0x22dd44 })), "ring");
    for (const m of microphones) {
      const g = new THREE.CylinderGeometry(0.06 * SPACING, 0.06 * SPACING, 3 * SPACING, 6);
      this._mark(m, new THREE.Mesh(g, new THREE.MeshBasicMaterial({ color: 0x3388ff })), "line");
    }
    for (const j of joins) {
      const g = new THREE.BufferGeometry().setAttribute("position", new THREE.BufferAttribute(new Float32Array(6), 3));
      const line = new THREE.Line(g, new THREE.LineBasicMaterial({ color: 0xff9922 }));
      line.userData = { join: j };
      this.markers.add(line);
      this.markerList.push(line);
    }
    this._moveMarkers();
    this.dirty = true;
  }

  _mark(item, mesh, kind) {
    if (item.lattice == null || !this.parts[item.lattice]) return;
    if (kind === "ring") mesh.rotation.x = Math.PI / 2;
    mesh.userData = { item };
    this.markers.add(mesh);
    this.markerList.push(mesh);
  }

  _moveMarkers() {
    const v = new THREE.Vector3(), w = new THREE.Vector3();
    for (const m of this.markerList || []) {
      const j = m.userData.join;
      if (j) {
        if (!j.pa || !this.parts[j.pa.lattice] || !this.parts[j.pb.lattice]) continue;
        this.parts[j.pa.lattice].cellWorld(j.pa.flat, v);
        this.parts[j.pb.lattice].cellWorld(j.pb.flat, w);
        const a = m.geometry.attributes.position;
        a.setXYZ(0, v.x, v.y, v.z); a.setXYZ(1, w.x, w.y, w.z); a.needsUpdate = true;
        continue;
      }
      const it = m.userData.item;
      this.parts[it.lattice].cellWorld(it.flat, v);
      m.position.copy(v);
    }
  }

  // the cell under a point of the canvas: {lattice, flat} or null
  pick(clientX, clientY) {
    const r = this.canvas.getBoundingClientRect();
    const ndc = new THREE.Vector2(((clientX - r.left) / r.width) * 2 - 1, -((clientY - r.top) / r.height) * 2 + 1);
    this.raycaster.setFromCamera(ndc, this.camera);
    const dist = this.camera.position.distanceTo(this.controls.target);
    this.raycaster.params.Points.threshold = Math.max(0.3 * SPACING, dist * 0.012);
    const hits = this.raycaster.intersectObjects(this.parts.filter(Boolean).map((p) => p.points), false);
    if (!hits.length) return null;
    // nearest to the ray, then nearest to the eye: a block's front cell wins over one behind it
    hits.sort((a, b) => (a.distanceToRay - b.distanceToRay) || (a.distance - b.distance));
    return { lattice: hits[0].object.userData.part.id, flat: hits[0].index };
  }

  // the cells whose screen position falls in a rectangle of client coordinates
  cellsIn(x0, y0, x1, y1) {
    const r = this.canvas.getBoundingClientRect(), v = new THREE.Vector3(), out = [];
    const [ax, bx] = [Math.min(x0, x1), Math.max(x0, x1)], [ay, by] = [Math.min(y0, y1), Math.max(y0, y1)];
    for (const p of this.parts) {
      if (!p) continue;
      for (let f = 0; f < p.n; f++) {
        if (!p.seen(f)) continue;
        p.cellWorld(f, v).project(this.camera);
        const sx = r.left + (v.x + 1) / 2 * r.width, sy = r.top + (1 - v.y) / 2 * r.height;
        if (v.z < 1 && sx >= ax && sx <= bx && sy >= ay && sy <= by) out.push({ lattice: p.id, flat: f });
      }
    }
    return out;
  }

  // screen position (client coordinates) of a cell, for tests and tooltips
  screenOf(lattice, flat) {
    const r = this.canvas.getBoundingClientRect();
    const v = this.parts[lattice].cellWorld(flat).project(this.camera);
    return { x: r.left + (v.x + 1) / 2 * r.width, y: r.top + (1 - v.y) / 2 * r.height };
  }

  // one layer of a block (or all: null)
  setLayer(id, layer) {
    for (const p of this.parts) if (p) p.setLayer(p.id === id ? layer : null);
    this.dirty = true;
  }

  setSelection(cells) {
    for (const p of this.parts) if (p) p.setSelection(cells.filter((c) => c.lattice === p.id).map((c) => c.flat));
    this.dirty = true;
  }
}
