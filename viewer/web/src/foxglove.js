// A minimal client of the Foxglove WebSocket protocol (foxglove.websocket.v1, JSON encoding):
// subscribes to every advertised channel and hands each decoded message to onMessage(topic, msg).
// Reconnects after the server goes away (a restarted viewer or stack).
export class FoxgloveClient {
  constructor(url) {
    this.url = url;
    this.channels = new Map();  // channel id -> topic
    this.subs = new Map();      // subscription id -> topic
    this.nextSub = 1;
    this.onMessage = () => {};
    this.onStatus = () => {};
    this.decoder = new TextDecoder();
  }
  connect() {
    const ws = new WebSocket(this.url, ['foxglove.websocket.v1']);
    ws.binaryType = 'arraybuffer';
    this.ws = ws;
    ws.onmessage = (ev) => this.handle(ev.data);
    ws.onclose = () => {
      this.onStatus('viewer connection closed; reconnecting…');
      this.channels.clear();
      this.subs.clear();
      setTimeout(() => this.connect(), 1000);
    };
  }
  handle(data) {
    if (typeof data === 'string') {
      const op = JSON.parse(data);
      if (op.op === 'advertise') {
        const subscriptions = [];
        for (const c of op.channels) {
          if (c.encoding !== 'json') continue;
          this.channels.set(c.id, c.topic);
          const id = this.nextSub++;
          this.subs.set(id, c.topic);
          subscriptions.push({ id, channelId: c.id });
        }
        this.ws.send(JSON.stringify({ op: 'subscribe', subscriptions }));
      } else if (op.op === 'unadvertise') {
        for (const id of op.channelIds) this.channels.delete(id);
      } else if (op.op === 'status' && op.level > 0) {
        console.warn(`viewer: ${op.message}`);
      }
      return;
    }
    const view = new DataView(data);
    if (view.byteLength < 13 || view.getUint8(0) !== 0x01) return;
    const topic = this.subs.get(view.getUint32(1, true));
    if (!topic) return;
    this.onMessage(topic, JSON.parse(this.decoder.decode(new Uint8Array(data, 13))));
  }
}
