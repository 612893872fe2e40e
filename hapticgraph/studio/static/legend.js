// What the stage's colours and markers mean, in its corner (click to fold it away): a lattice's
// or a waveguide's.
import { markerCanvas } from "./part.js";

export function legend(kind = "lattice") {
  const box = document.createElement("div");
  box.className = "legend";
  box.title = "What the colours and markers mean (click to fold)";
  const row = (swatch, text) => {
    const r = document.createElement("div");
    r.append(swatch, Object.assign(document.createElement("span"), { textContent: text }));
    return r;
  };
  const swatch = (cls) => Object.assign(document.createElement("i"), { className: cls });
  const picture = (kind) => Object.assign(document.createElement("img"), { src: markerCanvas(kind).toDataURL(), className: "marker" });
  if (kind === "waveguide") {
    box.append(
      row(swatch("sw-delay"), "delay line: its length in samples"),
      row(swatch("sw-loop"), "block on the string's loop"),
      row(swatch("sw-block"), "other block (wired as the lines show)"),
      row(swatch("sw-haptic"), "haptic device"),
      row(swatch("sw-mic"), "microphone"));
    box.addEventListener("click", () => box.classList.toggle("folded"));
    return box;
  }
  box.append(
    row(swatch("sw-displacement"), "down · rest · up"),
    row(swatch("sw-excitation"), "excitation"),
    row(swatch("sw-mic"), "microphone"),
    row(swatch("sw-join"), "join (a spring)"),
    row(picture("locked"), "locked cell"),
    row(swatch("sw-cut"), "cut cells (a hole)"),
    row(picture("mass"), "mass edited: larger is heavier"),
    row(swatch("sw-selection"), "selected"));
  box.addEventListener("click", () => box.classList.toggle("folded"));
  return box;
}
