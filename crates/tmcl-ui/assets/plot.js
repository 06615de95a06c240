// OpenTMCL workbench: scrolling time plots on a canvas, with CSV and SVG export. No library: each
// series keeps its own (time, value) samples, since the module's values are read one at a time.
//
// Each series has a unit; series of one unit share a value axis, the first unit's on the left, the
// others on the right, one column each. A `null` sample is a gap: the line stops there and starts
// again at the next value (the link went away, the module did not answer). Samples older than
// STALE_MS at the right edge are marked: the plot never draws a value on to "now" that was not read.
"use strict";

(function () {
  const MAX_POINTS = 60000; // per series: 10 minutes at 100 samples a second
  const STALE_MS = 2000; // no new value for this long: the plot says so
  const AXIS_W = 52; // the width of each right-hand axis column

  class Series {
    constructor(s) {
      this.key = s.key; this.label = s.label; this.color = s.color; this.unit = s.unit || "";
      this.range = s.range || null; // the parameter's own range [min, max], to keep the axis inside it
      this.removable = !!s.removable; this.visible = true;
      this.t = []; this.v = [];
    }
    push(t, v) {
      // Samples come in time order from one link; a late one is dropped rather than drawn backwards.
      const n = this.t.length;
      if (n && t < this.t[n - 1]) return;
      if (v === null && (!n || this.v[n - 1] === null)) return; // one gap marker is enough
      this.t.push(t); this.v.push(v);
      if (this.t.length > MAX_POINTS) { this.t.splice(0, this.t.length - MAX_POINTS); this.v.splice(0, this.v.length - MAX_POINTS); }
    }
    // Index of the first sample at or after time t.
    from(t) {
      let lo = 0, hi = this.t.length;
      while (lo < hi) { const mid = (lo + hi) >> 1; if (this.t[mid] < t) lo = mid + 1; else hi = mid; }
      return lo;
    }
    // The time of the newest real value (not a gap), or null.
    newest() {
      for (let i = this.t.length - 1; i >= 0; i--) if (this.v[i] !== null) return this.t[i];
      return null;
    }
    title() { return this.unit ? `${this.label} [${this.unit}]` : this.label; }
  }

  function niceStep(span, count, integers) {
    const raw = span / Math.max(1, count);
    const mag = Math.pow(10, Math.floor(Math.log10(raw)));
    const f = raw / mag;
    const step = (f < 1.5 ? 1 : f < 3 ? 2 : f < 7 ? 5 : 10) * mag;
    return integers ? Math.max(1, step) : step;
  }

  function fmt(v) {
    const a = Math.abs(v);
    if (a >= 1e9) return (v / 1e9).toFixed(a >= 1e10 ? 0 : 1) + "G";
    if (a >= 1e6) return (v / 1e6).toFixed(a >= 1e7 ? 0 : 1) + "M";
    if (a >= 1e4) return (v / 1e3).toFixed(a >= 1e5 ? 0 : 1) + "k";
    return String(Math.round(v * 100) / 100);
  }

  // A value range around [min, max] for an axis: a constant gets a small range around it (so a flat
  // line looks flat, not like noise), a changing value 6 % above and below; the parameter's own range
  // bounds it where it says more than the data.
  function axisRange(min, max, bound) {
    if (min === Infinity) return { min: 0, max: 1, empty: true };
    if (min === max) {
      const pad = Math.max(1, Math.abs(min) * 0.005);
      min -= pad; max += pad;
    } else {
      const pad = (max - min) * 0.06;
      let lo = min - pad, hi = max + pad;
      if (bound) { if (min >= bound[0]) lo = Math.max(lo, bound[0]); if (max <= bound[1]) hi = Math.min(hi, bound[1]); }
      min = lo; max = hi;
    }
    return { min, max };
  }

  class Plot {
    constructor(canvas, series, options) {
      this.canvas = canvas;
      this.series = series.map((s) => new Series(s));
      this.window = (options && options.window) || 30000;
      this.paused = false; this.pausedAt = 0; this.dirty = true;
      this.frames = 0;
      const draw = () => { if (this.dirty && !this.paused) this.draw(); requestAnimationFrame(draw); };
      requestAnimationFrame(draw);
      // Stale marks grow with time even without new samples.
      setInterval(() => { if (!this.paused) this.dirty = true; }, 500);
      new ResizeObserver(() => { this.dirty = true; if (this.paused) this.draw(); }).observe(canvas);
    }
    get(key) { return this.series.find((s) => s.key === key); }
    add(s) { if (this.get(s.key)) return null; const n = new Series(s); this.series.push(n); this.dirty = true; return n; }
    remove(key) { this.series = this.series.filter((s) => s.key !== key); this.dirty = true; }
    push(key, t, v) { for (const s of this.series) if (s.key === key) { s.push(t, v); this.dirty = true; } }
    // A gap in every series at time t: nothing is drawn across it.
    gap(t) { for (const s of this.series) s.push(t, null); this.dirty = true; }
    setPaused(p) { this.paused = p; this.pausedAt = Date.now(); this.dirty = true; if (!p) this.draw(); }
    setWindow(ms) { this.window = ms; this.dirty = true; if (this.paused) this.draw(); }
    clear() { for (const s of this.series) { s.t = []; s.v = []; } this.dirty = true; }

    // The units of the visible series, in order: one value axis each.
    units() {
      const out = [];
      for (const s of this.series) if (s.visible && !out.includes(s.unit)) out.push(s.unit);
      if (!out.length && this.series.length) out.push(this.series[0].unit);
      return out;
    }

    // The visible time range, and the value range of each axis.
    view() {
      const end = this.paused ? this.pausedAt : Date.now();
      const start = end - this.window;
      const axes = this.units().map((unit) => {
        let min = Infinity, max = -Infinity, integers = true, bound = null;
        for (const s of this.series) {
          if (!s.visible || s.unit !== unit) continue;
          if (s.range) bound = bound ? [Math.min(bound[0], s.range[0]), Math.max(bound[1], s.range[1])] : s.range.slice();
          // The sample before the window too, so a line enters from the left edge.
          for (let i = Math.max(0, s.from(start) - 1); i < s.t.length; i++) {
            if (s.t[i] > end) break;
            const v = s.v[i];
            if (v === null) continue;
            if (v < min) min = v;
            if (v > max) max = v;
            if (!Number.isInteger(v)) integers = false;
          }
        }
        const r = axisRange(min, max, bound);
        const color = (this.series.find((s) => s.visible && s.unit === unit) || {}).color || "#5b6475";
        return { unit, min: r.min, max: r.max, empty: !!r.empty, integers, color };
      });
      return { start, end, axes };
    }

    // Layout in CSS pixels: the plot area inside the axes.
    layout(w, h) {
      const right = Math.max(0, this.units().length - 1);
      // One line above the plot for each unit label on the right beyond the first.
      return { x0: 58, y0: 16 + Math.max(0, right - 1) * 12, x1: w - (right ? right * AXIS_W : 10), y1: h - 22 };
    }

    // How old the newest value is at the right edge, if it is stale (ms), else 0.
    staleFor(end) {
      let newest = null;
      for (const s of this.series) { const t = s.newest(); if (t !== null && (newest === null || t > newest)) newest = t; }
      if (newest === null) return 0;
      const age = end - newest;
      return age > STALE_MS ? age : 0;
    }

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
      const Ys = v.axes.map((a) => (y) => L.y1 - (y - a.min) / (a.max - a.min) * (L.y1 - L.y0));
      g.font = "11px system-ui, sans-serif"; g.fillStyle = "#5b6475"; g.strokeStyle = "#e6e9ee"; g.lineWidth = 1;
      const rows = Math.max(2, Math.floor((L.y1 - L.y0) / 32));
      v.axes.forEach((a, n) => {
        const ys = niceStep(a.max - a.min, rows, a.integers);
        const Y = Ys[n];
        g.fillStyle = n === 0 ? "#5b6475" : a.color;
        g.textAlign = n === 0 ? "right" : "left"; g.textBaseline = "middle";
        const x = n === 0 ? L.x0 - 6 : L.x1 + 6 + (n - 1) * AXIS_W;
        for (let y = Math.ceil(a.min / ys) * ys; y <= a.max; y += ys) {
          const py = Math.round(Y(y)) + 0.5;
          if (n === 0) { g.beginPath(); g.moveTo(L.x0, py); g.lineTo(L.x1, py); g.stroke(); }
          if (!a.empty) g.fillText(fmt(y), x, py);
        }
        // The axis's unit above it: the left one from the left edge, the right ones ending at the right edge.
        g.textBaseline = "bottom"; g.textAlign = n === 0 ? "left" : "right";
        if (a.unit) g.fillText(a.unit, n === 0 ? 4 : n === 1 ? w - 4 : x + AXIS_W - 4, n < 2 ? L.y0 - 3 : L.y0 - 3 - 12 * (n - 1));
      });
      g.fillStyle = "#5b6475";
      // Time grid: seconds before now.
      const span = (v.end - v.start) / 1000;
      const ts = niceStep(span, Math.max(2, Math.floor((L.x1 - L.x0) / 90)));
      g.textAlign = "center"; g.textBaseline = "top";
      for (let s = 0; s <= span + 1e-9; s += ts) {
        const px = Math.round(X(v.end - s * 1000)) + 0.5;
        g.beginPath(); g.moveTo(px, L.y0); g.lineTo(px, L.y1); g.stroke();
        g.fillText(s === 0 ? (this.paused ? "paused" : "now") : "−" + fmt(s) + " s", px, L.y1 + 5);
      }
      g.strokeStyle = "#c3c9d3"; g.strokeRect(L.x0 + 0.5, L.y0 + 0.5, L.x1 - L.x0, L.y1 - L.y0);
      g.save(); g.beginPath(); g.rect(L.x0, L.y0, L.x1 - L.x0, L.y1 - L.y0); g.clip();
      // Stale: no value came for a while; the time since is shaded, not drawn as if the value held.
      const stale = this.staleFor(v.end);
      if (stale) {
        const x = Math.max(L.x0, X(v.end - stale));
        g.fillStyle = "rgba(110, 119, 129, 0.12)"; g.fillRect(x, L.y0, L.x1 - x, L.y1 - L.y0);
        g.fillStyle = "#6e7781"; g.textAlign = "right"; g.textBaseline = "top";
        g.fillText(`no new values for ${fmt(stale / 1000)} s`, L.x1 - 6, L.y0 + 4);
      }
      // Lines: drawn last to first, so the first series (the actual value) lies on top; a null is a gap.
      for (const s of [...this.series].reverse()) {
        if (!s.visible || !s.t.length) continue;
        const Y = Ys[Math.max(0, v.axes.findIndex((a) => a.unit === s.unit))];
        g.strokeStyle = s.color; g.lineWidth = s === this.series[0] ? 2 : 1.5; g.beginPath();
        let first = true, lone = null;
        for (let i = Math.max(0, s.from(v.start) - 1); i < s.t.length; i++) {
          if (s.t[i] > v.end) break;
          if (s.v[i] === null) { first = true; continue; }
          const px = X(s.t[i]), py = Y(s.v[i]);
          if (first) { g.moveTo(px, py); first = false; lone = [px, py]; } else { g.lineTo(px, py); lone = null; }
        }
        g.stroke();
        if (lone) { g.fillStyle = s.color; g.fillRect(lone[0] - 1.5, lone[1] - 1.5, 3, 3); }
      }
      g.restore();
      this.dirty = false; this.frames++;
    }

    // The visible part as SVG elements, placed at (ox, oy) in a w × h box.
    svg(ox, oy, w, h, title) {
      const v = this.view(), L = this.layout(w, h);
      const X = (t) => (ox + L.x0 + (t - v.start) / (v.end - v.start) * (L.x1 - L.x0)).toFixed(1);
      const Ys = v.axes.map((a) => (y) => (oy + L.y1 - (y - a.min) / (a.max - a.min) * (L.y1 - L.y0)).toFixed(1));
      const esc = (s) => String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;");
      let out = `<text x="${ox + 4}" y="${oy - 18}" font-weight="600" font-size="12">${esc(title)}</text>\n`;
      const rows = Math.max(2, Math.floor((L.y1 - L.y0) / 32));
      v.axes.forEach((a, n) => {
        const ys = niceStep(a.max - a.min, rows, a.integers), Y = Ys[n];
        const x = n === 0 ? ox + L.x0 - 6 : ox + L.x1 + 6 + (n - 1) * AXIS_W;
        for (let y = Math.ceil(a.min / ys) * ys; y <= a.max; y += ys) {
          if (n === 0) out += `<line x1="${ox + L.x0}" x2="${ox + L.x1}" y1="${Y(y)}" y2="${Y(y)}" stroke="#e6e9ee"/>`;
          if (!a.empty) out += `<text x="${x}" y="${Y(y)}" text-anchor="${n === 0 ? "end" : "start"}" dominant-baseline="middle" fill="${n === 0 ? "#5b6475" : a.color}">${fmt(y)}</text>\n`;
        }
        if (a.unit) out += `<text x="${n === 0 ? ox + 4 : x}" y="${oy + L.y0 - 3}" fill="${n === 0 ? "#5b6475" : a.color}">${esc(a.unit)}</text>\n`;
      });
      const span = (v.end - v.start) / 1000, ts = niceStep(span, 6);
      for (let s = 0; s <= span + 1e-9; s += ts) {
        const x = X(v.end - s * 1000);
        out += `<line x1="${x}" x2="${x}" y1="${oy + L.y0}" y2="${oy + L.y1}" stroke="#e6e9ee"/>` +
          `<text x="${x}" y="${oy + L.y1 + 15}" text-anchor="middle" fill="#5b6475">${s === 0 ? "0" : "−" + fmt(s) + " s"}</text>\n`;
      }
      out += `<rect x="${ox + L.x0}" y="${oy + L.y0}" width="${L.x1 - L.x0}" height="${L.y1 - L.y0}" fill="none" stroke="#c3c9d3"/>\n`;
      let lx = ox + L.x0 + 4;
      for (const s of this.series) {
        if (!s.visible) continue;
        const Y = Ys[Math.max(0, v.axes.findIndex((a) => a.unit === s.unit))];
        let pts = [];
        const flush = () => { if (pts.length) out += `<polyline fill="none" stroke="${s.color}" stroke-width="1.6" points="${pts.join(" ")}"/>\n`; pts = []; };
        for (let i = Math.max(0, s.from(v.start) - 1); i < s.t.length; i++) {
          if (s.t[i] > v.end) break;
          if (s.v[i] === null) { flush(); continue; }
          pts.push(`${X(Math.max(s.t[i], v.start))},${Y(s.v[i])}`);
        }
        flush();
        out += `<line x1="${lx}" x2="${lx + 14}" y1="${oy - 6}" y2="${oy - 6}" stroke="${s.color}" stroke-width="3"/>` +
          `<text x="${lx + 18}" y="${oy - 2}" fill="#5b6475">${esc(s.title())}</text>\n`;
        lx += 30 + s.title().length * 6.2;
      }
      return out;
    }
  }

  // Every sample of `plots` as CSV: one row per time stamp, each series holding its last value (empty
  // in a gap). The header names each column with its unit: `actual position [µsteps]`.
  function toCsv(plots) {
    const all = [];
    for (const p of plots) for (const s of p.series) if (!all.some((a) => a.key === s.key)) all.push(s);
    const times = new Set();
    for (const s of all) for (const t of s.t) times.add(t);
    const sorted = [...times].sort((a, b) => a - b);
    const idx = all.map(() => 0), last = all.map(() => "");
    const t0 = sorted.length ? sorted[0] : 0;
    const quote = (s) => (/[",\n]/.test(s) ? `"${s.replace(/"/g, '""')}"` : s);
    const rows = ["time [s],unix time [ms]," + all.map((s) => quote(s.title())).join(",")];
    for (const t of sorted) {
      all.forEach((s, n) => { while (idx[n] < s.t.length && s.t[idx[n]] <= t) { last[n] = s.v[idx[n]] === null ? "" : s.v[idx[n]]; idx[n]++; } });
      rows.push(((t - t0) / 1000).toFixed(3) + "," + t.toFixed(1) + "," + last.join(","));
    }
    return rows.join("\n") + "\n";
  }

  // The plots as one SVG that says what it shows: `about.title` (module, model, address, version) and
  // the time range, then each panel with its title, its units and its series.
  function toSvg(plots, titles, about) {
    const w = 900, h = 220, gap = 56, top = 64;
    const esc = (s) => String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;");
    let body = "";
    plots.forEach((p, n) => { body += p.svg(0, top + n * (h + gap), w, h, titles[n]); });
    const height = top + plots.length * (h + gap);
    const v = plots.length ? plots[0].view() : { start: Date.now(), end: Date.now() };
    const iso = (t) => new Date(t).toISOString().replace("T", " ").slice(0, 19) + " UTC";
    const head = `<title>${esc((about && about.title) || "OpenTMCL workbench plot")}</title>\n` +
      `<text x="4" y="18" font-size="14" font-weight="600">${esc((about && about.title) || "OpenTMCL workbench")}</text>\n` +
      `<text x="4" y="36" fill="#5b6475">${esc(`${iso(v.start)} to ${iso(v.end)} (${fmt((v.end - v.start) / 1000)} s)`)}` +
      `${about && about.note ? " · " + esc(about.note) : ""}</text>\n`;
    return `<?xml version="1.0" encoding="UTF-8"?>\n<svg xmlns="http://www.w3.org/2000/svg" width="${w}" height="${height}" ` +
      `viewBox="0 0 ${w} ${height}" font-family="sans-serif" font-size="11">\n<rect width="100%" height="100%" fill="#fff"/>\n${head}${body}</svg>\n`;
  }

  window.TmclPlot = { Plot, toCsv, toSvg, axisRange };
})();
