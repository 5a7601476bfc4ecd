// The time plot panel: the ankle and hip torques of the virtual stance foot (19) on top, the CAM
// (reference, commanded, measured) below, one axis at a time. Whole run with a cursor (log), or the
// last 10 s (live).
const SERIES = [
  { key: 'tau_ankle_V', label: 'τ ankle', color: '#d62728', panel: 0 },
  { key: 'tau_hip_V', label: 'τ hip', color: '#1f77b4', panel: 0 },
  { key: 'l_ref_W', label: 'l ref', color: '#e0662b', panel: 1 },
  { key: 'l_cmd_W', label: 'l cmd', color: '#2b7be0', panel: 1 },
  { key: 'l_WCom', label: 'l meas', color: '#2bb04a', panel: 1 },
];
const UNITS = ['N m', 'N m s'];

export class TimePlot {
  constructor(canvas) {
    this.canvas = canvas;
    this.ctx = canvas.getContext('2d');
    this.axis = 1;
    this.cursor = null;
    this.window = null;  // live: seconds shown
    this.data = { t: [] };
    for (const s of SERIES) this.data[s.key] = [];
    this.pushes = [];
  }
  setSeries(series, pushes) {
    this.data = series;
    this.pushes = pushes ?? [];
    this.window = null;
    this.draw();
  }
  push(t, ankle, hip, ref, cmd, meas) {
    this.window = 10;
    const d = this.data;
    d.t.push(t);
    d.tau_ankle_V.push(ankle ?? null); d.tau_hip_V.push(hip ?? null);
    d.l_ref_W.push(ref ?? null); d.l_cmd_W.push(cmd ?? null); d.l_WCom.push(meas ?? null);
    while (d.t.length > 2 && d.t[d.t.length - 1] - d.t[0] > this.window) for (const k of Object.keys(d)) d[k].shift();
    this.cursor = t;
    if (!this._scheduled) { this._scheduled = true; requestAnimationFrame(() => { this._scheduled = false; this.draw(); }); }
  }
  /// Redraws: the series into a cached image when they changed, then the cursor over it.
  draw() {
    const { ctx, canvas } = this, W = canvas.width, H = canvas.height;
    const key = `${this.data.t.length}:${this.data.t[this.data.t.length - 1]}:${this.axis}:${W}x${H}`;
    if (key !== this._key || !this._cache) {
      this._cache ??= document.createElement('canvas');
      this._cache.width = W; this._cache.height = H;
      this._x = this.drawSeries(this._cache.getContext('2d'), W, H);
      this._key = key;
    }
    ctx.clearRect(0, 0, W, H);
    ctx.drawImage(this._cache, 0, 0);
    if (this._x && this.cursor !== null) {
      const x = this._x(this.cursor);
      ctx.strokeStyle = '#1d232a'; ctx.lineWidth = 1; ctx.beginPath();
      ctx.moveTo(x, 4); ctx.lineTo(x, H - 14); ctx.stroke();
    }
  }
  drawSeries(ctx, W, H) {
    const d = this.data;
    ctx.clearRect(0, 0, W, H);
    if (!d.t.length) return null;
    const t0 = d.t[0], t1 = Math.max(d.t[d.t.length - 1], t0 + 1e-3);
    const left = 44, right = 6, ph = (H - 30) / 2;
    const x = (t) => left + (t - t0) / (t1 - t0) * (W - left - right);
    ctx.font = '10px system-ui, sans-serif';
    for (let panel = 0; panel < 2; ++panel) {
      const top = 4 + panel * (ph + 10), series = SERIES.filter((s) => s.panel === panel);
      let lo = Infinity, hi = -Infinity;
      for (const s of series) for (const v of d[s.key]) { const y = v?.[this.axis]; if (y !== null && y !== undefined) { lo = Math.min(lo, y); hi = Math.max(hi, y); } }
      if (!Number.isFinite(lo)) { lo = -1; hi = 1; }
      if (hi - lo < 1e-6) { hi += 0.5; lo -= 0.5; }
      const pad = 0.08 * (hi - lo); lo -= pad; hi += pad;
      const y = (v) => top + (hi - v) / (hi - lo) * ph;
      ctx.fillStyle = 'rgba(214,39,40,0.10)';
      for (const p of this.pushes) ctx.fillRect(x(p.start), top, Math.max(1, x(p.end) - x(p.start)), ph);
      ctx.strokeStyle = '#c9cfd6'; ctx.lineWidth = 1;
      ctx.strokeRect(left, top, W - left - right, ph);
      if (lo < 0 && hi > 0) { ctx.beginPath(); ctx.moveTo(left, y(0)); ctx.lineTo(W - right, y(0)); ctx.stroke(); }
      ctx.fillStyle = '#4a525c';
      ctx.fillText(hi.toFixed(1), 2, top + 9); ctx.fillText(lo.toFixed(1), 2, top + ph); ctx.fillText(UNITS[panel], 2, top + ph / 2 + 3);
      let lx = left + 4;
      for (const s of series) {
        ctx.strokeStyle = s.color; ctx.lineWidth = 1.4; ctx.beginPath();
        let pen = false;
        for (let i = 0; i < d.t.length; ++i) {
          const v = d[s.key][i]?.[this.axis];
          if (v === null || v === undefined) { pen = false; continue; }
          if (pen) ctx.lineTo(x(d.t[i]), y(v)); else ctx.moveTo(x(d.t[i]), y(v));
          pen = true;
        }
        ctx.stroke();
        ctx.fillStyle = s.color; ctx.fillText(s.label, lx, top + 10); lx += ctx.measureText(s.label).width + 10;
      }
    }
    ctx.fillStyle = '#4a525c';
    ctx.fillText(`${(0).toFixed(1)} s`, left, H - 3);
    ctx.fillText(`${(t1 - t0).toFixed(1)} s`, W - right - 30, H - 3);
    return (t) => Math.min(Math.max(x(t), left), W - right);
  }
}
