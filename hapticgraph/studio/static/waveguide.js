// A waveguide patch drawn as what it models: its longest loop through delay lines (a string's
// round trip, nut -> right-going lines -> bridge -> left-going lines -> nut) folded in two, so the
// right-going lines run along one rail and the left-going ones back along the other, each as long
// as its delay; the blocks on the loop are nodes on the string (a junction met twice, once per
// direction, is one node between the rails), the other blocks stand in rows above, over the
// points they connect to. Distances are in samples of delay.
const BUDGET = 200000;       // edges walked looking for the longest loop (a small patch needs few)

function ends(text) {
  const m = /^([A-Za-z_]\w*)\.(\w+)$/.exec(text);
  return m ? { block: m[1], port: m[2] } : null;
}

// The longest loop through delay lines, port to port: [{block, from: input, to: output}], or [].
export function longestLoop(graph, lengths) {
  const next = new Map();
  const add = (a, b, w, step) => { if (!next.has(a)) next.set(a, []); next.get(a).push({ b, w, step }); };
  for (const blk of graph.blocks) {
    for (const i of blk.inputs) for (const o of blk.outputs) add(`i ${blk.name}.${i}`, `o ${blk.name}.${o}`, lengths[blk.name] || 0, { block: blk.name, from: i, to: o });
  }
  for (const c of graph.connections) {
    const a = ends(c.src), b = ends(c.dst);
    if (a && b) add(`o ${c.src}`, `i ${c.dst}`, 0, null);
  }
  let best = { w: 0, steps: [] }, budget = BUDGET;
  const on = new Set(), steps = [];
  const walk = (node, start, w) => {
    for (const e of next.get(node) || []) {
      if (--budget < 0) return;
      if (e.b === start) { if (w + e.w > best.w) best = { w: w + e.w, steps: [...steps, e.step].filter(Boolean) }; continue; }
      if (on.has(e.b) || e.b < start) continue;        // each loop once: from its smallest node
      on.add(e.b); steps.push(e.step);
      walk(e.b, start, w + e.w);
      on.delete(e.b); steps.pop();
    }
  };
  for (const start of [...next.keys()].sort()) { on.clear(); on.add(start); walk(start, start, 0); }
  return best.steps;
}

// Where everything is drawn: {loop (block names in order), samples (the loop's delay), delays:
// [{block, length, parts: [[x0, z0, x1, z1]]}], nodes: [{block, type, x, z, onLoop}], links:
// [[block, block]]}; null when no loop runs through a delay line.
export function stringLayout(graph, lengths) {
  const steps = longestLoop(graph, lengths);
  if (!steps.length) return null;
  const samples = steps.reduce((a, s) => a + (lengths[s.block] || 0), 0);
  // start at a block met once, the one with another block nearest to the opposite point
  const at = [];
  let s = 0;
  for (const st of steps) { at.push(s); s += lengths[st.block] || 0; }
  const count = {};
  steps.forEach((st) => { count[st.block] = (count[st.block] || 0) + 1; });
  const turning = (k) => {
    const half = (at[k] + samples / 2) % samples;
    const apart = (a, b) => Math.min(Math.abs(a - b), samples - Math.abs(a - b));
    return Math.min(...steps.map((st, j) => (lengths[st.block] || j === k ? Infinity : apart(at[j], half))));
  };
  const rank = Object.fromEntries(graph.blocks.map((b, i) => [b.name, i]));
  const better = (k, than) => than < 0 || turning(k) < turning(than) || (turning(k) === turning(than) && rank[steps[k].block] < rank[steps[than].block]);
  let first = -1;
  steps.forEach((st, k) => { if (!lengths[st.block] && count[st.block] === 1 && better(k, first)) first = k; });
  if (first < 0) first = Math.max(0, steps.findIndex((st) => !lengths[st.block]));
  const order = steps.slice(first).concat(steps.slice(0, first)), from = at[first];
  const rail = Math.max(3, samples * 0.06), row = Math.max(8, samples * 0.12), half = samples / 2;
  const place = (u) => (u <= half ? [u, -rail] : [samples - u, rail]);    // u: samples from the start
  const delays = [], visits = {}, ports = {};
  for (const st of order) {
    const u0 = (at[steps.indexOf(st)] - from + samples) % samples, len = lengths[st.block] || 0;
    if (len) {
      const parts = [], cut = u0 < half && u0 + len > half ? [u0, half, u0 + len] : [u0, u0 + len];
      for (let i = 0; i + 1 < cut.length; i++) {
        const a = place(cut[i] + (i ? 1e-9 : 0)), b = place(cut[i + 1] - 1e-9);
        parts.push([a[0], a[1], b[0], b[1]]);
      }
      delays.push({ block: st.block, length: len, parts });
      ports[`${st.block}.${st.from}`] = place(u0);
      ports[`${st.block}.${st.to}`] = place(u0 + len - 1e-9);
    } else {
      const p = place(u0);
      // a block at the turn (within a sample of either end) sits between the rails
      (visits[st.block] = visits[st.block] || []).push(Math.min(u0, samples - u0) < 1 || Math.abs(u0 - half) < 1 ? [p[0], 0] : p);
    }
  }
  const types = Object.fromEntries(graph.blocks.map((b) => [b.name, b.type]));
  const nodes = Object.entries(visits).map(([block, ps]) => ({ block, type: types[block], onLoop: true,
    x: ps.reduce((a, p) => a + p[0], 0) / ps.length, z: ps.length > 1 ? 0 : ps[0][1] }));
  const where = Object.fromEntries(nodes.map((n) => [n.block, [n.x, n.z]]));
  // the other blocks, in rows above the string by their distance from it
  const links = [], linked = {};
  for (const c of graph.connections) {
    const a = ends(c.src), b = ends(c.dst);
    if (!a || !b || a.block === b.block) continue;
    links.push([a.block, b.block, c.src, c.dst]);
    for (const [me, other, port] of [[a.block, b.block, c.dst], [b.block, a.block, c.src]]) (linked[me] = linked[me] || []).push({ other, port });
  }
  const placed = new Set([...Object.keys(where), ...delays.map((d) => d.block)]);
  for (let level = 1; placed.size < graph.blocks.length && level <= graph.blocks.length; level++) {
    const fresh = [];
    for (const blk of graph.blocks) {
      if (placed.has(blk.name)) continue;
      const xs = (linked[blk.name] || []).filter((l) => placed.has(l.other)).map((l) => (ports[l.port] || where[l.other] || [0])[0]);
      if (xs.length) fresh.push({ block: blk.name, type: blk.type, onLoop: false, x: xs.reduce((a, b) => a + b, 0) / xs.length, z: -rail - level * row });
    }
    if (!fresh.length) break;
    fresh.sort((a, b) => a.x - b.x);
    const gap = Math.max(12, samples * 0.16);
    for (let i = 1; i < fresh.length; i++) fresh[i].x = Math.max(fresh[i].x, fresh[i - 1].x + gap);
    for (const n of fresh) { nodes.push(n); where[n.block] = [n.x, n.z]; placed.add(n.block); }
  }
  return { loop: order.map((st) => st.block), samples, rail, delays, nodes, links, ports };
}
