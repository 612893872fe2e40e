// Small DOM helpers shared by the panels.
export const $ = (sel, root = document) => root.querySelector(sel);

export function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
    else if (k === "text") e.textContent = v;
    else if (v !== undefined && v !== null && v !== false) e.setAttribute(k, v === true ? "" : v);
  }
  for (const c of children) if (c != null) e.append(c);
  return e;
}

// the loader's FILE:LINE: message lines, shown until the next accepted command or dismissed
// (its × button, or Esc)
export function showError(lines) {
  $("#error-text").textContent = lines.filter(Boolean).join("\n");
  $("#error").hidden = false;
}

export function clearError() {
  $("#error-text").textContent = "";
  $("#error").hidden = true;
}

// a number as a person reads it: 4 significant digits, engineering range
export function fmt(v) {
  if (v === null || v === undefined || Number.isNaN(v)) return "—";
  if (v === 0) return "0";
  const a = Math.abs(v);
  return a >= 1e-3 && a < 1e5 ? String(Number(v.toPrecision(4))) : v.toExponential(3);
}
