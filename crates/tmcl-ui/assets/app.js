// OpenTMCL workbench: the page. One WebSocket to the server that owns the module's link; requests carry
// an id and get one answer each, events (values, link state, program state) arrive in batches.
"use strict";

(function () {
  const $ = (id) => document.getElementById(id);
  const el = (tag, props, ...children) => {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(props || {})) {
      if (k === "class") e.className = v;
      else if (k === "style") Object.assign(e.style, v); // an object: inline style attributes are not allowed (CSP)
      else if (k === "text") e.textContent = v;
      else if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
      else if (v !== null && v !== undefined && v !== false) e.setAttribute(k, v === true ? "" : v);
    }
    e.append(...children);
    return e;
  };

  // Things tests and benchmarks read (`window.workbench`).
  const wb = window.workbench = {
    hello: null, values: {}, received: {}, counts: {}, events: 0, connected: false, stats: null,
    program: null, debug: null, lastDownload: null, transit: [],
  };

  // Connection ---------------------------------------------------------------------------------------
  let ws = null, nextId = 1, retry = 500;
  const pending = new Map();
  const listeners = {};
  // Subscribes `f` to page events ("value", "prog", "debug", "progress", "view"); returns the unsubscribe.
  const on = (e, f) => {
    (listeners[e] = listeners[e] || []).push(f);
    return () => { listeners[e] = listeners[e].filter((g) => g !== f); };
  };
  const emit = (e, msg) => (listeners[e] || []).forEach((f) => f(msg));

  function connect() {
    ws = new WebSocket(`ws://${location.host}/ws`);
    ws.onopen = () => { retry = 500; wb.connected = true; call("hello").then(hello); watch(); };
    ws.onclose = () => {
      wb.connected = false;
      for (const [, p] of pending) p.reject(new Error("the workbench server went away"));
      pending.clear();
      setLine({ state: "offline", ok: false, error: "the workbench server is not reachable; retrying" });
      setTimeout(connect, retry); retry = Math.min(retry * 2, 5000);
    };
    ws.onmessage = (m) => {
      let msg;
      try { msg = JSON.parse(m.data); } catch (e) { return; }
      if (Array.isArray(msg)) { for (const ev of msg) event(ev); return; }
      const p = pending.get(msg.id);
      if (!p) return;
      pending.delete(msg.id);
      if ("ok" in msg) p.resolve(msg.ok); else p.reject(msg);
    };
  }

  function call(op, args) {
    return new Promise((resolve, reject) => {
      if (!ws || ws.readyState !== 1) { reject({ error: "not connected to the workbench server" }); return; }
      const id = nextId++;
      pending.set(id, { resolve, reject });
      ws.send(JSON.stringify(Object.assign({ id, op }, args || {})));
    });
  }
  wb.call = call;
  wb.on = on;

  function event(ev) {
    wb.events++;
    switch (ev.e) {
      case "v": {
        const now = Date.now();
        wb.values[ev.k] = ev.v; wb.received[ev.k] = now; wb.counts[ev.k] = (wb.counts[ev.k] || 0) + 1;
        // How long values take from the server's read to the page (the last 500), for the benchmarks.
        wb.transit.push(now - ev.t); if (wb.transit.length > 500) wb.transit.shift();
        emit("value", ev); break;
      }
      case "link": setLine(ev); break;
      case "epoch": newTrace(ev); break;
      case "stats": wb.stats = ev; $("rps").textContent = `${ev.rps.toFixed(0)}/s of ${ev.rate.toFixed(0)}`; break;
      case "prog": wb.program = ev; emit("prog", ev); break;
      case "debug": wb.debug = ev; emit("debug", ev); break;
      case "progress": emit("progress", ev); break;
      case "hello": hello(ev.hello); break;
      default: break;
    }
  }

  // The line's state (the server's `link` event): the pill in the header and, unless every request gets
  // its own answer, a sentence under it. Whenever the values stop being answers, the plots get a gap.
  const LINE_TEXT = { answering: "answering", mismatched: "mismatched replies", no_answer: "no answer",
    replies_off: "replies off", down: "link gone · reopening", offline: "offline" };
  function setLine(ev) {
    wb.line = ev;
    const pill = $("link-state");
    const warn = ev.state === "mismatched" || ev.state === "replies_off";
    pill.className = "pill " + (ev.state === "answering" ? "ok" : warn ? "warn" : ev.state === "offline" || ev.state === "down" ? "wait" : "bad");
    pill.textContent = ev.state === "mismatched" ? `${ev.mismatched_recent} mismatched repl${ev.mismatched_recent === 1 ? "y" : "ies"}` : (LINE_TEXT[ev.state] || ev.state);
    pill.title = ev.error || "";
    const note = $("line-note");
    note.textContent = ev.state === "answering" ? "" : ev.error || "";
    note.className = "line-note " + (warn ? "warn" : "bad");
    note.hidden = ev.state === "answering" || !ev.error;
    if (!ev.ok) { const t = Date.now(); for (const p of allPlots()) p.gap(t); }
  }
  // A new trace: another module or the link came back. What was plotted belongs to the old one.
  function newTrace(ev) {
    wb.epoch = ev.n;
    for (const p of allPlots()) p.clear();
    say("motion-status", ev.why === "link" ? "the link is back: a new trace begins" : "another module: a new trace begins", true);
  }

  // Module and model ----------------------------------------------------------------------------------
  let model = null, roles = {}, motor = 0;

  function hello(h) {
    wb.hello = h; model = h.model; roles = h.roles || {};
    $("model").textContent = model ? model.name : "unknown model";
    $("version").textContent = h.version || "no answer";
    $("address").textContent = h.address;
    // Long paths keep their end, which names the port.
    $("link-name").textContent = h.link.length > 44 ? "…" + h.link.slice(-43) : h.link; $("link-name").title = h.link;
    if (h.line) setLine(h.line);
    if (h.epoch !== undefined && wb.epoch !== undefined && h.epoch !== wb.epoch) newTrace({ n: h.epoch, why: "module" });
    wb.epoch = h.epoch;
    setupMotion(); setupClosedLoop();
    $("m-link").textContent = h.link; $("m-address").textContent = h.address;
    $("m-version").textContent = h.version || "no answer to command 136";
    $("m-model").textContent = model ? `${model.name} (${model.id})` : "unknown: give --module MODEL";
    $("m-manual").textContent = model ? model.manual : "–";
    $("m-rate").textContent = `${h.rate.toFixed(0)} requests per second`;
    $("select-address").value = h.address;
    const motors = model ? model.motors : 1;
    for (const s of document.querySelectorAll(".motor-select")) {
      s.replaceChildren(...Array.from({ length: motors }, (_, m) => el("option", { value: m, text: String(m) })));
      s.value = String(Math.min(motor, motors - 1));
      s.closest(".motor-choice").hidden = motors < 2;
    }
    buildParams(); buildIo(); setupPlots(true); buildVars(); setupProgram(); buildAxes();
    document.title = `${model ? model.name : "TMCL module"} ${h.address} · OpenTMCL workbench`;
    watch(); // what to poll depends on the model (its charts, its pulse divisor)
  }

  // Views: what is open decides what the server polls.
  let view = "params";
  function watch() {
    if (!ws || ws.readyState !== 1) return;
    const from = Number($("vars-from").value) || 0, count = Math.min(64, Math.max(1, Number($("vars-count").value) || 8));
    call("watch", { views: [view], motor, vars: [from, count], extra: extraKeys() }).catch(() => {});
  }
  const tabs = [...document.querySelectorAll('[role="tab"]')];
  function selectTab(tab) {
    for (const t of tabs) {
      const on = t === tab;
      t.setAttribute("aria-selected", on ? "true" : "false");
      t.tabIndex = on ? 0 : -1;
      $(t.getAttribute("aria-controls")).hidden = !on;
    }
    view = tab.id.replace("tab-", "");
    location.hash = view;
    watch();
    if (view === "console") $("console-input").focus();
    emit("view", view);
  }
  tabs.forEach((t, i) => {
    t.addEventListener("click", () => selectTab(t));
    t.addEventListener("keydown", (e) => {
      const d = e.key === "ArrowRight" ? 1 : e.key === "ArrowLeft" ? -1 : 0;
      if (d) { const n = tabs[(i + d + tabs.length) % tabs.length]; n.focus(); selectTab(n); }
    });
  });
  function selectMotor(m) {
    motor = m;
    for (const o of document.querySelectorAll(".motor-select")) o.value = String(m);
    buildParams(); setupPlots(true); markAxis(); watch();
    emit("motor", m);
  }
  for (const s of document.querySelectorAll(".motor-select")) s.addEventListener("change", () => selectMotor(Number(s.value)));

  // Axes (a model with several motors): a row per motor with its actual and target position, speed,
  // position-reached flag and switches, from the values the server reads of every motor while the motion
  // view is open; a row's button selects that motor.
  let axisCells = new Map();
  function buildAxes() {
    const motors = model ? model.motors : 1;
    $("axes-card").hidden = motors < 2;
    axisCells = new Map();
    if (motors < 2) { $("axes-body").replaceChildren(); return; }
    const cell = (m, role, make) => {
      const node = make();
      if (has(roles[role])) axisCells.set(`ap.${m}.${roles[role]}`, { node, role });
      return node;
    };
    const rows = Array.from({ length: motors }, (_, m) => {
      const pick = el("button", { type: "button", text: `Motor ${m}`, "aria-label": `Show motor ${m}` });
      pick.addEventListener("click", () => selectMotor(m));
      const value = (role) => cell(m, role, () => el("td", { text: "–", "data-axis-role": role }));
      const lamp = (role, text) => cell(m, role, () => el("span", { class: "lamp", text, "aria-label": `motor ${m} ${role} switch inactive` }));
      return el("tr", { "data-motor": String(m) },
        el("th", { scope: "row" }, pick),
        value("actual_position"), value("target_position"), value("actual_speed"), value("reached"),
        el("td", { class: "axis-switches" }, lamp("left", "L"), lamp("home", "H"), lamp("right", "R")));
    });
    $("axes-body").replaceChildren(...rows);
    markAxis();
  }
  function markAxis() {
    for (const tr of $("axes-body").children) {
      const on = Number(tr.dataset.motor) === motor;
      tr.classList.toggle("selected", on);
      if (on) tr.setAttribute("aria-current", "true"); else tr.removeAttribute("aria-current");
    }
  }
  on("value", (ev) => {
    const c = axisCells.get(ev.k);
    if (!c || !("v" in ev)) return;
    const m = mi();
    if (c.role === "left" || c.role === "right" || c.role === "home") {
      c.node.classList.toggle("on", !!ev.v);
      c.node.setAttribute("aria-label", `${c.node.getAttribute("aria-label").replace(/ (in)?active$/, "")} ${ev.v ? "active" : "inactive"}`);
    } else if (c.role === "reached") {
      c.node.textContent = ev.v ? "yes" : "no";
    } else if (c.role === "actual_speed") {
      c.node.textContent = `${ev.v} ${m.velocity_unit}`;
    } else {
      c.node.textContent = `${ev.v} ${m.position_unit}`;
    }
  });

  function say(id, text, ok) {
    const p = $(id); p.textContent = text; p.className = "status-line " + (ok === true ? "ok" : ok === false ? "bad" : "");
  }
  // A refusal in words: the module's status and, where the tables know, why.
  function refusal(err) {
    if (!err) return "failed";
    let text = err.error || String(err);
    if (err.explanation) text += `: ${err.explanation}`;
    return text;
  }

  // Parameters ---------------------------------------------------------------------------------------
  const paramRows = new Map(); // key -> {row, input|span, desc}
  function keyOf(p) { return p.kind === "ap" ? `ap.${motor}.${p.number}` : `gp.${p.bank}.${p.number}`; }
  function buildParams() {
    const table = $("param-table");
    for (const b of table.querySelectorAll("tbody")) b.remove();
    paramRows.clear();
    $("param-empty").hidden = !!model;
    if (!model) return;
    const groups = [
      ["ap", `Axis parameters, motor ${motor}`, (p) => p.kind === "ap"],
      ["gp0", "Global parameters, bank 0", (p) => p.kind === "gp" && p.bank === 0],
      ["gp3", "Interrupt configuration, bank 3", (p) => p.kind === "gp" && p.bank === 3],
    ];
    for (const [id, title, pick] of groups) {
      const body = el("tbody", { "data-group": id });
      body.append(el("tr", { class: "group" }, el("th", { colspan: 7, scope: "colgroup", text: title })));
      for (const p of model.params.filter(pick)) {
        const key = keyOf(p);
        let cell;
        if (p.write) {
          cell = el("input", { type: "text", inputmode: "numeric", "aria-label": `${p.name} value`, value: "", "data-key": key });
          cell.addEventListener("keydown", (e) => {
            if (e.key === "Enter") { e.preventDefault(); writeParam(p, cell); }
            if (e.key === "Escape") { cell.value = wb.values[key] ?? ""; cell.blur(); }
          });
          cell.addEventListener("change", () => writeParam(p, cell));
        } else {
          cell = el("span", { "data-key": key, text: p.read ? "…" : "(write only)" });
        }
        const store = p.store ? [
          el("button", { type: "button", "aria-label": `Store ${p.name}`, text: "Store", onclick: () => eeprom("store", p) }), " ",
          el("button", { type: "button", "aria-label": `Restore ${p.name}`, text: "Restore", onclick: () => eeprom("restore", p) }),
        ] : [];
        const row = el("tr", { "data-key": key, "data-search": `${p.number} ${p.name} ${p.title}`.toLowerCase() },
          el("td", { class: "num", text: String(p.number) }),
          el("td", { class: "name", title: `${p.title} (${p.section})` }, p.name, el("small", { text: p.title })),
          el("td", { class: "val" }, cell),
          el("td", { class: "unit-cell", text: p.unit }),
          el("td", { class: "range", text: p.range }),
          el("td", { class: "access", text: p.access, title: "R read, W write, E EEPROM, A stored automatically, P password protected" }),
          el("td", { class: "eeprom" }, ...store));
        body.append(row);
        paramRows.set(key, { row, cell, p });
        if (key in wb.values) showParam(key, wb.values[key]);
      }
      table.append(body);
    }
    filterParams();
  }
  function showParam(key, value) {
    const r = paramRows.get(key);
    if (!r) return;
    if (r.cell.tagName === "INPUT") {
      if (document.activeElement === r.cell || r.cell.dataset.dirty) return; // the user is typing
      if (r.cell.value !== String(value)) { r.cell.value = value; flash(r.row); }
    } else if (r.cell.textContent !== String(value)) { r.cell.textContent = value; flash(r.row); }
  }
  function flash(row) { row.classList.remove("changed"); void row.offsetWidth; row.classList.add("changed"); }
  function paramArg(p) { return { kind: p.kind, number: p.number, index: p.kind === "ap" ? motor : p.bank }; }
  async function writeParam(p, input) {
    const text = input.value.trim();
    if (text === "" || text === String(wb.values[keyOf(p)])) return;
    const value = /^[-+]?0x[0-9a-f]+$/i.test(text) ? parseInt(text, 16) : Number(text);
    const r = paramRows.get(keyOf(p));
    if (!Number.isInteger(value)) { r.row.classList.add("refused"); say("param-status", `${p.name}: "${text}" is not a whole number`, false); return; }
    try {
      const ok = await call("set", { param: paramArg(p), value });
      for (const row of $("param-table").querySelectorAll("tr.refused")) row.classList.remove("refused");
      input.value = ok.value;
      say("param-status", `${p.kind === "ap" ? "SAP" : "SGP"} ${p.number}: ${p.name} = ${ok.value}${p.unit ? " " + p.unit : ""}`, true);
    } catch (err) {
      r.row.classList.add("refused");
      // The field shows what the module keeps, not the refused value; the refusal says what was typed.
      const kept = wb.values[keyOf(p)];
      input.value = kept ?? ""; delete input.dataset.dirty;
      const range = p.range ? ` (${p.name} takes ${p.range}${p.unit ? " " + p.unit : ""})` : "";
      const why = refusal(err);
      say("param-status", `${p.name} = ${value} refused: ${why}${why.includes(" takes ") ? "" : range}`, false);
    }
  }
  async function eeprom(what, p) {
    try {
      const ok = await call(what, { param: paramArg(p) });
      say("param-status", `${what === "store" ? "Stored" : "Restored"} ${p.name} (${ok.value})`, true);
    } catch (err) { say("param-status", `${p.name}: ${refusal(err)}`, false); }
  }
  function filterParams() {
    const q = $("param-filter").value.trim().toLowerCase(), which = $("param-which").value;
    for (const body of $("param-table").querySelectorAll("tbody")) {
      const groupOn = which === "all" || body.dataset.group === which;
      let any = false;
      for (const row of body.querySelectorAll("tr[data-key]")) {
        const on = groupOn && (!q || row.dataset.search.includes(q));
        row.hidden = !on; any = any || on;
      }
      body.hidden = !any;
    }
  }
  // Parameter sets: save, load (and store), store all; what was skipped or refused is listed.
  function setReport(ok, verb) {
    const list = $("set-report");
    // Refusals first, then what a load could not carry (another unit), then the rest of the skips.
    const rank = (o) => (o.result === "refused" ? 0 : /unit differs/.test(o.why || "") ? 1 : 2);
    const sorted = [...ok.outcomes].sort((a, b) => rank(a) - rank(b));
    list.replaceChildren(...sorted.map((o) => el("li", { class: o.result, text: `${o.param} ${o.name} = ${o.value}${o.unit ? " " + o.unit : ""}: ${o.result}${o.why ? ", " + o.why : ""}` })));
    list.hidden = !ok.outcomes.length;
    const parts = [`${ok.written + ok.stored} ${verb}`];
    if (ok.stored && verb !== "stored") parts.push(`${ok.stored} stored in the EEPROM`);
    if (ok.unchanged) parts.push(`${ok.unchanged} unchanged`);
    if (ok.skipped) parts.push(`${ok.skipped} skipped`);
    if (ok.refused) parts.push(`${ok.refused} refused`);
    say("param-status", parts.join(", "), ok.refused === 0);
    wb.lastSet = ok;
  }
  $("set-save").addEventListener("click", async () => {
    say("param-status", "reading every parameter…");
    try {
      const ok = await call("save_params");
      save(ok.file_name, ok.toml, "application/toml");
      wb.lastSaved = ok;
      say("param-status", `saved ${ok.count} parameters to ${ok.file_name}${ok.notes.length ? ` (${ok.notes.length} not readable)` : ""}`, true);
    } catch (err) { say("param-status", `save: ${refusal(err)}`, false); }
  });
  async function loadSet(text, anyModel) {
    say("param-status", "writing the set…");
    $("set-report").hidden = true;
    try {
      setReport(await call("load_params", { text, store: $("set-store").checked, any_model: anyModel }), "written");
    } catch (err) {
      say("param-status", `load: ${refusal(err)}`, false);
      if (!anyModel && /the set is of a/.test(err.error || "")) {
        $("param-status").append(" ", el("button", { type: "button", text: "Load what matches by number and unit",
          onclick: () => loadSet(text, true) }));
      }
    }
  }
  wb.loadSet = loadSet;
  $("set-load").addEventListener("change", async (e) => {
    const f = e.target.files[0]; if (!f) return;
    const text = await f.text(); e.target.value = "";
    loadSet(text, false);
  });
  $("set-store-all").addEventListener("click", async () => {
    say("param-status", "storing every parameter…");
    try { setReport(await call("store_all"), "stored"); } catch (err) { say("param-status", `store all: ${refusal(err)}`, false); }
  });
  $("param-filter").addEventListener("input", filterParams);
  $("param-which").addEventListener("change", filterParams);
  on("value", (ev) => { if ("v" in ev) showParam(ev.k, ev.v); });

  // Motion and plots ---------------------------------------------------------------------------------
  // Everything in the model's own units: the Speed box takes what ROR/ROL take on this model (TMC428
  // velocity units 0..2047 on the PDx-113), the State card and the plots say the unit of each value.
  let plots = [], panels = [];
  const allPlots = () => plots;
  const COLORS = { actual: "#1f6feb", target: "#d4762c", encoder: "#2da44e", load: "#8250df", current: "#cf222e" };
  const PALETTE = ["#0a7b83", "#bf8700", "#8250df", "#cf222e", "#1f6feb", "#2da44e", "#d4762c", "#6e7781"];
  const FALLBACK_MOTION = { velocity_unit: "pps", velocity_max: 2147483647, speed_min: 1, speed_max: 2147483647,
    speed_default: 51200, position_unit: "µsteps", position_bits: 32, kinematics: "pps" };
  const mi = () => (model && model.motion) || FALLBACK_MOTION;
  const has = (n) => n !== null && n !== undefined;
  function paramOf(kind, number, bank) {
    if (!model) return null;
    return model.params.find((p) => p.kind === kind && p.number === number && (kind === "ap" || p.bank === bank)) || null;
  }
  // "a..b" as [a, b]; null for sets and unbounded ranges.
  function rangeOf(text) {
    const m = /^(-?\d+)\.\.(-?\d+)$/.exec(text || "");
    return m ? [Number(m[1]), Number(m[2])] : null;
  }
  function setupMotion() {
    const m = mi(), speed = $("speed");
    speed.min = 0; speed.max = m.velocity_max;
    if (!speed.dataset.touched || Number(speed.value) > m.velocity_max) speed.value = m.speed_default;
    $("speed-unit").textContent = m.velocity_unit;
    $("speed-range").textContent = `0..${m.velocity_max}`;
    $("position-unit").textContent = m.position_unit;
    const half = 2 ** (m.position_bits - 1);
    $("position").min = -half; $("position").max = half - 1;
  }
  $("speed").addEventListener("input", () => { $("speed").dataset.touched = "1"; });
  // A velocity in words; on a TMC428 model also in microsteps per second, by the pulse divisor read.
  function velocityText(v) {
    const m = mi();
    if (m.kinematics !== "tmc428" || !has(m.pulse_divisor)) return `${v} ${m.velocity_unit}`;
    const pd = wb.values[`ap.${motor}.${m.pulse_divisor}`];
    if (pd === undefined) return `${v} ${m.velocity_unit}`;
    const pps = m.clock_hz * v / (2 ** pd * 2048 * 32);
    return `${v} ${m.velocity_unit} ≈ ${Math.round(pps).toLocaleString("en-US")} µsteps/s`;
  }

  // The charts the user added: per model, stored in the browser. Each entry {title, params: [{kind, number, bank}]}.
  let charts = [];
  const chartStore = () => `tmcl-charts-${model ? model.id : "unknown"}`;
  function loadCharts() {
    try { charts = JSON.parse(localStorage.getItem(chartStore()) || "[]"); } catch (e) { charts = []; }
    if (!Array.isArray(charts)) charts = [];
  }
  function saveCharts() { localStorage.setItem(chartStore(), JSON.stringify(charts)); }
  const keyOfParam = (q) => (q.kind === "ap" ? `ap.${motor}.${q.number}` : `gp.${q.bank}.${q.number}`);
  // The values polled besides the standard ones: the charted parameters, and the TMC428 pulse divisor.
  function extraKeys() {
    const keys = [];
    for (const c of charts) for (const q of c.params) keys.push(keyOfParam(q));
    const m = mi();
    if (m.kinematics === "tmc428" && has(m.pulse_divisor)) keys.push(`ap.${motor}.${m.pulse_divisor}`);
    for (const k of closedLoopKeys()) keys.push(k);
    return [...new Set(keys)];
  }
  function seriesOf(kind, number, bank, label, color, removable) {
    const p = paramOf(kind, number, bank);
    const key = kind === "ap" ? `ap.${motor}.${number}` : `gp.${bank}.${number}`;
    return { key, label: label || (p ? p.name : `${kind.toUpperCase()} ${number}`), color, unit: p ? p.unit : "",
      range: p ? rangeOf(p.range) : null, removable };
  }
  function standardPanels() {
    const ap = (n, label, color) => (has(n) ? seriesOf("ap", n, 0, label, color) : null);
    const cl = model && model.closed_loop;
    const defs = [
      ["position", "Position", [ap(roles.actual_position, "actual position", COLORS.actual), ap(roles.target_position, "target position", COLORS.target), ap(roles.encoder, "encoder", COLORS.encoder)]],
      ["velocity", "Velocity", [ap(roles.actual_speed, "actual speed", COLORS.actual), ap(roles.target_speed, "target speed", COLORS.target),
        cl ? ap(cl.measured_velocity, "measured velocity", COLORS.encoder) : null]],
      ["load", "Load and current", [ap(roles.load, "load value", COLORS.load), cl ? null : ap(roles.current, "current scale", COLORS.current)]],
      ["closed", "Closed loop", cl ? [ap(cl.position_error, "position error", COLORS.load), ap(cl.current_scale, "current scale", COLORS.current)] : []],
    ];
    return defs.map(([id, title, list]) => ({ id, title, series: list.filter(Boolean) }));
  }
  function legendOf(panel) {
    const plot = panel.plot;
    const items = plot.series.map((s) => {
      const box = el("input", { type: "checkbox", checked: s.visible, "aria-label": `Show ${s.label}` });
      box.addEventListener("change", () => { s.visible = box.checked; plot.dirty = true; if (plot.paused) plot.draw(); });
      const parts = [box, el("span", { class: "swatch", style: { background: s.color } }), s.unit ? `${s.label} [${s.unit}]` : s.label];
      const label = el("label", {}, ...parts);
      if (!s.removable) return label;
      const x = el("button", { type: "button", class: "remove", text: "×", "aria-label": `Remove ${s.label} from the chart`,
        onclick: () => removeCharted(panel, s.key) });
      return el("span", { class: "legend-item" }, label, x);
    });
    panel.legend.replaceChildren(...items);
  }
  function figureFor(id, title, custom) {
    if (!custom) return { fig: $(`plot-${id}`).closest("figure"), canvas: $(`plot-${id}`), legend: $(`legend-${id}`) };
    const legend = el("span", { class: "legend" });
    const canvas = el("canvas", { role: "img", "aria-label": `Chart of ${title}` });
    const fig = el("figure", { class: "plot", "data-chart": id }, el("figcaption", {}, title, " ", legend), canvas);
    $("charts").append(fig);
    return { fig, canvas, legend };
  }
  function setupPlots(force) {
    if (!force && plots.length && plots[0].motor === motor) return;
    loadCharts();
    $("charts").replaceChildren();
    const windowMs = Number($("plot-window").value) * 1000;
    const defs = standardPanels().concat(charts.map((c, n) => ({ id: `chart-${n}`, title: c.title, custom: true,
      series: c.params.map((q, i) => seriesOf(q.kind, q.number, q.bank, null, PALETTE[i % PALETTE.length], true)) })));
    panels = defs.map((d) => {
      const f = figureFor(d.id, d.title, d.custom);
      const fresh = f.canvas.cloneNode(false); f.canvas.replaceWith(fresh);
      const plot = new TmclPlot.Plot(fresh, d.series, { window: windowMs });
      plot.motor = motor; plot.title = d.title;
      // A panel the model cannot fill is not drawn.
      f.fig.hidden = d.series.length === 0;
      const panel = { id: d.id, title: d.title, plot, fig: f.fig, legend: f.legend, custom: !!d.custom };
      legendOf(panel);
      return panel;
    });
    plots = panels.filter((p) => !p.fig.hidden).map((p) => p.plot);
    wb.plots = plots; wb.panels = panels;
    // What was read already goes into the new panels.
    const panelsOpt = [el("option", { value: "new", text: "a new panel" }), ...panels.filter((p) => !p.fig.hidden).map((p, n) => el("option", { value: p.id, text: p.title }))];
    $("chart-panel").replaceChildren(...panelsOpt);
    buildChartChoices();
  }
  function buildChartChoices() {
    const list = $("chart-params");
    const rows = model ? model.params.filter((p) => p.read) : [];
    list.replaceChildren(...rows.map((p) => el("option", {
      value: `${p.kind === "ap" ? "AP" : `GP ${p.bank}:`} ${p.number} ${p.name}`,
      text: `${p.title}${p.unit ? " [" + p.unit + "]" : ""}`,
    })));
  }
  // The parameter a chart choice names: "AP 206 LoadValue", "GP 0: 66 SerialAddress", a name, or "ap 206".
  function chartParam(text) {
    if (!model) return null;
    const t = text.trim();
    let m = /^AP\s+(\d+)/i.exec(t);
    if (m) return paramOf("ap", Number(m[1]));
    m = /^GP\s+(\d+):?\s+(\d+)/i.exec(t);
    if (m) return paramOf("gp", Number(m[2]), Number(m[1]));
    m = /^GP\s+(\d+)$/i.exec(t);
    if (m) return paramOf("gp", Number(m[1]), 0);
    const name = t.toLowerCase();
    return model.params.find((p) => p.read && p.name.toLowerCase() === name) ||
      model.params.find((p) => p.read && p.title.toLowerCase() === name) || null;
  }
  function addChart(text, where) {
    const p = chartParam(text);
    if (!p) { say("motion-status", `no readable parameter "${text}" on the ${model ? model.name : "module"}`, false); return false; }
    if (!p.read) { say("motion-status", `${p.name} cannot be read (${p.access})`, false); return false; }
    const q = { kind: p.kind, number: p.number, bank: p.kind === "gp" ? p.bank : 0 };
    const label = `${p.kind === "ap" ? "AP" : "GP"} ${p.number} ${p.name}`;
    const panel = panels.find((x) => x.id === where);
    if (panel && !panel.custom) {
      // Into a standard panel: it becomes a chart of its own kept with that panel's title.
      charts.push({ title: `${panel.title}: ${p.name}`, params: [q] });
    } else if (panel && panel.custom) {
      const c = charts[Number(panel.id.slice(6))];
      if (c.params.some((x) => x.kind === q.kind && x.number === q.number && x.bank === q.bank)) return true;
      c.params.push(q);
    } else {
      charts.push({ title: label, params: [q] });
    }
    saveCharts(); setupPlots(true); watch();
    say("motion-status", `charting ${label}${p.unit ? " in " + p.unit : ""}`, true);
    return true;
  }
  function removeCharted(panel, key) {
    const c = charts[Number(panel.id.slice(6))];
    if (!c) return;
    c.params = c.params.filter((q) => keyOfParam(q) !== key);
    charts = charts.filter((x) => x.params.length);
    saveCharts(); setupPlots(true); watch();
  }
  $("chart-form").addEventListener("submit", (e) => {
    e.preventDefault();
    if (addChart($("chart-param").value, $("chart-panel").value)) $("chart-param").value = "";
  });
  wb.addChart = addChart;
  on("value", (ev) => {
    // A refused read is a gap in that value's line, not a value.
    for (const p of plots) p.push(ev.k, ev.t, "v" in ev ? ev.v : null);
    if (!("v" in ev)) return;
    const m = (n) => `ap.${motor}.${n}`;
    const pos = mi().position_unit;
    const show = (id, n, text) => { if (has(n) && ev.k === m(n)) $(id).textContent = text(ev.v); };
    show("st-apos", roles.actual_position, (v) => `${v} ${pos}`); show("st-tpos", roles.target_position, (v) => `${v} ${pos}`);
    show("st-aspeed", roles.actual_speed, velocityText); show("st-tspeed", roles.target_speed, velocityText);
    if (ev.k === m(roles.reached)) $("st-reached").textContent = ev.v ? "yes" : "no";
    const lamp = (id, n) => { if (ev.k === m(n)) { $(id).classList.toggle("on", !!ev.v); $(id).setAttribute("aria-label", `${$(id).textContent} switch ${ev.v ? "active" : "inactive"}`); } };
    lamp("sw-left", roles.left); lamp("sw-right", roles.right); lamp("sw-home", roles.home);
    if (ev.k === `rfs.${motor}`) $("rfs-status").textContent = ev.v ? `searching (${ev.v})` : "no search active";
  });
  // The plot update rate: new samples of the actual position per second, shown and kept for tests.
  let lastCount = 0;
  // The closed loop (TMCM-1310): encoder initialisation, close/open, the status word's bits as lamps, the
  // settings beside the plots of position error, current scale and measured velocity.
  const clInfo = () => (model && model.closed_loop) || null;
  const closedLoopKeys = () => {
    const cl = clInfo();
    if (!cl) return [];
    return [cl.encoder_init, cl.active, cl.status_word, cl.position_error, cl.current_scale, cl.measured_velocity]
      .filter(has).map((n) => `ap.${motor}.${n}`);
  };
  const INIT_STATE = ["not initialised", "initialising…", "initialised", "failed"];
  function setupClosedLoop() {
    const cl = clInfo();
    $("cl-card").hidden = !cl;
    if (!cl) return;
    $("cl-bits").replaceChildren(...cl.status_bits.map((name, bit) => el("span", { class: "lamp", "data-bit": bit, text: name })));
    const rows = cl.settings.map((n) => {
      const p = paramOf("ap", n);
      if (!p) return null;
      const input = el("input", { type: "number", "aria-label": p.name, "data-cl": n });
      input.addEventListener("change", async () => {
        try {
          const ok = await call("set", { param: { kind: "ap", number: n, index: motor }, value: Number(input.value) });
          input.value = ok.value; say("cl-status", `${p.name} = ${ok.value}${p.unit ? " " + p.unit : ""}`, true);
        } catch (err) {
          say("cl-status", `${p.name} = ${input.value} refused: ${refusal(err)}`, false);
          readSetting(n, input);
        }
      });
      readSetting(n, input);
      return el("tr", {}, el("th", { scope: "row", title: `AP ${n}, ${p.title}`, text: p.title }), el("td", {}, input), el("td", { text: p.unit || "" }));
    }).filter(Boolean);
    $("cl-settings").replaceChildren(...rows);
  }
  async function readSetting(n, input) {
    try { input.value = (await call("get", { param: { kind: "ap", number: n, index: motor } })).value; } catch (e) { /* shown as empty */ }
  }
  async function clWrite(n, value, what) {
    try {
      await call("set", { param: { kind: "ap", number: n, index: motor }, value });
      say("cl-status", what, true);
    } catch (err) { say("cl-status", `${what}: ${refusal(err)}`, false); }
  }
  $("cl-init").addEventListener("click", () => { const cl = clInfo(); if (cl) clWrite(cl.encoder_init, 1, "encoder initialisation started (AP " + cl.encoder_init + " := 1)"); });
  $("cl-close").addEventListener("click", () => { const cl = clInfo(); if (cl) clWrite(cl.closed_loop, 1, "closing the loop (AP " + cl.closed_loop + " := 1)"); });
  $("cl-open").addEventListener("click", () => { const cl = clInfo(); if (cl) clWrite(cl.closed_loop, 0, "opening the loop (AP " + cl.closed_loop + " := 0)"); });
  on("value", (ev) => {
    const cl = clInfo();
    if (!cl || !("v" in ev)) return;
    const k = (n) => `ap.${motor}.${n}`;
    if (ev.k === k(cl.encoder_init)) $("cl-init-state").textContent = `${INIT_STATE[ev.v] || ev.v} (AP ${cl.encoder_init} = ${ev.v})`;
    if (ev.k === k(cl.active)) $("cl-loop-state").textContent = ev.v ? `closed (AP ${cl.active} = 1)` : `open (AP ${cl.active} = 0)`;
    if (has(cl.status_word) && ev.k === k(cl.status_word)) {
      for (const lamp of $("cl-bits").children) lamp.classList.toggle("on", !!(ev.v & (1 << Number(lamp.dataset.bit))));
    }
  });
  setInterval(() => {
    const key = `ap.${motor}.${roles.actual_position}`;
    const n = wb.counts[key] || 0;
    wb.plotRate = n - lastCount; lastCount = n;
    $("plot-rate").textContent = `${wb.plotRate} samples/s`;
  }, 1000);
  async function motion(action, value) {
    try {
      const ok = await call("motion", { action, motor, value: value || 0 });
      wb.lastMotion = { action, value, t: ok.t, at: Date.now() };
      const unit = action.startsWith("rotate") ? " " + mi().velocity_unit : action.startsWith("move") ? " " + mi().position_unit : "";
      say("motion-status", `${action.replace(/_/g, " ")}${value !== undefined ? " " + value + unit : ""}: done`, true);
    } catch (err) { say("motion-status", `${action.replace(/_/g, " ")}: ${refusal(err)}`, false); }
  }
  const num = (id) => { const v = Number($(id).value); return Number.isFinite(v) ? Math.trunc(v) : 0; };
  $("ror").addEventListener("click", () => motion("rotate_right", num("speed")));
  $("rol").addEventListener("click", () => motion("rotate_left", num("speed")));
  $("mst").addEventListener("click", () => motion("stop"));
  $("mvp-abs").addEventListener("click", () => motion("move_absolute", num("position")));
  $("mvp-rel").addEventListener("click", () => motion("move_relative", num("position")));
  $("rfs-start").addEventListener("click", () => motion("reference_start"));
  $("rfs-stop").addEventListener("click", () => motion("reference_stop"));
  $("plot-pause").addEventListener("click", (e) => {
    const p = e.currentTarget.getAttribute("aria-pressed") !== "true";
    e.currentTarget.setAttribute("aria-pressed", p ? "true" : "false");
    e.currentTarget.textContent = p ? "Resume" : "Pause";
    for (const pl of plots) pl.setPaused(p);
  });
  $("plot-window").addEventListener("change", () => { for (const p of plots) p.setWindow(Number($("plot-window").value) * 1000); });
  function save(name, text, type) {
    const a = el("a", { href: URL.createObjectURL(new Blob([text], { type })), download: name });
    document.body.append(a); a.click(); a.remove();
    setTimeout(() => URL.revokeObjectURL(a.href), 1000);
  }
  const stamp = () => new Date().toISOString().replace(/[:.]/g, "-").slice(0, 19);
  // What an export is of: the module, its model, address and version, and the motor.
  function about() {
    const h = wb.hello || {};
    const name = model ? `${model.name} (${model.id})` : "unknown model";
    return { title: `${name}, module address ${h.address}, version ${h.version || "unknown"}, motor ${motor}`,
      note: `OpenTMCL workbench on ${h.link || "?"}` };
  }
  const shown = () => panels.filter((p) => !p.fig.hidden);
  const exportCsv = () => TmclPlot.toCsv(shown().map((p) => p.plot));
  const exportSvg = () => TmclPlot.toSvg(shown().map((p) => p.plot), shown().map((p) => p.title), about());
  $("plot-csv").addEventListener("click", () => save(`tmcl-plot-${stamp()}.csv`, exportCsv(), "text/csv"));
  $("plot-svg").addEventListener("click", () => save(`tmcl-plot-${stamp()}.svg`, exportSvg(), "image/svg+xml"));
  wb.exportCsv = exportCsv;
  wb.exportSvg = exportSvg;

  // I/O ----------------------------------------------------------------------------------------------
  function buildIo() {
    const ports = model ? model.ports : [];
    const ins = $("io-inputs"), an = $("io-analog").tBodies[0], outs = $("io-outputs");
    ins.replaceChildren(); an.replaceChildren(); outs.replaceChildren();
    for (const p of ports) {
      const key = `io.${p.bank}.${p.port}`;
      if (p.kind === "input") {
        ins.append(el("li", {}, el("span", { text: p.name }), el("span", { class: "lamp", "data-key": key, "aria-label": `${p.name} input`, text: "–" })));
      } else if (p.kind === "analog" || p.kind === "temperature" || p.kind === "supply") {
        an.append(el("tr", {}, el("th", { scope: "row", text: p.name }), el("td", { "data-key": key, text: "–" }),
          el("td", {}, p.kind === "analog" ? el("meter", { min: 0, max: 4095, value: 0, "data-meter": key, "aria-label": `${p.name} level` }) : "")));
      } else if (p.kind === "output") {
        const box = el("input", { type: "checkbox", role: "switch", "aria-label": p.name, "data-key": key });
        box.addEventListener("change", async () => {
          try {
            await call("output", { port: p.port, bank: p.bank, value: box.checked ? 1 : 0 });
            say("io-status", `SIO ${p.port}, ${p.bank}, ${box.checked ? 1 : 0}: ${p.name} ${box.checked ? "on" : "off"}`, true);
          } catch (err) { box.checked = !box.checked; say("io-status", `${p.name}: ${refusal(err)}`, false); }
        });
        outs.append(el("li", {}, el("span", { text: p.name }), el("label", { class: "switch" }, box)));
      }
    }
    if (!ins.children.length) ins.append(el("li", { class: "hint", text: "none known" }));
    if (!outs.children.length) outs.append(el("li", { class: "hint", text: "none known" }));
  }
  on("value", (ev) => {
    if (!ev.k.startsWith("io.") || !("v" in ev)) return;
    for (const e of document.querySelectorAll(`#view-io [data-key="${ev.k}"]`)) {
      if (e.tagName === "INPUT") { if (document.activeElement !== e) e.checked = !!ev.v; }
      else if (e.classList.contains("lamp")) { e.classList.toggle("on", !!ev.v); e.textContent = ev.v ? "high" : "low"; }
      else e.textContent = ev.v;
    }
    const m = document.querySelector(`#view-io [data-meter="${ev.k}"]`);
    if (m) m.value = ev.v;
  });

  // Console ------------------------------------------------------------------------------------------
  const history = JSON.parse(localStorage.getItem("tmcl-console-history") || "[]");
  let historyAt = history.length, draft = "";
  function log(cls, text) {
    const list = $("console-log");
    const li = el("li", { class: cls, text });
    list.append(li);
    while (list.children.length > 2000) list.firstChild.remove();
    list.scrollTop = list.scrollHeight;
    return li;
  }
  $("console-form").addEventListener("submit", async (e) => {
    e.preventDefault();
    const input = $("console-input"), line = input.value.trim();
    if (!line) return;
    if (history[history.length - 1] !== line) history.push(line);
    while (history.length > 200) history.shift();
    localStorage.setItem("tmcl-console-history", JSON.stringify(history));
    historyAt = history.length; draft = ""; input.value = "";
    log("cmd", line);
    try {
      const ok = await call("console", { line });
      log("bytes", `  sent ${ok.sent}  [${ok.bytes}]`);
      const named = ok.name ? ` (${ok.name})` : "";
      log("ok", `  ${ok.reply}${named}`);
    } catch (err) {
      if (err.sent) log("bytes", `  sent ${err.sent}`);
      log("err", `  ${refusal(err)}`);
    }
  });
  $("console-input").addEventListener("keydown", (e) => {
    const input = e.currentTarget;
    if (e.key === "ArrowUp" && historyAt > 0) {
      if (historyAt === history.length) draft = input.value;
      input.value = history[--historyAt]; e.preventDefault();
    } else if (e.key === "ArrowDown" && historyAt < history.length) {
      historyAt++; input.value = historyAt === history.length ? draft : history[historyAt]; e.preventDefault();
    }
  });
  $("console-clear").addEventListener("click", () => $("console-log").replaceChildren());

  // Program ------------------------------------------------------------------------------------------
  const editor = new TmclEditor.Editor($("editor"));
  wb.editor = editor;
  // The program in the editor is kept per model; a model's first program is its own sample (its speed in
  // its own unit, from the server's tables).
  const programStore = () => `tmcl-program-${model ? model.id : "unknown"}`;
  let programModel;
  function setupProgram() {
    const id = model ? model.id : null;
    if (programModel === id) return;
    programModel = id;
    const sample = model ? model.sample_program : "// Give --module MODEL to get the model's sample program.\n";
    // A program kept by an earlier version (one for all models) becomes this model's, unless it is that
    // version's PD28-1021 sample, which other models refuse.
    const legacy = localStorage.getItem("tmcl-program");
    if (legacy !== null && localStorage.getItem(programStore()) === null && model &&
        !legacy.startsWith("// A first program: back and forth between two positions.")) {
      localStorage.setItem(programStore(), legacy);
    }
    localStorage.removeItem("tmcl-program");
    editor.value = localStorage.getItem(programStore()) ?? sample;
    downloaded = null;
  }
  editor.onChange = () => { localStorage.setItem(programStore(), editor.value); downloaded = null; };
  let downloaded = null; // the source last downloaded
  // Errors keep a program from assembling; warnings (the model would refuse the instruction, status 3
  // or 4, and the program would skip it) are marked at their line and do not.
  function diagnostics(list, okText, warnings = []) {
    const ul = $("diagnostics");
    const marked = [...list, ...warnings.map((w) => ({ ...w, warning: true }))];
    ul.replaceChildren(...marked.map((d) => el("li", { class: d.warning ? "warn" : "" }, el("button", {
      type: "button",
      text: (d.warning ? "warning: " : "") + (d.line ? `line ${d.line}, column ${d.column}: ${d.message}` : d.message),
      onclick: () => d.line && editor.goTo(d.line, d.column),
    }))));
    if (!list.length && okText) ul.append(el("li", { class: "ok", text: okText }));
    editor.setDiagnostics(marked);
  }
  async function assemble() {
    try {
      const ok = await call("assemble", { source: editor.value });
      diagnostics(ok.diagnostics, ok.instructions !== null ? `Assembled: ${ok.instructions} instructions, no errors.` : "", ok.warnings || []);
      return ok.diagnostics.length === 0;
    } catch (err) { diagnostics([{ line: 0, message: refusal(err) }]); return false; }
  }
  async function download() {
    say("pg-progress", "downloading…");
    try {
      const ok = await call("download", { source: editor.value });
      if (ok.diagnostics.length) { diagnostics(ok.diagnostics); say("pg-progress", "not downloaded: the program has errors", false); return false; }
      diagnostics([], `Downloaded: ${ok.stored} instructions at addresses 0–${ok.stored - 1}.`, ok.warnings || []);
      downloaded = editor.value; wb.lastDownload = ok;
      say("pg-progress", `${ok.stored} instructions stored`, true);
      await sendBreakpoints([...editor.breakpoints]);
      return true;
    } catch (err) { say("pg-progress", `download failed: ${refusal(err)}`, false); return false; }
  }
  async function sendBreakpoints(lines) {
    if (downloaded === null) { showBreakpoints(lines); return; }
    try {
      const ok = await call("breakpoints", { lines });
      editor.setBreakpoints(ok.lines); showBreakpoints(ok.lines);
    } catch (err) { say("pg-progress", refusal(err), false); }
  }
  function showBreakpoints(lines) {
    $("bp-list").replaceChildren(...(lines.length ? lines.map((n) => el("li", {},
      el("span", { text: `line ${n}: ${(editor.lines()[n - 1] || "").trim()}` }),
      el("button", { type: "button", "aria-label": `Remove breakpoint at line ${n}`, text: "×", onclick: () => editor.toggle(n) }))) :
      [el("li", { class: "hint", text: "none" })]));
  }
  editor.onBreakpoints = (lines) => sendBreakpoints(lines);
  showBreakpoints([]);
  async function program(action) {
    if (downloaded === null && (action === "start")) { if (!(await download())) return; }
    try { await call("program", { action }); } catch (err) { say("pg-progress", `${action}: ${refusal(err)}`, false); }
  }
  $("pg-assemble").addEventListener("click", assemble);
  $("pg-download").addEventListener("click", download);
  for (const a of ["start", "stop", "step", "continue", "reset"]) $(`pg-${a}`).addEventListener("click", () => program(a));
  $("pg-open").addEventListener("change", async (e) => {
    const f = e.target.files[0]; if (!f) return;
    editor.value = await f.text(); editor.onChange(); e.target.value = "";
  });
  $("pg-save").addEventListener("click", () => save("program.tmc", editor.value, "text/plain"));
  function showProgram(ev) {
    const state = ev.continuing ? "running to a breakpoint" : ev.mode_text + (ev.waiting ? " (waiting)" : "");
    $("prog-state").textContent = `${ev.mode_text}${ev.continuing ? " ⇢ bp" : ""}, pc ${ev.pc}`;
    $("dbg-state").textContent = state;
    $("dbg-pc").textContent = ev.line ? `${ev.pc} (line ${ev.line})` : String(ev.pc);
    const live = ev.mode === 1 || ev.continuing;
    editor.setPc(downloaded !== null && ev.line && !live ? ev.line : downloaded !== null && ev.line && live ? ev.line : null);
  }
  on("prog", showProgram);
  on("debug", (ev) => {
    if (ev.error) { say("pg-progress", ev.error, false); return; }
    showProgram(ev);
    $("dbg-acc").textContent = ev.acc ?? "–"; $("dbg-x").textContent = ev.x ?? "–";
    const why = { breakpoint: `stopped at the breakpoint on line ${ev.line}`, stopped: "stopped", step: "stepped",
      reset: "reset", running: "running", continuing: "running to the next breakpoint (single steps)" }[ev.reason] || ev.reason;
    say("pg-progress", why, true);
  });
  on("progress", (ev) => {
    if (ev.what === "download") say("pg-progress", `downloading ${ev.done}/${ev.total}`);
    if (ev.what === "scan") say("scan-status", `scanning ${ev.done}/${ev.total}`);
  });
  on("value", (ev) => {
    if (ev.k === "acc") $("dbg-acc").textContent = ev.v;
    if (ev.k === "x") $("dbg-x").textContent = ev.v;
    if (ev.k.startsWith("gp.2.")) { const c = document.querySelector(`#vars [data-key="${ev.k}"]`); if (c) c.textContent = "v" in ev ? ev.v : `status ${ev.s}`; }
  });
  function buildVars() {
    const from = Math.max(0, Number($("vars-from").value) || 0);
    const count = Math.min(64, Math.max(1, Number($("vars-count").value) || 8));
    const limit = model ? model.user_variables : 256;
    const rows = [];
    for (let n = from; n < Math.min(from + count, limit); n++) {
      const key = `gp.2.${n}`;
      rows.push(el("tr", {}, el("th", { scope: "row", text: `GGP ${n}, 2` }), el("td", { "data-key": key, text: key in wb.values ? wb.values[key] : "–" })));
    }
    $("vars").tBodies[0].replaceChildren(...rows);
  }
  for (const id of ["vars-from", "vars-count"]) $(id).addEventListener("change", () => { buildVars(); watch(); });

  // Module: scan and select -------------------------------------------------------------------------
  $("scan-form").addEventListener("submit", async (e) => {
    e.preventDefault();
    const first = Number($("scan-first").value), last = Number($("scan-last").value);
    say("scan-status", "scanning…");
    try {
      const ok = await call("scan", { first, last });
      $("scan-results").replaceChildren(...ok.modules.map((m) => el("li", {},
        el("span", { text: `address ${m.address}` }), el("span", { text: m.version || "(no version string)" }),
        el("button", { type: "button", text: "Use", "aria-label": `Use module ${m.address}`, onclick: () => select(m.address) }))));
      say("scan-status", `${ok.modules.length} module${ok.modules.length === 1 ? "" : "s"} between ${first} and ${last}`, true);
    } catch (err) { say("scan-status", refusal(err), false); }
  });
  async function select(address) {
    try { await call("select", { address }); say("scan-status", `talking to address ${address}`, true); watch(); }
    catch (err) { say("scan-status", refusal(err), false); }
  }
  $("select-form").addEventListener("submit", (e) => { e.preventDefault(); select(Number($("select-address").value)); });

  // Start ----------------------------------------------------------------------------------------------
  const first = tabs.find((t) => t.id === `tab-${location.hash.slice(1)}`) || tabs[0];
  selectTab(first);
  connect();
})();
