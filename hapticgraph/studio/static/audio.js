// The studio heard in the page (--audio browser): audio frames from the WebSocket into an
// AudioWorklet's ring buffer, at the session's rate (the browser resamples to the card).
import { $ } from "./dom.js";

const LATENCY_S = 0.08;

export class Player {
  constructor(ctx) {
    this.ctx = ctx;
    this.node = null;
    this.stats = { underruns: 0, buffered: 0, blocks: 0 };
    $("#sound").onclick = () => (this.node ? this.stop() : this.start());
    ctx.link.on("audio", (f) => {
      this.stats.blocks++;
      if (this.node) this.node.port.postMessage(f.data.slice(0, f.frames * f.channels));
    });
  }

  update(desc) {
    this.audio = desc.audio;
    $("#sound").hidden = desc.audio.mode !== "browser";
  }

  async start() {
    const { rate, channels } = this.audio;
    this.context = new AudioContext({ sampleRate: rate, latencyHint: "interactive" });
    await this.context.audioWorklet.addModule("/static/worklet.js");
    this.node = new AudioWorkletNode(this.context, "studio-player", {
      numberOfInputs: 0, outputChannelCount: [Math.min(2, channels)], processorOptions: { channels, latency: LATENCY_S } });
    this.node.port.onmessage = (e) => Object.assign(this.stats, e.data);
    this.node.connect(this.context.destination);
    await this.context.resume();
    $("#sound").textContent = "Sound off";
  }

  stop() {
    this.node.disconnect();
    this.context.close();
    this.node = null;
    $("#sound").textContent = "Sound on";
  }
}
