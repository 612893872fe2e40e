// What every plot of the views shares: the font of axis labels, a number as a tick label (with a
// real minus sign: a hyphen is thin and easily lost at an edge) and round tick values.
import { fmt } from "./dom.js";

export const AXIS_FONT = "12px system-ui, sans-serif";

export function label(v) {
  return fmt(v).replace(/^-/, "−").replace("e-", "e−");
}

// round values (1, 2 or 5 × 10^k apart) between lo and hi, about `count` of them
export function ticks(lo, hi, count = 5) {
  if (!(hi > lo)) return [lo];
  const raw = (hi - lo) / count, mag = 10 ** Math.floor(Math.log10(raw));
  const step = mag * ([1, 2, 5, 10].find((m) => m * mag >= raw) || 10);
  const out = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + 1e-9 * step; v += step) out.push(Number(v.toPrecision(12)));
  return out;
}
