// A waveguide patch drawn as what it models: its longest loop through delay lines (a string's
// round trip, nut -> right-going lines -> bridge -> left-going lines -> nut) folded in two, so the
// right-going lines run along one rail and the left-going ones back along the other, each as long
// as its delay; the blocks on the loop are nodes on the string (a junction met twice, once per
// direction, is one node between the rails), the other blocks stand in rows above, over the
// points they connect to. Distances are in samples of delay.
import * as THREE from "three";

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
      if (e.b === start) {
        // the most delay; of two loops as long, the one through fewer blocks (no detour)
        const mine = [...steps, e.step].filter(Boolean);
        if (w + e.w > best.w || (w + e.w === best.w && mine.length < best.steps.length)) best = { w: w + e.w, steps: mine };
        continue;
      }
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
  // blocks met at the same point (at the turn, with nothing but a delay line between them) stacked
  for (const n of nodes) {
    const same = nodes.filter((m) => Math.abs(m.x - n.x) < 0.5 && Math.abs(m.z - n.z) < 0.5);
    if (same.length > 1 && same[0] === n) same.forEach((m, i) => { m.z += (i - (same.length - 1) / 2) * 0.8 * rail; });
  }
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

const WG = { delay: 0xe0b050, loop: 0xff9922, other: 0x8a96a8, mic: 0x3388ff, haptic: 0x22dd44, link: 0x5a6678 };

// The layout as three.js objects (delay lines as bars, blocks as balls, connections as lines) and
// the HTML labels put in `parent`: {group, labels: [{el, at}]}, `at` where a label stands.
export function stringScene(layout, parent) {
  const group = new THREE.Group(), labels = [];
  const label = (text, x, z, cls) => {
    const e = Object.assign(document.createElement("div"), { className: `label wg ${cls}`, textContent: text });
    parent.append(e);
    labels.push({ el: e, at: new THREE.Vector3(x, 0, z) });
  };
  const line = new THREE.MeshBasicMaterial({ color: WG.delay }), thick = 0.12 * layout.rail;
  for (const d of layout.delays) {
    let longest = d.parts[0];
    for (const [x0, z0, x1, z1] of d.parts) {
      // a little short of its ends, so that where one line meets the next is seen
      const bar = new THREE.Mesh(new THREE.BoxGeometry(Math.max(Math.abs(x1 - x0) - 0.5, thick), thick, thick), line);
      bar.position.set((x0 + x1) / 2, 0, (z0 + z1) / 2);
      group.add(bar);
      if (Math.abs(x1 - x0) > Math.abs(longest[2] - longest[0])) longest = [x0, z0, x1, z1];
    }
    if (d.parts.length > 1) {             // a line round the turn: the rails joined where it turns
      const [a, b] = [d.parts[0], d.parts[d.parts.length - 1]];
      const bar = new THREE.Mesh(new THREE.BoxGeometry(thick, thick, Math.abs(b[1] - a[3]) + thick), line);
      bar.position.set(a[2], 0, (a[3] + b[1]) / 2);
      group.add(bar);
    }
    const [x0, z0, x1] = longest;
    label(`${d.block} · ${d.length} samples`, (x0 + x1) / 2, z0 + Math.sign(z0) * 0.9 * layout.rail, "delay");
  }
  const where = Object.fromEntries(layout.nodes.map((n) => [n.block, n]));
  const ball = new THREE.SphereGeometry(0.35 * layout.rail, 16, 12);
  for (const n of layout.nodes) {
    const colour = n.onLoop ? WG.loop : WG[n.type] || WG.other;
    const m = new THREE.Mesh(ball, new THREE.MeshBasicMaterial({ color: colour }));
    m.position.set(n.x, 0, n.z);
    m.userData = { block: n.block };
    group.add(m);
    label(`${n.block}: ${n.type}`, n.x, n.z - 0.45 * layout.rail, "node");
  }
  const pts = [];
  for (const [a, b, src, dst] of layout.links) {
    const p = layout.ports[src] || (where[a] && [where[a].x, where[a].z]), q = layout.ports[dst] || (where[b] && [where[b].x, where[b].z]);
    if (p && q) pts.push(p[0], 0, p[1], q[0], 0, q[1]);
  }
  group.add(new THREE.LineSegments(new THREE.BufferGeometry().setAttribute("position", new THREE.Float32BufferAttribute(pts, 3)),
    new THREE.LineBasicMaterial({ color: WG.link })));
  return { group, labels };
}
