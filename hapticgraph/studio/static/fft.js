// A radix-2 FFT (in place, iterative) and the magnitude spectrum of a Hann-windowed block.
const cache = new Map();

function tables(n) {
  if (cache.has(n)) return cache.get(n);
  const rev = new Uint32Array(n), cos = new Float64Array(n / 2), sin = new Float64Array(n / 2), hann = new Float64Array(n);
  const bits = Math.log2(n);
  for (let i = 0; i < n; i++) {
    let r = 0;
    for (let b = 0; b < bits; b++) r |= ((i >> b) & 1) << (bits - 1 - b);
    rev[i] = r;
    hann[i] = 0.5 - 0.5 * Math.cos((2 * Math.PI * i) / n);
  }
  for (let i = 0; i < n / 2; i++) { cos[i] = Math.cos((2 * Math.PI * i) / n); sin[i] = -Math.sin((2 * Math.PI * i) / n); }
  const t = { rev, cos, sin, hann };
  cache.set(n, t);
  return t;
}

export function fft(re, im) {
  const n = re.length, { rev, cos, sin } = tables(n);
  for (let i = 0; i < n; i++) {
    const j = rev[i];
    if (j > i) { [re[i], re[j]] = [re[j], re[i]]; [im[i], im[j]] = [im[j], im[i]]; }
  }
  for (let size = 2; size <= n; size *= 2) {
    const half = size / 2, step = n / size;
    for (let s = 0; s < n; s += size) {
      for (let k = 0; k < half; k++) {
        const c = cos[k * step], d = sin[k * step], a = s + k, b = a + half;
        const tr = re[b] * c - im[b] * d, ti = re[b] * d + im[b] * c;
        re[b] = re[a] - tr; im[b] = im[a] - ti; re[a] += tr; im[a] += ti;
      }
    }
  }
}

// |X[k]| in dB (k = 0 .. n/2) of the last n samples of x ending at `end` (n a power of two)
export function spectrumDb(x, end, n) {
  const { hann } = tables(n), re = new Float64Array(n), im = new Float64Array(n);
  for (let i = 0; i < n; i++) { const j = end - n + i; re[i] = j >= 0 ? x[j] * hann[i] : 0; }
  fft(re, im);
  const out = new Float32Array(n / 2 + 1);
  for (let k = 0; k <= n / 2; k++) out[k] = 10 * Math.log10(re[k] * re[k] + im[k] * im[k] + 1e-30);
  return out;
}
