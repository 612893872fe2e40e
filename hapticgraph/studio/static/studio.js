// The studio page: connects to the server that served it, draws the running instrument and wires
// every panel to the one protocol (docs/studio.md). `window.studio` is the scripting door:
// send(command) -> Promise of the reply, fps (frames drawn per second with new cell data).
import { Link } from "./link.js";
import { Instrument } from "./instrument.js";
import { flatten } from "./layout.js";
import { Tools, TYPED } from "./tools.js";
import { Params } from "./params.js";
import { Wiring } from "./wiring.js";
import { Scopes } from "./scope.js";
import { Modes } from "./modes.js";
import { Player } from "./audio.js";
import { History } from "./history.js";
import { Mapping } from "./mapping.js";
import { Recovery } from "./recovery.js";
import { $, showError, clearError } from "./dom.js";

const token = new URLSearchParams(location.search).get("token") || "";
const link = new Link(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws?token=${encodeURIComponent(token)}`);
const view = new Instrument($("#view"));

// the protocol's instrument, with cells also as flat indices (what the view counts in)
function withFlat(desc) {
  const byId = {};
  for (const l of desc.lattices) {
    l.lockedFlat = l.locked.map((i) => flatten(l.shape, i));
    l.cutFlat = l.cut.map((i) => flatten(l.shape, i));
    byId[l.id] = l;
  }
  const byName = Object.fromEntries(desc.lattices.map((l) => [l.name, l]));
  const at = (x) => { if (x.lattice != null && x.index) x.flat = flatten(byId[x.lattice].shape, x.index); return x; };
  desc.excitations.forEach(at);
  desc.microphones.forEach(at);
  for (const j of desc.joins) {
    j.pa = cellRef(j.a, byName);
    j.pb = cellRef(j.b, byName);
  }
  desc.byId = byId;
  return desc;
}

function cellRef(text, byName) {
  const m = /^\s*([A-Za-z_][\w]*)\s*(?:\[([\d,\s]*)\])?\s*$/.exec(text || "");
  const l = m && byName[m[1]];
  if (!l) return null;
  const idx = m[2] ? m[2].split(",").map((s) => parseInt(s, 10)) : [0];
  return { lattice: l.id, flat: flatten(l.shape, idx) };
}

// commands that change the patch or the sound (a live parameter's `set` lands at once: not counted)
const EDITS = new Set(["set", "lock", "unlock", "cut", "cells", "join", "place", "remove", "map", "text",
  "undo", "redo", "restart", "save", "recover"]);

function slow(command) {
  if (!EDITS.has(command.cmd)) return false;
  if (command.cmd !== "set" || !studio.desc) return true;
  const p = studio.desc.params.find((x) => x.block === command.block && x.param === command.param);
  return !(p && p.live);
}

// edits sent and not yet answered: shown (#pending, body[data-pending]), and the stage's tools
// take no click meanwhile
function pending(delta) {
  studio.pending += delta;
  const on = studio.pending > 0;
  $("#pending").hidden = !on;
  document.body.toggleAttribute("data-pending", on);
  if (panels.tools) panels.tools.busy(on);
}

// a command through the link; a refused one shows its error, an accepted one clears it
async function send(command) {
  const counted = slow(command);
  if (counted) pending(1);
  let reply;
  try { reply = await link.send(command); } finally { if (counted) pending(-1); }
  if (reply.ok) clearError();
  else showError(reply.errors || [reply.error]);
  return reply;
}

const studio = {
  send: (command) => link.send(command),
  fps: 0, received: 0, renders: 0, desc: null, view, link, pending: 0,
};
window.studio = studio;

const panels = {};
let problemShown = false;       // the banner says the sound stopped (a problem event)

// what a designer can do once the sound stopped to protect the player (a runaway, a NaN)
const STOPPED = "The sound has stopped. Undo, or change what ran away: the sound then starts again from rest " +
  "(t = 0). Or Restart.";

function apply(desc) {
  desc = withFlat(desc);
  studio.desc = desc;
  view.build(desc.lattices);
  view.setMarkers(desc.excitations, desc.microphones, desc.joins);
  $("#title").textContent = `${desc.patch.name} — ${desc.patch.path}`;
  for (const p of Object.values(panels)) p.update(desc);
  if (desc.problem) { showError([desc.problem, STOPPED]); problemShown = true; }
  else if (problemShown) { clearError(); problemShown = false; }     // the sound plays again
}

function measure() {
  let drawn = 0, recv = 0, renders = 0, t0 = performance.now();
  const loop = () => {
    if (view.draw()) drawn++;
    renders++;           // animation frames (the picture is redrawn only when something changed)
    const t = performance.now();
    if (t - t0 >= 1000) {
      studio.fps = Math.round((drawn * 1000) / (t - t0) * 10) / 10;
      studio.received = Math.round(((link.received - recv) * 1000) / (t - t0) * 10) / 10;
      studio.renders = Math.round((renders * 1000) / (t - t0) * 10) / 10;
      $("#fps").textContent = `${studio.fps.toFixed(0)} fps`;
      drawn = 0; renders = 0; recv = link.received; t0 = t;
    }
    requestAnimationFrame(loop);
  };
  requestAnimationFrame(loop);
}

// the help overlay (?), and Esc for the banner
function help() {
  const box = $("#help");
  $("#help-open").onclick = () => box.showModal();
  $("#help-close").onclick = () => box.close();
  document.addEventListener("keydown", (e) => {
    if (e.ctrlKey || e.metaKey || e.altKey || e.target.matches(TYPED)) return;
    if (e.key === "?" && !document.querySelector("dialog[open]")) { e.preventDefault(); box.showModal(); }
    else if (e.key === "Escape" && !document.querySelector("dialog[open]")) clearError();
  });
}

function tabs() {
  for (const b of document.querySelectorAll("#tabs button")) {
    b.onclick = () => {
      if (b.dataset.tab === "scope" || b.dataset.tab === "modes") panels.scopes.wake();
      for (const o of document.querySelectorAll("#tabs button")) o.classList.toggle("on", o === b);
      for (const t of document.querySelectorAll(".tab")) t.hidden = t.id !== `tab-${b.dataset.tab}`;
    };
  }
}

// Ask the server for no more cell frames than the page draws: frames it would drop cost the
// server and the page work beside the sound (a software-rendered page on a small machine).
// A page that keeps up is offered more again, up to the server's rate; a hidden page gets none.
function pace(drawn) {
  const top = studio.desc.fps;
  let want = document.hidden ? 0 : pace.offered;
  if (!document.hidden && studio.received > 0) {
    if (drawn < 0.8 * studio.received) want = Math.max(10, Math.round(1.25 * drawn));
    else if (drawn >= 0.9 * studio.received) want = Math.min(top, Math.round(1.5 * want) || top);
  }
  if (want === pace.asked) return;
  pace.asked = want;
  pace.offered = want || pace.offered;
  link.send({ cmd: "frames", fps: want }).catch(() => {});
}

async function main() {
  tabs();
  $("#error-close").onclick = () => clearError();
  help();
  link.on("cells", (f) => { if (!panels.modes.showing(f.lattice)) view.take(f.lattice, f.values); });
  const ctx = { send, view, link, studio, panels };
  const recovery = new Recovery(ctx);      // not a panel: it has nothing to update from the instrument
  studio.recovery = recovery;
  link.on("event", (m) => {
    if (m.type === "changed") apply(m);
    else if (m.type === "problem") { showError([m.message, STOPPED]); problemShown = true; }
    else if (m.type === "recovery") recovery.event(m);
    else if (m.type === "status") (studio.status = m), $("#status").textContent = `t ${m.t.toFixed(1)} s · xruns ${m.xruns} · load ${(100 * m.load).toFixed(0)} %`;
  });
  // a lost connection: the page keeps what it has (and downloads the text); the same studio back,
  // the page takes its hello as the instrument now and asks for its cell frames again
  link.on("close", () => recovery.offline());
  link.on("retry", (attempts) => recovery.retrying(attempts));
  link.on("hello", (h) => { recovery.online(); apply(h); pace.asked = undefined; pace(studio.fps); });
  let hello;
  try { hello = await link.open(); } catch (e) { showError([e.message]); return; }
  panels.tools = new Tools(ctx);
  panels.params = new Params(ctx);
  panels.wiring = new Wiring(ctx);
  panels.scopes = new Scopes(ctx);
  panels.modes = new Modes(ctx);
  panels.history = new History(ctx);
  panels.mapping = new Mapping(ctx);
  panels.player = new Player(ctx);
  studio.audio = panels.player.stats;
  studio.tools = panels.tools;
  studio.params = panels.params;
  apply(hello);
  measure();
  // a hidden page asks for no cell frames (the server then sends none), and for them again when seen
  document.addEventListener("visibilitychange", () => pace(studio.fps));
  setInterval(() => pace(studio.fps), 2000);
  pace.offered = hello.fps;
  document.body.dataset.ready = "1";
}

main();
