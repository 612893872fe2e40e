// One lattice drawn: a line (string), a surface (sheet, slices of >= 4-D) or points (block),
// with every cell also a point so that it can be picked. Colour shows displacement on a
// blue-white-red scale normalised by a decaying peak, so a quiet instrument is still seen moving.
import * as THREE from "three";
import { restPositions, topology, kindOf, count, SPACING } from "./layout.js";

const LOCKED = new THREE.Color(0x3a3a3a);
const LIFT = 0.45 * SPACING;     // the loudest cell moves this far (display units)
const DECAY = 0.9;               // per drawn frame: the colour scale follows a fast-fading peak (the
                                 // sound decays slower, so a ringing instrument stays coloured)

export function displacementColour(u, out, o) {
  // u in [-1, 1]: blue (down) - near-white - red (up); the square root lifts the quieter cells
  const a = Math.sqrt(Math.min(1, Math.abs(u)));
  if (u >= 0) { out[o] = 0.92; out[o + 1] = 0.92 - 0.75 * a; out[o + 2] = 0.92 - 0.8 * a; }
  else { out[o] = 0.92 - 0.8 * a; out[o + 1] = 0.92 - 0.6 * a; out[o + 2] = 0.92; }
}

export class Part {
  constructor(spec) {
    this.name = spec.name;
    this.shape = spec.shape;
    this.kind = kindOf(spec.shape);
    this.n = count(spec.shape);
    const { pos, size } = restPositions(spec.shape);
    this.rest = pos;
    this.size = size;
    this.values = new Float32Array(this.n);
    this.fresh = false;
    this.peak = 1e-12;
    this.group = new THREE.Group();
    this.group.name = spec.name;
    this.geometry = new THREE.BufferGeometry();
    this.position = new THREE.BufferAttribute(new Float32Array(pos), 3).setUsage(THREE.DynamicDrawUsage);
    this.colour = new THREE.BufferAttribute(new Float32Array(3 * this.n), 3).setUsage(THREE.DynamicDrawUsage);
    this.geometry.setAttribute("position", this.position);
    this.geometry.setAttribute("color", this.colour);
    this.points = new THREE.Points(this.geometry, new THREE.PointsMaterial({
      size: this.kind === "block" ? 0.45 : this.kind === "string" ? 0.35 : 0.22, vertexColors: true, sizeAttenuation: true }));
    this.points.userData.part = this;
    this.group.add(this.points);
    this.overlays = {};
    this.setCells(spec.locked || [], spec.cut || []);
  }

  setCells(locked, cut) {
    this.locked = new Set(locked);
    this.cut = new Set(cut);
    this._rebuildSkin();
    this._showCells();
    this.paint();
  }

  // A block shows one layer (first axis = `layer`) or all (null): the inner cells can then be
  // seen and clicked, to place a microphone or an excitation inside the block.
  setLayer(layer) {
    this.layer = this.kind === "block" ? layer : null;
    this._showCells();
  }

  seen(f) {
    return !this.cut.has(f) && (this.layer == null || Math.floor(f / this.layerSize) === this.layer);
  }

  _showCells() {
    this.layerSize = this.n / this.shape[0];
    const visible = [];
    for (let f = 0; f < this.n; f++) if (this.seen(f)) visible.push(f);
    this.geometry.setIndex(visible);
    this.geometry.boundingSphere = null;
    this._overlay("locked", [...this.locked].filter((f) => this.seen(f)), 0x202020, 0.5);
  }

  // The skin and the overlays share the cells' position (and colour) buffers, so they are never
  // disposed (that would free the shared buffers): a change only gives them a new index.
  _rebuildSkin() {
    const topo = topology(this.shape, [...this.cut]);
    const index = topo.lines.length ? topo.lines : topo.triangles;
    if (!this.skin) {
      if (!index.length) return;
      const g = new THREE.BufferGeometry();
      g.setAttribute("position", this.position);
      g.setAttribute("color", this.colour);
      this.skin = topo.lines.length
        ? new THREE.LineSegments(g, new THREE.LineBasicMaterial({ vertexColors: true }))
        : new THREE.Mesh(g, new THREE.MeshBasicMaterial({ vertexColors: true, side: THREE.DoubleSide, transparent: true, opacity: 0.85 }));
      this.group.add(this.skin);
    }
    this.skin.geometry.setIndex(index);
  }

  // A set of cells drawn again on top (locked cells, the selection), sharing the positions.
  _overlay(key, cells, colour, size) {
    let p = this.overlays[key];
    if (!p) {
      const g = new THREE.BufferGeometry();
      g.setAttribute("position", this.position);
      p = new THREE.Points(g, new THREE.PointsMaterial({ color: colour, size, sizeAttenuation: true, depthTest: key !== "selection" }));
      p.renderOrder = key === "selection" ? 2 : 1;
      this.overlays[key] = p;
      this.group.add(p);
    }
    p.geometry.setIndex(cells);
    p.visible = cells.length > 0;
  }

  setSelection(cells) {
    this._overlay("selection", cells, 0xffd000, this.kind === "block" ? 0.6 : 0.4);
  }

  // A new frame of displacements (metres), drawn at the next paint.
  take(values) {
    if (values.length !== this.n) return;
    this.values.set(values);
    this.fresh = true;
  }

  paint() {
    const v = this.values, pos = this.position.array, col = this.colour.array, rest = this.rest;
    let peak = 0;
    for (let f = 0; f < this.n; f++) { const a = Math.abs(v[f]); if (a > peak) peak = a; }   // NaN (cut) skipped
    this.peak = Math.max(peak, this.peak * DECAY, 1e-12);
    const k = 1 / this.peak;
    for (let f = 0, o = 0; f < this.n; f++, o += 3) {
      const x = v[f];
      const u = x === x ? x * k : 0;          // a cut cell (NaN) rests where it was, unseen
      pos[o + 1] = rest[o + 1] + LIFT * u;
      if (this.locked.has(f)) { col[o] = LOCKED.r; col[o + 1] = LOCKED.g; col[o + 2] = LOCKED.b; }
      else displacementColour(u, col, o);
    }
    this.position.needsUpdate = true;
    this.colour.needsUpdate = true;
    this.fresh = false;
  }

  // Where a cell is now, in world coordinates.
  cellWorld(flat, out = new THREE.Vector3()) {
    const p = this.position.array;
    out.set(p[3 * flat], p[3 * flat + 1], p[3 * flat + 2]);
    return this.group.localToWorld(out);
  }
}
