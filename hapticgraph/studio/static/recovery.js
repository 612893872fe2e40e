// The designer's unsaved edits (docs/studio.md, "Unsaved edits"): while the studio is gone the
// page says so and still downloads the edited text it last had; when a studio opens a patch with
// edits an earlier one did not save, it offers them (the `recovery` event) and the page asks.
import { $ } from "./dom.js";

const GIVE_UP_HINT = 4;    // failed tries before the page says the studio may have been stopped

// the text as a file the browser saves (it needs no connection: the text is the page's own)
export function download(text, name) {
  const url = URL.createObjectURL(new Blob([text], { type: "application/yaml" }));
  const a = Object.assign(document.createElement("a"), { href: url, download: name });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 60000);
}

const baseName = (path) => path.split(/[\\/]/).pop();
const plural = (n) => `${n} unsaved edit${n === 1 ? "" : "s"}`;

export class Recovery {
  constructor(ctx) {
    this.ctx = ctx;
    this.offer = null;
    $("#offline-download").onclick = () => this.downloadNow();
    $("#recovery-accept").onclick = () => this.accept();
    $("#recovery-discard").onclick = () => this.discard();
    $("#recovery-download").onclick = () => {
      if (this.offer) download(this.offer.text, baseName(this.ctx.studio.desc.patch.path));
    };
    $("#recovery-dialog").addEventListener("cancel", (e) => e.preventDefault());   // answered, not escaped
  }

  downloadNow() {
    const desc = this.ctx.studio.desc;
    if (desc) download(desc.text, baseName(desc.patch.path));
  }

  // the connection is lost: what the page still has, and where the studio kept the edits
  offline() {
    const desc = this.ctx.studio.desc;
    const kept = desc && desc.kept;
    $("#offline-what").textContent = "The connection to the studio closed; reconnecting…";
    $("#offline-kept").textContent = kept
      ? `${plural(kept.edits)} kept in ${kept.file}: the studio offers them when it opens ${baseName(desc.patch.path)} again.`
      : desc && desc.dirty ? "The unsaved edits could not be kept beside the patch: download them." : "";
    $("#offline").hidden = false;
  }

  retrying(attempts) {
    if (attempts + 1 >= GIVE_UP_HINT) {
      $("#offline-what").textContent = "The studio is not answering (still trying). If it was stopped, start it " +
        "again and open the URL it prints.";
    }
  }

  online() { $("#offline").hidden = true; }

  // a `recovery` event: an offer to show, or one answered (here or on another page)
  event(msg) {
    const dialog = $("#recovery-dialog");
    if (!msg.offered) {
      this.offer = null;
      if (dialog.open) dialog.close();
      return;
    }
    this.offer = msg;
    $("#recovery-title").textContent = `Recover ${plural(msg.edits)} of ${baseName(this.ctx.studio.desc.patch.path)}?`;
    $("#recovery-what").textContent = `A studio that stopped before saving kept them in ${msg.file} ` +
      `(${new Date(msg.written * 1000).toLocaleString()}).` +
      (msg.patch_changed ? " The patch file has changed since: recovering replaces its text with this one." : "");
    $("#recovery-diff").textContent = msg.diff;
    $("#recovery-error").textContent = "";
    if (!dialog.open) dialog.showModal();
  }

  async accept() {
    const r = await this.ctx.link.send({ cmd: "recover" });
    if (!r.ok) $("#recovery-error").textContent = (r.errors || [r.error]).join("\n");
    return r;
  }

  async discard() {
    if (!this.offer || !window.confirm(`Discard the ${plural(this.offer.edits)}? They cannot be recovered afterwards.`)) return null;
    const r = await this.ctx.link.send({ cmd: "discard_recovery" });
    if (!r.ok) $("#recovery-error").textContent = (r.errors || [r.error]).join("\n");
    return r;
  }
}
