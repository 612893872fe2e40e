// The patch's wiring as a graph: blocks in columns by their distance from the sources (the longest
// path along connections, loops cut where they close), connections as curves from an output to
// an input. A cell port (`blk[1, 1, 2].force`) is drawn on its lattice's box.
const NS = "http://www.w3.org/2000/svg";
const W = 120, H = 26, DX = 170, DY = 40, PAD = 12;

function node(tag, attrs, text) {
  const e = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  return e;
}

export function blockOf(end) {
  return end.replace(/\[.*\]/, "").split(".")[0];
}

// column of each block: longest path from a block with no inputs, bounded by the block count
export function columns(names, edges) {
  const col = Object.fromEntries(names.map((n) => [n, 0]));
  for (let pass = 0; pass < names.length; pass++) {
    let moved = false;
    for (const [a, b] of edges) {
      if (a === b || !(a in col) || !(b in col)) continue;
      if (col[b] < col[a] + 1 && col[a] + 1 < names.length) { col[b] = col[a] + 1; moved = true; }
    }
    if (!moved) break;
  }
  return col;
}

export class Wiring {
  _curve(a, b, title, cls) {
    if (!a || !b) return;
    const x0 = a.x + W, y0 = a.y + H / 2, x1 = b.x, y1 = b.y + H / 2, bend = Math.max(40, Math.abs(x1 - x0) / 2);
    const path = node("path", { d: `M${x0},${y0} C${x0 + bend},${y0} ${x1 - bend},${y1} ${x1},${y1}`, class: cls });
    path.append(node("title", {}, title));
    this.svg.append(path);
  }

  constructor(ctx) { this.ctx = ctx; this.svg = document.getElementById("wiring"); }

  update(desc) {
    const names = desc.graph.blocks.map((b) => b.name);
    const types = Object.fromEntries(desc.graph.blocks.map((b) => [b.name, b.type]));
    // a join (a spring block naming two cells) sits between the two parts it joins
    const joins = desc.joins.flatMap((j) => [[blockOf(j.a), j.block], [j.block, blockOf(j.b)]]);
    const edges = desc.graph.connections.map((c) => [blockOf(c.src), blockOf(c.dst)]).concat(joins);
    const col = columns(names, edges);
    const rows = {}, at = {};
    for (const n of names) {
      const c = col[n];
      rows[c] = (rows[c] || 0) + 1;
      at[n] = { x: PAD + c * DX, y: PAD + (rows[c] - 1) * DY };
    }
    const width = PAD * 2 + (Math.max(0, ...Object.values(col)) * DX) + W;
    const height = PAD * 2 + Math.max(1, ...Object.values(rows)) * DY;
    this.svg.innerHTML = "";
    this.svg.setAttribute("viewBox", `0 0 ${width} ${height}`);
    this.svg.setAttribute("width", "100%");
    this.svg.style.maxWidth = `${width}px`;
    const seen = new Set();
    for (const [a, b] of joins) this._curve(at[a], at[b], `${a} ~ ${b}: joined by a spring`, "wire join");
    for (const c of desc.graph.connections) {
      const a = at[blockOf(c.src)], b = at[blockOf(c.dst)];
      const k = `${blockOf(c.src)}>${blockOf(c.dst)}`;
      if (!a || !b || seen.has(k)) continue;
      seen.add(k);
      this._curve(a, b, desc.graph.connections.filter((d) => `${blockOf(d.src)}>${blockOf(d.dst)}` === k)
        .map((d) => `${d.src} -> ${d.dst}`).join("\n"), "wire");
    }
    for (const n of names) {
      const g = node("g", { class: `wblock t-${types[n]}`, transform: `translate(${at[n].x},${at[n].y})` });
      g.append(node("rect", { width: W, height: H, rx: 4 }), node("text", { x: 6, y: 17 }, `${n}: ${types[n]}`));
      this.svg.append(g);
    }
  }
}
