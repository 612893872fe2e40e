// Where each cell of a lattice sits at rest, and which cells are drawn joined.
//
// A cell is addressed by its flat index in C order (the last axis fastest), as numpy and the
// server count them. Strings lie along x, sheets in the x-z plane, blocks fill x-y-z; four and
// more dimensions become a grid of 2-D slices over the last two axes (rows and columns of the
// grid run over the leading axes), as Cymatic could not draw them either. Displacement is drawn
// along y (the cells move along one axis, as in Cymatic); in a block it mostly shows as colour.

export const SPACING = 1.0;
const SLICE_GAP = 1.5;

export function strides(shape) {
  const out = new Array(shape.length);
  let s = 1;
  for (let a = shape.length - 1; a >= 0; a--) { out[a] = s; s *= shape[a]; }
  return out;
}

export function count(shape) {
  return shape.reduce((a, b) => a * b, 1);
}

export function unflatten(shape, flat) {
  const idx = new Array(shape.length);
  for (let a = shape.length - 1; a >= 0; a--) { idx[a] = flat % shape[a]; flat = Math.floor(flat / shape[a]); }
  return idx;
}

export function flatten(shape, idx) {
  const st = strides(shape);
  return idx.reduce((acc, i, a) => acc + i * st[a], 0);
}

// "plate[4, 5]" as probes write it
export function cellName(lattice, shape, flat) {
  return `${lattice}[${unflatten(shape, flat).join(", ")}]`;
}

// "plate[4, 5]" -> {lattice: "plate", index: [4, 5]}; null when it is not a lattice cell
export function parseCell(text) {
  const m = /^\s*([A-Za-z_][\w.]*)\s*\[([\d,\s]+)\]\s*$/.exec(text || "");
  if (!m) return null;
  return { lattice: m[1], index: m[2].split(",").map((s) => parseInt(s, 10)) };
}

// The kind of drawing a shape gets: 'string' | 'sheet' | 'block' | 'slices'
export function kindOf(shape) {
  return ["string", "sheet", "block"][shape.length - 1] || "slices";
}

function gridOfSlices(shape) {
  const lead = shape.slice(0, -2);
  const cols = lead[lead.length - 1];
  const rows = count(lead) / cols;
  return { rows, cols, h: shape[shape.length - 2], w: shape[shape.length - 1] };
}

// Rest positions (x, y, z per cell) centred on the origin, and the extent along x and z.
export function restPositions(shape) {
  const n = count(shape);
  const pos = new Float32Array(3 * n);
  const kind = kindOf(shape);
  const g = kind === "slices" ? gridOfSlices(shape) : null;
  for (let f = 0; f < n; f++) {
    const idx = unflatten(shape, f);
    let x = 0, y = 0, z = 0;
    if (kind === "string") x = idx[0];
    else if (kind === "sheet") { x = idx[1]; z = idx[0]; }
    else if (kind === "block") { x = idx[2]; z = idx[1]; y = idx[0]; }
    else {
      const slice = Math.floor(f / (g.h * g.w));
      const row = Math.floor(slice / g.cols), col = slice % g.cols;
      x = col * (g.w - 1 + SLICE_GAP) + idx[idx.length - 1];
      z = row * (g.h - 1 + SLICE_GAP) + idx[idx.length - 2];
    }
    pos[3 * f] = x * SPACING; pos[3 * f + 1] = y * SPACING; pos[3 * f + 2] = z * SPACING;
  }
  return centre(pos);
}

function centre(pos) {
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < pos.length; i++) { const a = i % 3; lo[a] = Math.min(lo[a], pos[i]); hi[a] = Math.max(hi[a], pos[i]); }
  const mid = lo.map((l, a) => (l + hi[a]) / 2);
  for (let i = 0; i < pos.length; i++) pos[i] -= mid[i % 3];
  return { pos, size: hi.map((h, a) => h - lo[a]) };
}

// Pairs of cells drawn as line segments (a string's neighbours) or triangles (a sheet's or a
// slice's quads); a cut cell takes its segments and triangles away.
export function topology(shape, cut) {
  const kind = kindOf(shape);
  const gone = new Set(cut);
  if (kind === "string") {
    const seg = [];
    for (let i = 0; i + 1 < shape[0]; i++) if (!gone.has(i) && !gone.has(i + 1)) seg.push(i, i + 1);
    return { lines: seg, triangles: [] };
  }
  if (kind === "block") return { lines: [], triangles: [] };
  const h = shape[shape.length - 2], w = shape[shape.length - 1];
  const tri = [];
  for (let base = 0; base < count(shape); base += h * w) {
    for (let r = 0; r + 1 < h; r++) {
      for (let c = 0; c + 1 < w; c++) {
        const a = base + r * w + c, b = a + 1, d = a + w, e = d + 1;
        if (gone.has(a) || gone.has(b) || gone.has(d) || gone.has(e)) continue;
        tri.push(a, d, b, b, d, e);
      }
    }
  }
  return { lines: [], triangles: tri };
}
