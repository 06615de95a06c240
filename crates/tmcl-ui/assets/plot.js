// OpenTMCL workbench: scrolling time plots on a canvas, with CSV and SVG export. No library: each
// series keeps its own (time, value) samples, since the module's values are read one at a time.
"use strict";

(function () {
  const MAX_POINTS = 60000; // per series: 10 minutes at 100 samples a second

  class Series {
    constructor(key, label, color, right) {
      this.key = key; this.label = label; this.color = color; this.right = !!right; this.visible = true;
      this.t = []; this.v = [];
    }
    push(t, v) {
      // Samples come in time order from one link; a late one is dropped rather than drawn backwards.
      const n = this.t.length;
      if (n && t < this.t[n - 1]) return;
      this.t.push(t); this.v.push(v);
      if (this.t.length > MAX_POINTS) { this.t.splice(0, this.t.length - MAX_POINTS); this.v.splice(0, this.v.length - MAX_POINTS); }
    }
    // Index of the first sample at or after time t.
    from(t) {
      let lo = 0, hi = this.t.length;
      while (lo < hi) { const mid = (lo + hi) >> 1; if (this.t[mid] < t) lo = mid + 1; else hi = mid; }
      return lo;
    }
  }

  function niceStep(span, count) {
    const raw = span / Math.max(1, count);
    const mag = Math.pow(10, Math.floor(Math.log10(raw)));
    const f = raw / mag;
    return (f < 1.5 ? 1 : f < 3 ? 2 : f < 7 ? 5 : 10) * mag;
  }

  function fmt(v) {
    const a = Math.abs(v);
    if (a >= 1e9) return (v / 1e9).toFixed(a >= 1e10 ? 0 : 1) + "G";
    if (a >= 1e6) return (v / 1e6).toFixed(a >= 1e7 ? 0 : 1) + "M";
    if (a >= 1e4) return (v / 1e3).toFixed(a >= 1e5 ? 0 : 1) + "k";
    return String(Math.round(v * 100) / 100);
  }

  class Plot {
    constructor(canvas, series, options) {
      this.canvas = canvas;
      this.series = series.map((s) => new Series(s.key, s.label, s.color, s.right));
      this.window = (options && options.window) || 30000;
      this.paused = false; this.pausedAt = 0; this.dirty = true;
      this.frames = 0;
      const draw = () => { if (this.dirty && !this.paused) this.draw(); requestAnimationFrame(draw); };
      requestAnimationFrame(draw);
      new ResizeObserver(() => { this.dirty = true; if (this.paused) this.draw(); }).observe(canvas);
    }
    get(key) { return this.series.find((s) => s.key === key); }
    push(key, t, v) { const s = this.get(key); if (s) { s.push(t, v); this.dirty = true; } }
    setPaused(p) { this.paused = p; this.pausedAt = Date.now(); this.dirty = true; if (!p) this.draw(); }
    setWindow(ms) { this.window = ms; this.dirty = true; if (this.paused) this.draw(); }
    clear() { for (const s of this.series) { s.t = []; s.v = []; } this.dirty = true; }

    // The visible time range, and the value range of the left axis (and of the right one, for the series
    // that use it).
    view() {
      const end = this.paused ? this.pausedAt : Date.now();
      const start = end - this.window;
      const range = (right) => {
        let min = Infinity, max = -Infinity;
        for (const s of this.series) {
          if (!s.visible || s.right !== right) continue;
          // The sample before the window too, so a line enters from the left edge.
          for (let i = Math.max(0, s.from(start) - 1); i < s.t.length; i++) {
            if (s.t[i] > end) break;
            if (s.v[i] < min) min = s.v[i];
            if (s.v[i] > max) max = s.v[i];
          }
        }
        if (min === Infinity) { min = 0; max = 1; }
        if (min === max) { const pad = Math.max(1, Math.abs(min) * 0.1); min -= pad; max += pad; }
        const pad = (max - min) * 0.06;
        return { min: min - pad, max: max + pad };
      };
      const left = range(false), right = range(true);
      return { start, end, min: left.min, max: left.max, right: this.series.some((s) => s.right) ? right : null };
    }

    // Layout in CSS pixels: plot area inside the axes.
    layout(w, h) { return { x0: 58, y0: 8, x1: w - (this.series.some((s) => s.right) ? 46 : 10), y1: h - 22 }; }

    draw() {
      const c = this.canvas, dpr = window.devicePixelRatio || 1;
      const w = c.clientWidth, h = c.clientHeight;
      if (!w || !h) return;
      if (c.width !== Math.round(w * dpr) || c.height !== Math.round(h * dpr)) { c.width = Math.round(w * dpr); c.height = Math.round(h * dpr); }
      const g = c.getContext("2d");
      g.setTransform(dpr, 0, 0, dpr, 0, 0);
      g.clearRect(0, 0, w, h);
      const v = this.view(), L = this.layout(w, h);
      const X = (t) => L.x0 + (t - v.start) / (v.end - v.start) * (L.x1 - L.x0);
      const Y = (y) => L.y1 - (y - v.min) / (v.max - v.min) * (L.y1 - L.y0);
      g.font = "11px system-ui, sans-serif"; g.fillStyle = "#5b6475"; g.strokeStyle = "#e6e9ee"; g.lineWidth = 1;
      // Value grid.
      const ys = niceStep(v.max - v.min, Math.max(2, Math.floor((L.y1 - L.y0) / 32)));
      g.textAlign = "right"; g.textBaseline = "middle";
      for (let y = Math.ceil(v.min / ys) * ys; y <= v.max; y += ys) {
        const py = Math.round(Y(y)) + 0.5;
        g.beginPath(); g.moveTo(L.x0, py); g.lineTo(L.x1, py); g.stroke();
        g.fillText(fmt(y), L.x0 - 6, py);
      }
      // Time grid: seconds before now.
      const span = (v.end - v.start) / 1000;
      const ts = niceStep(span, Math.max(2, Math.floor((L.x1 - L.x0) / 90)));
      g.textAlign = "center"; g.textBaseline = "top";
      for (let s = 0; s <= span + 1e-9; s += ts) {
        const px = Math.round(X(v.end - s * 1000)) + 0.5;
        g.beginPath(); g.moveTo(px, L.y0); g.lineTo(px, L.y1); g.stroke();
        g.fillText(s === 0 ? (this.paused ? "paused" : "now") : "−" + fmt(s) + " s", px, L.y1 + 5);
      }
      if (v.right) {
        const R = (y) => L.y1 - (y - v.right.min) / (v.right.max - v.right.min) * (L.y1 - L.y0);
        const rs = niceStep(v.right.max - v.right.min, Math.max(2, Math.floor((L.y1 - L.y0) / 32)));
        g.textAlign = "left"; g.textBaseline = "middle"; g.fillStyle = (this.series.find((s) => s.right) || {}).color || "#5b6475";
        for (let y = Math.ceil(v.right.min / rs) * rs; y <= v.right.max; y += rs) g.fillText(fmt(y), L.x1 + 6, Math.round(R(y)) + 0.5);
        g.fillStyle = "#5b6475";
      }
      g.strokeStyle = "#c3c9d3"; g.strokeRect(L.x0 + 0.5, L.y0 + 0.5, L.x1 - L.x0, L.y1 - L.y0);
      // Lines: steps are drawn as they are (a value holds until the next sample).
      g.save(); g.beginPath(); g.rect(L.x0, L.y0, L.x1 - L.x0, L.y1 - L.y0); g.clip();
      // Drawn last to first, so the first series (the actual value) lies on top.
      for (const s of [...this.series].reverse()) {
        if (!s.visible || !s.t.length) continue;
        const Ys = s.right && v.right ? (y) => L.y1 - (y - v.right.min) / (v.right.max - v.right.min) * (L.y1 - L.y0) : Y;
        g.strokeStyle = s.color; g.lineWidth = s === this.series[0] ? 2 : 1.5; g.beginPath();
        let first = true;
        for (let i = Math.max(0, s.from(v.start) - 1); i < s.t.length; i++) {
          if (s.t[i] > v.end) break;
          const px = X(s.t[i]), py = Ys(s.v[i]);
          if (first) { g.moveTo(px, py); first = false; } else g.lineTo(px, py);
        }
        g.stroke();
      }
      g.restore();
      this.dirty = false; this.frames++;
    }

    // The visible part as SVG elements, placed at (ox, oy) in a w × h box.
    svg(ox, oy, w, h, title) {
      const v = this.view(), L = this.layout(w, h);
      const X = (t) => (ox + L.x0 + (t - v.start) / (v.end - v.start) * (L.x1 - L.x0)).toFixed(1);
      const Y = (y) => (oy + L.y1 - (y - v.min) / (v.max - v.min) * (L.y1 - L.y0)).toFixed(1);
      const R = (y) => (oy + L.y1 - (y - v.right.min) / (v.right.max - v.right.min) * (L.y1 - L.y0)).toFixed(1);
      const esc = (s) => String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;");
      let out = `<text x="${ox + L.x0}" y="${oy - 4}" font-weight="600">${esc(title)}</text>\n`;
      const ys = niceStep(v.max - v.min, Math.max(2, Math.floor((L.y1 - L.y0) / 32)));
      for (let y = Math.ceil(v.min / ys) * ys; y <= v.max; y += ys) {
        out += `<line x1="${ox + L.x0}" x2="${ox + L.x1}" y1="${Y(y)}" y2="${Y(y)}" stroke="#e6e9ee"/>` +
          `<text x="${ox + L.x0 - 6}" y="${Y(y)}" text-anchor="end" dominant-baseline="middle" fill="#5b6475">${fmt(y)}</text>\n`;
      }
      const span = (v.end - v.start) / 1000, ts = niceStep(span, 6);
      for (let s = 0; s <= span + 1e-9; s += ts) {
        const x = X(v.end - s * 1000);
        out += `<line x1="${x}" x2="${x}" y1="${oy + L.y0}" y2="${oy + L.y1}" stroke="#e6e9ee"/>` +
          `<text x="${x}" y="${oy + L.y1 + 15}" text-anchor="middle" fill="#5b6475">${s === 0 ? "0" : "−" + fmt(s) + " s"}</text>\n`;
      }
      if (v.right) {
        const rs = niceStep(v.right.max - v.right.min, Math.max(2, Math.floor((L.y1 - L.y0) / 32)));
        for (let y = Math.ceil(v.right.min / rs) * rs; y <= v.right.max; y += rs) {
          out += `<text x="${ox + L.x1 + 6}" y="${R(y)}" dominant-baseline="middle" fill="#5b6475">${fmt(y)}</text>\n`;
        }
      }
      out += `<rect x="${ox + L.x0}" y="${oy + L.y0}" width="${L.x1 - L.x0}" height="${L.y1 - L.y0}" fill="none" stroke="#c3c9d3"/>\n`;
      let lx = ox + L.x0 + 120;
      for (const s of this.series) {
        if (!s.visible) continue;
        const pts = [];
        for (let i = Math.max(0, s.from(v.start) - 1); i < s.t.length; i++) {
          if (s.t[i] > v.end) break;
          pts.push(`${X(Math.max(s.t[i], v.start))},${s.right && v.right ? R(s.v[i]) : Y(s.v[i])}`);
        }
        if (pts.length) out += `<polyline fill="none" stroke="${s.color}" stroke-width="1.6" points="${pts.join(" ")}"/>\n`;
        out += `<line x1="${lx}" x2="${lx + 14}" y1="${oy - 8}" y2="${oy - 8}" stroke="${s.color}" stroke-width="3"/>` +
          `<text x="${lx + 18}" y="${oy - 4}" fill="#5b6475">${esc(s.label)}</text>\n`;
        lx += 30 + s.label.length * 6.5;
      }
      return out;
    }
  }

  // Every sample of `plots` as CSV: one row per time stamp, each series holding its last value.
  function toCsv(plots) {
    const all = plots.flatMap((p) => p.series);
    const times = new Set();
    for (const s of all) for (const t of s.t) times.add(t);
    const sorted = [...times].sort((a, b) => a - b);
    const idx = all.map(() => 0), last = all.map(() => "");
    const t0 = sorted.length ? sorted[0] : 0;
    const rows = ["time_s,unix_ms," + all.map((s) => s.label.replace(/,/g, " ")).join(",")];
    for (const t of sorted) {
      all.forEach((s, n) => { while (idx[n] < s.t.length && s.t[idx[n]] <= t) { last[n] = s.v[idx[n]]; idx[n]++; } });
      rows.push(((t - t0) / 1000).toFixed(3) + "," + t.toFixed(1) + "," + last.join(","));
    }
    return rows.join("\n") + "\n";
  }

  function toSvg(plots, titles) {
    const w = 900, h = 220, gap = 40;
    let body = "";
    plots.forEach((p, n) => { body += p.svg(0, 30 + n * (h + gap), w, h, titles[n]); });
    const height = 30 + plots.length * (h + gap);
    return `<?xml version="1.0" encoding="UTF-8"?>\n<svg xmlns="http://www.w3.org/2000/svg" width="${w}" height="${height}" ` +
      `viewBox="0 0 ${w} ${height}" font-family="sans-serif" font-size="11">\n<rect width="100%" height="100%" fill="#fff"/>\n${body}</svg>\n`;
  }

  window.TmclPlot = { Plot, toCsv, toSvg };
})();
