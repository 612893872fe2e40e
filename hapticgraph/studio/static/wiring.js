// The patch's wiring as a graph: blocks in columns by their distance from the sources (the longest
// path along connections, loops cut where they close), connections as curves from an output to
// an input. A cell port (`blk[1, 1, 2].force`) is drawn on its lattice's box.
const NS = "http://www.w3.org/2000/svg";
const H = 26, GAP_X = 50, DY = 40, PAD = 12, FONT_PX = 12, TEXT_PAD = 8;
const MIN_W = 120;

function node(tag, attrs, text) {
  const e = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  return e;
}

// the width of a box's text at the graph's font
function textWidth(text) {
  const g = textWidth.g || (textWidth.g = document.createElement("canvas").getContext("2d"));
  g.font = `${FONT_PX}px system-ui, sans-serif`;
  return Math.ceil(g.measureText(text).width);
}

export function blockOf(end) {
  return end.replace(/\[.*\]/, "").split(".")[0];
}

// column of each block: the longest path from a block with no inputs along the connections, each
// loop cut where a depth-first walk from the sources closes it (a waveguide's loop would
// otherwise push every block of it one column further, round and round)
export function columns(names, edges) {
  const out = Object.fromEntries(names.map((n) => [n, []]));
  for (const [a, b] of edges) if (a !== b && a in out && b in out) out[a].push(b);
  const fed = new Set(edges.map(([, b]) => b));
  const state = {}, order = [], forward = [];
  const walk = (n) => {
    state[n] = 1;
    for (const m of out[n]) {
      if (state[m] === 1) continue;            // closes a loop: cut
      forward.push([n, m]);
      if (!state[m]) walk(m);
    }
    state[n] = 2;
    order.push(n);
  };
  for (const n of [...names.filter((n) => !fed.has(n)), ...names]) if (!state[n]) walk(n);
  const col = Object.fromEntries(names.map((n) => [n, 0]));
  for (const n of order.reverse()) for (const [a, b] of forward) if (a === n) col[b] = Math.max(col[b], col[a] + 1);
  return col;
}

export class Wiring {
  _curve(a, b, title, cls) {
    if (!a || !b) return;
    const x0 = a.x + this.w, y0 = a.y + H / 2, x1 = b.x, y1 = b.y + H / 2, bend = Math.max(40, Math.abs(x1 - x0) / 2);
    const path = node("path", { d: `M${x0},${y0} C${x0 + bend},${y0} ${x1 - bend},${y1} ${x1},${y1}`, class: cls });
    path.append(node("title", {}, title));
    this.svg.append(path);
  }

  constructor(ctx) {
    this.ctx = ctx;
    this.svg = document.getElementById("wiring");
    // the stage draws from the describe object too (edited masses, a waveguide's delay lines):
    // it is updated with the panels
    ctx.panels.stage = ctx.view;
  }

  update(desc) {
    const names = desc.graph.blocks.map((b) => b.name);
    const types = Object.fromEntries(desc.graph.blocks.map((b) => [b.name, b.type]));
    // a join (a spring block naming two cells) sits between the two parts it joins
    const joins = desc.joins.flatMap((j) => [[blockOf(j.a), j.block], [j.block, blockOf(j.b)]]);
    const edges = desc.graph.connections.map((c) => [blockOf(c.src), blockOf(c.dst)]).concat(joins);
    const col = columns(names, edges);
    // a box as wide as the longest name needs
    const W = this.w = Math.max(MIN_W, ...names.map((n) => textWidth(`${n}: ${types[n]}`) + 2 * TEXT_PAD));
    const DX = W + GAP_X;
    const rows = {}, at = {};
    for (const n of names) {
      const c = col[n];
      rows[c] = (rows[c] || 0) + 1;
      at[n] = { x: PAD + c * DX, y: PAD + (rows[c] - 1) * DY };
    }
    const width = PAD * 2 + (Math.max(0, ...Object.values(col)) * DX) + W;
    const height = PAD * 2 + Math.max(1, ...Object.values(rows)) * DY;
    this.svg.innerHTML = "";
    // drawn one to one (the tab scrolls): a graph scaled to fit had text of a few pixels
    this.svg.setAttribute("viewBox", `0 0 ${width} ${height}`);
    this.svg.setAttribute("width", width);
    this.svg.setAttribute("height", height);
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
      g.append(node("rect", { width: W, height: H, rx: 4 }), node("text", { x: TEXT_PAD, y: 17 }, `${n}: ${types[n]}`));
      this.svg.append(g);
    }
  }
}
