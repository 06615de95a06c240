// OpenTMCL workbench: the program editor. A plain textarea (so typing, selection, undo and screen readers
// work as in any text field) over a highlighted copy of its text, with a gutter of line numbers that are
// also the breakpoint toggles.
"use strict";

(function () {
  const MNEMONICS = new Set(("ROR ROL MST MVP SAP GAP STAP RSAP SGP GGP STGP RSGP RFS SIO GIO CALC COMP JC JA CSUB " +
    "RSUB WAIT STOP SCO GCO CCO ACO CALCX AAP AGP CLE EI DI VECT RETI SAC UF0 UF1 UF2 UF3 UF4 UF5 UF6 UF7").split(" "));
  const TYPE_WORDS = new Set(("ABS REL COORD START STATUS ADD SUB MUL DIV MOD AND OR XOR NOT LOAD SWAP ZE NZ EQ NE GT " +
    "GE LT LE ETO EAL EDV EPO ESD TICKS POS REFSW LIMSW RFS ALL").split(" "));

  const esc = (s) => s.replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;");

  // One line as highlighted HTML; `err` is [start, end) in characters to underline, or null.
  function highlight(line, err) {
    const spans = [];
    const re = /(\/\/.*$)|(^\s*#\w+.*$)|(#op\b)|([A-Za-z_][\w]*\s*:(?!:))|([-+]?(?:0x[0-9a-fA-F]+|\$[0-9a-fA-F]+|0b[01]+|\d+))|([A-Za-z_][\w]*)/g;
    let m, last = 0;
    while ((m = re.exec(line))) {
      if (m.index > last) spans.push([last, m.index, null]);
      let cls = null;
      if (m[1]) cls = "tk-c";
      else if (m[2]) cls = "tk-d";
      else if (m[3]) cls = "tk-m";
      else if (m[4]) cls = "tk-l";
      else if (m[5]) cls = "tk-n";
      else if (m[6]) { const w = m[6].toUpperCase(); cls = MNEMONICS.has(w) ? "tk-m" : TYPE_WORDS.has(w) ? "tk-t" : null; }
      spans.push([m.index, m.index + m[0].length, cls]);
      last = m.index + m[0].length;
      if (!m[0].length) re.lastIndex++;
    }
    if (last < line.length) spans.push([last, line.length, null]);
    // Split at the error's edges, then render.
    let html = "";
    for (const [a, b, cls] of spans) {
      const cuts = [a, b];
      if (err) for (const e of err) if (e > a && e < b) cuts.push(e);
      cuts.sort((x, y) => x - y);
      for (let i = 0; i + 1 < cuts.length; i++) {
        const [x, y] = [cuts[i], cuts[i + 1]];
        if (x === y) continue;
        const classes = [cls, err && x >= err[0] && y <= err[1] ? "tk-e" : null].filter(Boolean).join(" ");
        const text = esc(line.slice(x, y));
        html += classes ? `<span class="${classes}">${text}</span>` : text;
      }
    }
    return html;
  }

  class Editor {
    constructor(root) {
      this.root = root;
      this.gutter = document.createElement("div"); this.gutter.className = "gutter";
      this.gutter.setAttribute("role", "group"); this.gutter.setAttribute("aria-label", "Line numbers and breakpoints");
      const code = document.createElement("div"); code.className = "code";
      this.pre = document.createElement("pre"); this.pre.setAttribute("aria-hidden", "true");
      this.area = document.createElement("textarea");
      this.area.spellcheck = false; this.area.setAttribute("aria-label", "TMCL program");
      this.area.setAttribute("autocapitalize", "off"); this.area.setAttribute("autocomplete", "off");
      this.area.wrap = "off";
      code.append(this.pre, this.area); root.append(this.gutter, code);
      this.breakpoints = new Set(); this.errors = new Map(); this.pc = null;
      this.onBreakpoints = () => {}; this.onChange = () => {};
      this.area.addEventListener("input", () => { this.render(); this.onChange(); });
      this.area.addEventListener("scroll", () => this.sync());
      this.area.addEventListener("keydown", (e) => {
        if (e.key === "Tab" && !e.shiftKey && !e.ctrlKey && !e.altKey) {
          // Indent with spaces; Escape then Tab leaves the editor (the textarea keeps keyboard users free).
          if (this.escaped) { this.escaped = false; return; }
          e.preventDefault();
          document.execCommand("insertText", false, "    ");
        }
        if (e.key === "F9") {
          // F9 toggles the breakpoint on the caret's line, as in most IDEs (the gutter is for the mouse).
          e.preventDefault();
          this.toggle(this.area.value.slice(0, this.area.selectionStart).split("\n").length);
        }
        this.escaped = e.key === "Escape";
      });
      this.gutter.addEventListener("click", (e) => {
        const b = e.target.closest("button"); if (!b) return;
        this.toggle(Number(b.dataset.line));
      });
      this.render();
    }
    get value() { return this.area.value; }
    set value(text) { this.area.value = text; this.errors.clear(); this.render(); }
    lines() { return this.area.value.split("\n"); }
    toggle(line) {
      if (this.breakpoints.has(line)) this.breakpoints.delete(line); else this.breakpoints.add(line);
      this.render(); this.onBreakpoints([...this.breakpoints].sort((a, b) => a - b));
    }
    setBreakpoints(lines) { this.breakpoints = new Set(lines); this.render(); }
    // diagnostics: [{line, column, width, message}]
    setDiagnostics(list) {
      this.errors.clear();
      for (const d of list) if (d.line > 0 && !this.errors.has(d.line)) this.errors.set(d.line, d);
      this.render();
    }
    setPc(line) { if (this.pc !== line) { this.pc = line; this.render(); if (line) this.reveal(line); } }
    reveal(line) {
      const top = (line - 1) * 20, view = this.area.clientHeight;
      if (top < this.area.scrollTop || top > this.area.scrollTop + view - 40) this.area.scrollTop = Math.max(0, top - view / 3);
    }
    goTo(line, column) {
      const lines = this.lines();
      let pos = 0;
      for (let i = 0; i < line - 1 && i < lines.length; i++) pos += lines[i].length + 1;
      pos += Math.max(0, (column || 1) - 1);
      this.area.focus(); this.area.setSelectionRange(pos, pos); this.reveal(line);
    }
    render() {
      const lines = this.lines();
      let html = "";
      lines.forEach((text, i) => {
        const n = i + 1, d = this.errors.get(n);
        const err = d ? [d.column - 1, d.column - 1 + Math.max(1, d.width)] : null;
        const cls = ["ln", n === this.pc ? "pc" : "", d ? (d.warning ? "warn" : "err") : ""].filter(Boolean).join(" ");
        html += `<div class="${cls}">${highlight(text, err) || " "}</div>`;
      });
      this.pre.innerHTML = html + "<div class=\"ln\"> </div>";
      // The gutter: reuse buttons, add or remove at the end.
      const g = this.gutter;
      while (g.children.length > lines.length) g.lastChild.remove();
      while (g.children.length < lines.length) {
        const b = document.createElement("button"); b.type = "button"; b.tabIndex = -1; g.append(b);
      }
      for (let i = 0; i < lines.length; i++) {
        const b = g.children[i], n = i + 1, on = this.breakpoints.has(n);
        if (b.dataset.line !== String(n)) { b.dataset.line = n; b.textContent = n; }
        b.setAttribute("aria-label", `Breakpoint at line ${n}`);
        b.setAttribute("aria-pressed", on ? "true" : "false");
        const mark = this.errors.get(n);
        b.className = [n === this.pc ? "pc" : "", mark ? (mark.warning ? "warn" : "err") : ""].filter(Boolean).join(" ");
        if (this.errors.has(n)) b.title = this.errors.get(n).message; else b.removeAttribute("title");
      }
      this.sync();
    }
    sync() {
      this.pre.scrollTop = this.area.scrollTop; this.pre.scrollLeft = this.area.scrollLeft;
      this.gutter.scrollTop = this.area.scrollTop;
    }
  }

  window.TmclEditor = { Editor, highlight };
})();
