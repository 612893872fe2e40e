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

// The skin drawn over the cells: each uncut cell owns the tile (a sheet's or a slice's square,
// a string's segment) reaching half a spacing to each side, so a cut leaves a hole exactly the
// size of the cut cells. The tiles' corners are shared: a corner sits half a spacing from the
// cells around it and moves with their mean. Returns the corners' rest positions (x, y, z), for
// each corner the uncut cells around it (CSR: start offsets and cells), and the index of the
// skin's line segments (a string) or triangles (sheets and slices); a block has none.
export function skin(shape, cut, rest) {
  const kind = kindOf(shape), gone = new Set(cut), half = SPACING / 2;
  if (kind === "block") return { corners: new Float32Array(0), start: new Int32Array(1), cells: new Int32Array(0), lines: [], triangles: [] };
  const h = kind === "string" ? 1 : shape[shape.length - 2], w = shape[shape.length - 1];
  const slices = count(shape) / (h * w), ch = kind === "string" ? 1 : h + 1, cw = w + 1, per = ch * cw;
  const corners = new Float32Array(3 * slices * per), around = [];
  for (let s = 0; s < slices; s++) {
    for (let r = 0; r < ch; r++) {
      for (let c = 0; c < cw; c++) {
        const k = s * per + r * cw + c, cr = Math.min(r, h - 1), cc = Math.min(c, w - 1), f = s * h * w + cr * w + cc;
        corners[3 * k] = rest[3 * f] + (c < w ? -half : half);
        corners[3 * k + 1] = rest[3 * f + 1];
        corners[3 * k + 2] = rest[3 * f + 2] + (kind === "string" ? 0 : r < h ? -half : half);
        const mine = [];
        for (const rr of kind === "string" ? [0] : [r - 1, r]) {
          for (const c2 of [c - 1, c]) {
            const g = s * h * w + rr * w + c2;
            if (rr >= 0 && rr < h && c2 >= 0 && c2 < w && !gone.has(g)) mine.push(g);
          }
        }
        around.push(mine);
      }
    }
  }
  const start = new Int32Array(around.length + 1);
  around.forEach((m, k) => { start[k + 1] = start[k] + m.length; });
  const cells = Int32Array.from(around.flat());
  const lines = [], triangles = [];
  for (let f = 0; f < count(shape); f++) {
    if (gone.has(f)) continue;
    const s = Math.floor(f / (h * w)), r = Math.floor((f % (h * w)) / w), c = f % w, a = s * per + r * cw + c;
    if (kind === "string") lines.push(a, a + 1);
    else triangles.push(a, a + cw, a + 1, a + 1, a + cw, a + cw + 1);
  }
  return { corners, start, cells, lines, triangles };
}
