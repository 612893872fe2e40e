// One lattice drawn: a line (string), a surface (sheet, slices of >= 4-D) or points (block),
// with every cell also a point so that it can be picked. Colour shows displacement on a
// blue-white-red scale normalised by a decaying peak, so a quiet instrument is still seen moving.
// Locked cells carry a pin marker, cells whose mass was edited a ring sized by their mass.
import * as THREE from "three";
import { restPositions, skin, kindOf, count, SPACING } from "./layout.js";

const LOCKED = new THREE.Color(0x3a3a3a);
export const MASS_COLOUR = "#d070ff";
// a locked cell's pin (a mass ring is this big for 4 times the lattice's mass); a point's size
// shows at about 0.4 of the same length (three.js scales points by half the view's height)
const MARKER = 1.6 * SPACING;

// The markers' pictures, drawn once (the legend shows the same pictures).
export function markerCanvas(kind) {
  const c = document.createElement("canvas");
  c.width = c.height = 64;
  const g = c.getContext("2d");
  if (kind === "locked") {             // a pin: a dark square, a light frame and a cross
    g.fillStyle = "#202020"; g.fillRect(8, 8, 48, 48);
    g.strokeStyle = "#e8e8e8"; g.lineWidth = 6; g.strokeRect(8, 8, 48, 48);
    g.beginPath(); g.moveTo(18, 18); g.lineTo(46, 46); g.moveTo(46, 18); g.lineTo(18, 46); g.stroke();
  } else {                             // a ring, the cell seen through it
    g.strokeStyle = MASS_COLOUR; g.lineWidth = 8; g.beginPath(); g.arc(32, 32, 26, 0, 2 * Math.PI); g.stroke();
  }
  return c;
}

const textures = {};
function texture(kind) {
  return textures[kind] || (textures[kind] = new THREE.CanvasTexture(markerCanvas(kind)));
}
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
    this._overlay("locked", [...this.locked].filter((f) => this.seen(f)), { map: texture("locked"), size: MARKER });
    for (const [key, m] of Object.entries(this.masses || {})) {
      this._overlay(key, m.cells.filter((f) => this.seen(f)), { map: texture("mass"), size: m.size * MARKER });
    }
  }

  // Cells whose mass differs from the lattice's: {flat: mass}, `mass` the lattice's. One ring
  // overlay per mass, its size growing with the cube root of the ratio (a mass's linear size).
  setMasses(masses, mass) {
    for (const key of Object.keys(this.masses || {})) this.overlays[key].visible = false;
    const by = {};
    for (const [flat, m] of Object.entries(masses)) (by[m] = by[m] || []).push(Number(flat));
    this.masses = {};
    for (const [m, cells] of Object.entries(by)) {
      const ratio = Number(m) / mass;
      this.masses[`mass ${m}`] = { cells, ratio, size: Math.min(2, Math.max(0.5, Math.cbrt(ratio) / 1.6)) };
    }
    this._showCells();
  }

  // The skin has corners of its own (between the cells), moved by paint() with the cells
  // around them; a cut changes which cells those are and which tiles are drawn.
  _rebuildSkin() {
    const sk = skin(this.shape, [...this.cut], this.rest);
    this.sk = sk;
    const index = sk.lines.length || this.kind === "string" ? sk.lines : sk.triangles;
    if (!this.skin) {
      if (this.kind === "block") return;
      const g = new THREE.BufferGeometry();
      g.setAttribute("position", new THREE.BufferAttribute(new Float32Array(sk.corners), 3).setUsage(THREE.DynamicDrawUsage));
      g.setAttribute("color", new THREE.BufferAttribute(new Float32Array(sk.corners.length), 3).setUsage(THREE.DynamicDrawUsage));
      this.skin = this.kind === "string"
        ? new THREE.LineSegments(g, new THREE.LineBasicMaterial({ vertexColors: true }))
        : new THREE.Mesh(g, new THREE.MeshBasicMaterial({ vertexColors: true, side: THREE.DoubleSide, transparent: true, opacity: 0.85 }));
      this.group.add(this.skin);
    }
    this.skin.geometry.setIndex(index);
  }

  // A set of cells drawn again on top (locked cells, edited masses, the selection), sharing the
  // cells' positions (never disposed: that would free the shared buffer).
  _overlay(key, cells, look) {
    let p = this.overlays[key];
    if (!p) {
      const g = new THREE.BufferGeometry();
      g.setAttribute("position", this.position);
      const marker = look.map ? { map: look.map, transparent: true, alphaTest: 0.3 } : { color: look.colour };
      // the markers drawn over the skin (a tilted sheet would hide half of each), the cells not
      p = new THREE.Points(g, new THREE.PointsMaterial({ ...marker, size: look.size, sizeAttenuation: true, depthTest: !look.map && key !== "selection" }));
      p.renderOrder = key === "selection" ? 3 : 2;
      this.overlays[key] = p;
      this.group.add(p);
    }
    p.material.size = look.size;
    p.geometry.setIndex(cells);
    p.visible = cells.length > 0;
  }

  setSelection(cells) {
    this._overlay("selection", cells, { colour: 0xffd000, size: this.kind === "block" ? 0.6 : 0.4 });
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
    const k = 1 / this.peak, us = this.us || (this.us = new Float32Array(this.n));
    for (let f = 0, o = 0; f < this.n; f++, o += 3) {
      const x = v[f];
      const u = x === x ? x * k : 0;          // a cut cell (NaN) rests where it was, unseen
      us[f] = u;
      pos[o + 1] = rest[o + 1] + LIFT * u;
      if (this.locked.has(f)) { col[o] = LOCKED.r; col[o + 1] = LOCKED.g; col[o + 2] = LOCKED.b; }
      else displacementColour(u, col, o);
    }
    this.position.needsUpdate = true;
    this.colour.needsUpdate = true;
    if (this.skin) this._paintSkin(us);
    this.fresh = false;
  }

  // each corner of the skin at the mean displacement of the uncut cells around it
  _paintSkin(us) {
    const { corners, start, cells } = this.sk, a = this.skin.geometry.attributes, pos = a.position.array, col = a.color.array;
    for (let k = 0, o = 0; k + 1 < start.length; k++, o += 3) {
      let sum = 0;
      for (let i = start[k]; i < start[k + 1]; i++) sum += us[cells[i]];
      const u = start[k + 1] > start[k] ? sum / (start[k + 1] - start[k]) : 0;
      pos[o + 1] = corners[o + 1] + LIFT * u;
      displacementColour(u, col, o);
    }
    a.position.needsUpdate = true;
    a.color.needsUpdate = true;
  }

  // Where a cell is now, in world coordinates.
  cellWorld(flat, out = new THREE.Vector3()) {
    const p = this.position.array;
    out.set(p[3 * flat], p[3 * flat + 1], p[3 * flat + 2]);
    return this.group.localToWorld(out);
  }
}
