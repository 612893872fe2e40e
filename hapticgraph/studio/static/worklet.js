// AudioWorklet: plays the studio's audio frames from a ring buffer filled over the port. An
// underrun plays silence and is counted; too much buffered (the page fell behind) drops the
// oldest samples so the sound stays close to the instrument.
const SECONDS = 1.0;

class StudioPlayer extends AudioWorkletProcessor {
  constructor(options) {
    super();
    this.channels = options.processorOptions.channels;
    this.target = Math.round(options.processorOptions.latency * sampleRate);
    this.ring = new Float32Array(Math.round(SECONDS * sampleRate) * this.channels);
    this.frames = this.ring.length / this.channels;
    this.read = 0; this.write = 0; this.filled = 0; this.underruns = 0; this.started = false;
    this.port.onmessage = (e) => this.push(e.data);
  }

  push(data) {
    const n = data.length / this.channels;
    for (let i = 0; i < n; i++) {
      const o = this.write * this.channels;
      for (let c = 0; c < this.channels; c++) this.ring[o + c] = data[i * this.channels + c];
      this.write = (this.write + 1) % this.frames;
    }
    this.filled += n;
    if (this.filled > this.frames - 128) {           // overflow: keep the newest
      const drop = this.filled - this.target;
      this.read = (this.read + drop) % this.frames; this.filled -= drop;
    }
  }

  process(inputs, outputs) {
    const out = outputs[0], n = out[0].length;
    if (!this.started && this.filled < this.target) return true;
    this.started = true;
    for (let i = 0; i < n; i++) {
      if (this.filled === 0) { this.underruns++; this.started = false; for (const ch of out) ch.fill(0, i); break; }
      const o = this.read * this.channels;
      for (let c = 0; c < out.length; c++) out[c][i] = this.ring[o + Math.min(c, this.channels - 1)];
      this.read = (this.read + 1) % this.frames; this.filled--;
    }
    if (currentFrame % sampleRate < n) this.port.postMessage({ underruns: this.underruns, buffered: this.filled / sampleRate });
    return true;
  }
}

registerProcessor("studio-player", StudioPlayer);
