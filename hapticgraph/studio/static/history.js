// Undo, redo, restart, the text pane, and save with a diff preview (what will change in the file).
import { $ } from "./dom.js";
import { TYPED } from "./tools.js";

export class History {
  constructor(ctx) {
    this.ctx = ctx;
    $("#undo").onclick = () => ctx.send({ cmd: "undo" });
    $("#redo").onclick = () => ctx.send({ cmd: "redo" });
    $("#restart").onclick = () => ctx.send({ cmd: "restart" });
    $("#save").onclick = () => this.preview();
    $("#save-confirm").onclick = () => this.save();
    $("#save-cancel").onclick = () => $("#save-dialog").close();
    $("#text-apply").onclick = () => ctx.send({ cmd: "text", text: $("#text").value });
    $("#text-reload").onclick = () => { $("#text").value = this.text; };
    document.addEventListener("keydown", (e) => {
      if (e.key.toLowerCase() === "r" && !(e.ctrlKey || e.metaKey || e.altKey) && !e.target.matches(TYPED)
          && !document.querySelector("dialog[open]")) { ctx.send({ cmd: "restart" }); return; }
      // a field where text is typed keeps its own undo; a slider, a checkbox or a menu does not
      if (!(e.ctrlKey || e.metaKey) || (e.target.matches(TYPED) && !e.target.matches("select"))) return;
      const k = e.key.toLowerCase();
      if (k === "z" && !e.shiftKey) { e.preventDefault(); ctx.send({ cmd: "undo" }); }
      else if ((k === "z" && e.shiftKey) || k === "y") { e.preventDefault(); ctx.send({ cmd: "redo" }); }
      else if (k === "s") { e.preventDefault(); this.preview(); }
    });
  }

  update(desc) {
    $("#undo").disabled = !desc.undo;
    $("#redo").disabled = !desc.redo;
    $("#undo").textContent = `Undo${desc.undo ? ` (${desc.undo})` : ""}`;
    $("#redo").textContent = `Redo${desc.redo ? ` (${desc.redo})` : ""}`;
    $("#save").textContent = desc.dirty ? "Save… *" : "Save…";
    this.path = desc.patch.path;
    // the text pane follows the patch unless the user is typing in it
    if (document.activeElement !== $("#text") || $("#text").value === this.text) $("#text").value = desc.text;
    this.text = desc.text;
  }

  async preview() {
    const r = await this.ctx.send({ cmd: "diff" });
    if (!r.ok) return r;
    $("#save-path").textContent = this.path;
    $("#save-diff").textContent = r.result.diff || "(no changes: the file already says this)";
    $("#save-diff").innerHTML = $("#save-diff").innerHTML.split("\n").map((l) =>
      l.startsWith("+") && !l.startsWith("+++") ? `<ins>${l}</ins>` : l.startsWith("-") && !l.startsWith("---") ? `<del>${l}</del>` : l).join("\n");
    $("#save-dialog").showModal();
    return r;
  }

  async save() {
    const as = $("#save-as").value.trim();
    const r = await this.ctx.send(as ? { cmd: "save", path: as } : { cmd: "save" });
    if (r.ok) $("#save-as").value = "";
    $("#save-dialog").close();
    return r;
  }
}
