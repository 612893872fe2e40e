// A scrolling spectrogram that fills its canvas: frequency (Hz, log or linear) up, the session's
// time (s) across, amplitude (dB) as colour with its scale beside. Columns are kept as spectra
// and painted again on one common scale (the loudest shown column at the top), so the colour
// bar always tells the truth and a decaying sound is seen to decay.
import { spectrumDb } from "./fft.js";
import { AXIS_FONT, label, ticks } from "./axis.js";

const HOP = 512, NFFT = 4096, RANGE_DB = 70, KEEP = 1600, LO_HZ = 20;
const AMPLITUDE_DB = 20 * Math.log10(4 / NFFT);   // a Hann-windowed sine of amplitude A peaks at A·NFFT/4
const M = { left: 50, right: 56, top: 16, bottom: 34 };

// dark blue - purple - orange - pale yellow
export function heat(v) {
  return [Math.round(255 * Math.min(1, 1.6 * v)), Math.round(255 * Math.max(0, 1.4 * v - 0.4)), Math.round(60 + 120 * Math.sin(Math.PI * Math.min(1, v * 1.2))), 255];
}

// heat() of 256 levels, looked up per pixel (the picture is painted again several times a second)
const LUT = Uint8ClampedArray.from({ length: 256 * 4 }, (_, i) => heat(Math.floor(i / 4) / 255)[i % 4]);

export class Spectrogram {
  constructor(canvas) {
    this.canvas = canvas;
    this.g = canvas.getContext("2d");
    this.image = document.createElement("canvas");
    this.axes = null;          // what was drawn last: plot area, tick labels (tests read them)
    this.reset(44100);
  }

  reset(rate) {
    this.rate = rate;
    this.columns = [];         // {end: the session's sample index after the column's block, db}
    this.next = null;
    this.changed = true;
  }

  // buf[0, len) is the signal up to the session's sample `end`; the columns due are computed
  // only while the spectrogram is seen (a gap then starts the picture again)
  take(buf, len, end, shown) {
    if (this.next === null || this.next > end || this.next <= end - len) this.next = Math.ceil((end - len + NFFT) / HOP) * HOP;
    for (; this.next <= end; this.next += HOP) {
      if (!shown) continue;
      const last = this.columns[this.columns.length - 1];
      if (last && last.end !== this.next - HOP) this.columns = [];
      this.columns.push({ end: this.next, db: spectrumDb(buf, len - (end - this.next), NFFT) });
      this.changed = true;
    }
    if (this.columns.length > KEEP) this.columns.splice(0, this.columns.length - KEEP);
  }

  // one pixel column a spectrum, as many as fit; fewer are stretched across the plot
  draw({ top, log }) {
    const c = this.canvas, w = c.clientWidth, h = c.clientHeight;
    const key = `${top} ${log} ${w} ${h}`;
    if (!this.changed && key === this.key) return;
    this.changed = false; this.key = key;
    if (w && h && (c.width !== w || c.height !== h)) { c.width = w; c.height = h; }
    const g = this.g, pw = c.width - M.left - M.right, ph = c.height - M.top - M.bottom;
    g.fillStyle = "#101317"; g.fillRect(0, 0, c.width, c.height);
    if (pw < 10 || ph < 10) return;
    const cols = this.columns.slice(-pw), n = cols.length, lo = log ? LO_HZ : 0;
    const fOf = (u) => (log ? lo * (top / lo) ** u : u * top);
    const yOf = (f) => M.top + ph * (1 - (log ? Math.log(f / lo) / Math.log(top / lo) : f / top));
    let peak = -Infinity;
    for (const col of cols) for (let k = 1; k < col.db.length; k++) if (col.db[k] > peak) peak = col.db[k];
    const dbTop = Math.ceil((peak + AMPLITUDE_DB) / 10) * 10, dbLow = dbTop - RANGE_DB;
    if (n) {
      const bins = Int32Array.from({ length: ph }, (_, y) => Math.min(NFFT / 2, Math.round(fOf(1 - y / Math.max(1, ph - 1)) * NFFT / this.rate)));
      const img = new ImageData(n, ph);
      for (let x = 0; x < n; x++) {
        const db = cols[x].db;
        for (let y = 0; y < ph; y++) {
          const level = Math.round(255 * Math.min(1, Math.max(0, (db[bins[y]] + AMPLITUDE_DB - dbLow) / RANGE_DB)));
          const o = 4 * (y * n + x), l = 4 * level;
          img.data[o] = LUT[l]; img.data[o + 1] = LUT[l + 1]; img.data[o + 2] = LUT[l + 2]; img.data[o + 3] = 255;
        }
      }
      this.image.width = n; this.image.height = ph;
      this.image.getContext("2d").putImageData(img, 0, 0);
      g.imageSmoothingEnabled = false;
      g.drawImage(this.image, 0, 0, n, ph, M.left, M.top, pw, ph);
    }
    // axes: frequency left, time below, the colour scale right
    g.font = AXIS_FONT; g.fillStyle = "#aaa"; g.strokeStyle = "#aaa";
    const freq = (log ? [20, 50, 100, 200, 500, 1000, 2000, 5000, 10000, 20000] : ticks(0, top, 5)).filter((f) => f >= lo && f <= top);
    g.textAlign = "right"; g.textBaseline = "middle";
    const axes = { plot: { x: M.left, y: M.top, w: pw, h: ph }, columns: n, freq: [], time: [], db: [], dbTop, dbLow };
    for (const f of freq) {
      const y = yOf(f), text = f >= 1000 ? `${f / 1000}k` : label(f);
      g.fillRect(M.left - 4, Math.round(y), 4, 1); g.fillText(text, M.left - 6, y);
      axes.freq.push(text);
    }
    g.textAlign = "left"; g.textBaseline = "alphabetic"; g.fillText("f [Hz]", 4, 11);
    if (n) {
      const t0 = cols[0].end / this.rate, t1 = cols[n - 1].end / this.rate, xOf = (t) => M.left + (n > 1 ? (t - t0) / (t1 - t0) : 1) * pw;
      g.textAlign = "center"; g.textBaseline = "top";
      for (const t of ticks(t0, t1, 5)) { const x = xOf(t); g.fillRect(Math.round(x), M.top + ph, 1, 4); g.fillText(label(t), x, M.top + ph + 6); axes.time.push(label(t)); }
      axes.t = [t0, t1];
    }
    g.textAlign = "center"; g.textBaseline = "bottom"; g.fillText("session time t [s]", M.left + pw / 2, c.height - 1);
    const bx = M.left + pw + 8;
    for (let y = 0; y < ph; y++) { const [r, gg, b] = heat(1 - y / (ph - 1)); g.fillStyle = `rgb(${r},${gg},${b})`; g.fillRect(bx, M.top + y, 12, 1); }
    g.fillStyle = "#aaa"; g.textAlign = "left"; g.textBaseline = "middle";
    for (let d = dbTop; n && d >= dbLow; d -= 10) { const y = M.top + ph * (dbTop - d) / RANGE_DB; g.fillText(label(d), bx + 16, y); axes.db.push(label(d)); }
    g.textBaseline = "alphabetic"; g.fillText("dB", bx, 11);
    this.axes = axes;
  }
}
