/* pkmlib interactive figures: the paper's maps precomputed by pkmlib (pkmlib/explore), drawn on a
 * <canvas>. No library, no network: data files are <script> files (they load over HTTP and from
 * file://), arrays are float32, byte-shuffled, gzip, base64, decompressed by the browser's DecompressionStream.
 * Markup: <div class="pk-explore" data-src="../site/explore/data/p1_maps"></div> and this script. */
(function () {
  "use strict";
  if (window.pkExplore && window.pkExplore.started) return;
  const pending = {};  // "id" or "id/key" -> {promise, resolve}
  const store = {};
  function slot(name) {
    if (!pending[name]) {
      let resolve;
      const promise = new Promise((r) => { resolve = r; });
      pending[name] = { promise, resolve };
    }
    return pending[name];
  }
  function loadScript(url, name) {
    const s = slot(name);
    if (!s.requested) {
      s.requested = true;
      const el = document.createElement("script");
      el.src = url;
      el.onerror = () => console.warn("pk-explore: could not load " + url);
      document.head.appendChild(el);
    }
    return s.promise;
  }
  async function decode(b64) {
    const bin = atob(b64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("gzip"));
    const b = new Uint8Array(await new Response(stream).arrayBuffer());
    const n = b.length / 4, out = new Uint8Array(b.length);  // un-shuffle: byte k of value i is b[k n + i]
    for (let i = 0; i < n; i++) { out[4 * i] = b[i]; out[4 * i + 1] = b[n + i]; out[4 * i + 2] = b[2 * n + i]; out[4 * i + 3] = b[3 * n + i]; }
    return new Float32Array(out.buffer);  // little endian on every platform a browser runs on
  }

  // ---------- formatting ----------
  function fmt(v, digits) {
    // `digits` significant digits; plain notation from 1e-3 to 1e6, else exponent notation
    if (v === null || v === undefined || !isFinite(v)) return "NaN";
    if (v === 0) return "0";
    const a = Math.abs(v);
    if (a >= 1e-3 && a < 1e6) return Number(v.toPrecision(digits)).toString();
    return v.toExponential(digits - 1);
  }
  function fmtControl(c, v) {
    if (typeof v === "string") return /[\s\[\]]/.test(v) ? "'" + v + "'" : v;  // a list: one shell word
    return Number(v.toPrecision(c.digits || 4)).toString();
  }
  function shown(c, v) { return typeof v === "string" ? v : fmtControl(c, v); }
  function withUnit(text, unit) {
    if (!unit) return text;
    if (unit === "deg") return text + "°";
    return text + " " + unit;
  }
  function niceTicks(lo, hi, n) {
    const span = hi - lo;
    if (!(span > 0)) return [lo];
    const raw = span / n, mag = Math.pow(10, Math.floor(Math.log10(raw)));
    const step = [1, 2, 2.5, 5, 10].map((m) => m * mag).find((s) => span / s <= n) || 10 * mag;
    const out = [];
    for (let t = Math.ceil(lo / step) * step; t <= hi + step * 1e-9; t += step) out.push(Math.abs(t) < step * 1e-9 ? 0 : t);
    return out;
  }
  function tickText(t) { return Number(t.toPrecision(6)).toString(); }

  // ---------- a map figure ----------
  class MapFigure {
    constructor(el, manifest, base) {
      this.el = el; this.m = manifest; this.base = base;
      this.controls = manifest.controls;
      this.pos = this.controls.map((c) => (c.paper === null || c.paper === undefined) ? 0 : c.values.indexOf(c.paper));
      if (el.dataset.field) {
        const fi = this.controls.findIndex((c) => c.field);
        const at = this.controls[fi].values.indexOf(el.dataset.field);
        if (fi >= 0 && at >= 0) this.pos[fi] = at;
      }
      this.build();
      this.update();
      window.addEventListener("resize", () => this.draw());
    }
    build() {
      const el = this.el, m = this.m;
      el.innerHTML = "";
      el.classList.add("pk-ready");
      const mk = (tag, cls, parent) => { const e = document.createElement(tag); if (cls) e.className = cls; (parent || el).appendChild(e); return e; };
      this.title = mk("div", "pk-title");
      this.banner = mk("div", "pk-banner");
      this.banner.setAttribute("role", "status");
      const box = mk("div", "pk-controls");
      this.inputs = this.controls.map((c, i) => {
        const row = mk("label", "pk-control", box);
        row.dataset.name = c.name;
        const name = mk("span", "pk-control-label", row);
        name.textContent = c.label + (c.unit && c.kind !== "select" ? " (" + (c.unit === "deg" ? "°" : c.unit) + ")" : "");
        let input;
        if (c.kind === "select") {
          input = mk("select", "pk-select", row);
          c.values.forEach((v, j) => { const o = document.createElement("option"); o.value = j; o.textContent = v; input.appendChild(o); });
        } else {
          input = mk("input", "pk-slider", row);
          input.type = "range"; input.min = 0; input.max = c.values.length - 1; input.step = 1;
        }
        input.value = this.pos[i];
        input.name = c.name;
        input.setAttribute("aria-label", c.label);
        const value = mk("output", "pk-control-value", row);
        input.addEventListener("input", () => { this.pos[i] = Number(input.value); this.update(); });
        input.addEventListener("change", () => { this.pos[i] = Number(input.value); this.update(); });
        return { input, value };
      });
      const wrap = mk("div", "pk-canvas-wrap");
      this.canvas = mk("canvas", "pk-canvas", wrap);
      this.canvas.setAttribute("role", "img");
      this.readout = mk("div", "pk-readout");
      this.readout.textContent = "Hover over the map for the pose and the value.";
      this.stats = mk("div", "pk-stats");
      const rr = mk("div", "pk-rerun");
      rr.appendChild(document.createTextNode(m.local_label || "Re-run with these values: "));
      this.rerun = mk("code", "pk-rerun-command", rr);
      const note = mk("div", "pk-note");
      note.textContent = "Precomputed by pkmlib (pkmlib/explore) at " + m.resolution + "." + (m.fixed ? " Fixed: " + m.fixed + "." : "");
      this.canvas.addEventListener("mousemove", (ev) => this.hover(ev));
      this.canvas.addEventListener("mouseleave", () => { this.hoverAt = null; this.draw(); });
    }
    fieldIndex() { const i = this.controls.findIndex((c) => c.field); return i < 0 ? 0 : this.pos[i]; }
    key() { return this.controls.map((c, i) => c.field ? null : this.pos[i]).filter((v) => v !== null).join("_"); }
    atPaper() { return this.controls.every((c, i) => c.paper === null || c.paper === undefined || c.values[this.pos[i]] === c.paper); }
    paramText() {
      return this.controls.filter((c) => !c.field).map((c, i) => {
        const j = this.controls.indexOf(c);
        return c.label + " = " + withUnit(shown(c, c.values[this.pos[j]]), c.unit);
      }).join(", ");
    }
    async update() {
      const m = this.m;
      this.controls.forEach((c, i) => {
        const v = c.values[this.pos[i]];
        this.inputs[i].value.textContent = typeof v === "string" ? "" : withUnit(fmtControl(c, v), c.unit);
        this.inputs[i].input.value = this.pos[i];
      });
      const diff = this.controls.filter((c, i) => c.paper !== null && c.paper !== undefined && c.values[this.pos[i]] !== c.paper);
      this.banner.hidden = diff.length === 0;
      this.el.dataset.paper = diff.length === 0 ? "true" : "false";
      this.banner.textContent = diff.length === 0 ? "" : "Not the paper's parameters: " + diff.map((c) => {
        const j = this.controls.indexOf(c);
        return c.label + " = " + withUnit(shown(c, c.values[this.pos[j]]), c.unit) + " (paper " + withUnit(shown(c, c.paper), c.unit) + ")";
      }).join(", ") + ".";
      const params = this.controls.filter((c) => c.param).map((c) => {
        const j = this.controls.indexOf(c);
        return "-p " + c.param + " " + fmtControl(c, c.values[this.pos[j]]);
      }).join(" ");
      const key = this.key();
      this.rerun.textContent = (m.local && m.local[key]) ? m.local[key] : (m.rerun && m.rerun[key]) ? m.rerun[key] : "make rerun NB=" + m.notebook + ' PARAMS="' + params + '"';
      this.el.dataset.loading = "true";
      const chunk = await loadChunk(this.base, m.id, key);
      if (key !== this.key()) return;  // moved on meanwhile
      this.chunk = chunk;
      this.field = m.fields[this.fieldIndex()];
      this.values = chunk[this.field.name].values;
      this.vrange = chunk[this.field.name];
      this.inside = chunk.inside ? chunk.inside.values : null;
      this.summarise();
      this.draw();
      this.el.dataset.loading = "false";
      this.el.dataset.key = key;
    }
    summarise() {
      const v = this.values, f = this.field;
      let lo = Infinity, hi = -Infinity, n = 0, neg = 0, pos = 0, gap = 0;
      for (let i = 0; i < v.length; i++) {
        const x = v[i];
        if (isFinite(x)) { n++; if (x < lo) lo = x; if (x > hi) hi = x; if (x < 0) neg++; else if (x > 0) pos++; }
        else if (this.inside && this.inside[i] > 0) gap++;
      }
      this.lo = lo; this.hi = hi;
      const m = this.m, d = f.digits || 4;
      let title = m.title.replace("{figure}", f.figure).replace("{label}", f.label) + " at " + this.paramText();
      let stats;
      if (n === 0) stats = f.empty || "no point of the grid is inside the workspace at these parameters";
      else if (f.scale === "sign") stats = f.symbol + " < 0" + (f.sign_labels ? " (" + f.sign_labels[0] + ")" : "") + " at " + neg + " points, > 0" + (f.sign_labels ? " (" + f.sign_labels[1] + ")" : "") + " at " + pos + " points of " + n;
      else stats = f.symbol + " from " + fmt(lo, d) + " to " + fmt(hi, d) + (f.unit ? " " + f.unit : "") + " over " + n + " " + (f.over || "points");
      if (f.total) {  // counts per cell: their sum (e.g. the points of a section's slab)
        let sum = 0;
        for (let i = 0; i < v.length; i++) if (isFinite(v[i])) sum += v[i];
        stats += "; " + sum + " " + f.unit + " in all";
        this.stats.dataset.total = sum;
      }
      if (f.area) {  // a sign map whose positive points each stand for a cell: their area (e.g. the atlas's value)
        const area = Number((pos * f.area.cell).toFixed(6));
        stats += "; " + f.area.label + " " + area + " " + f.area.unit;
        this.stats.dataset.area = area;
      }
      if (n && f.clip) stats += "; colour clipped at the " + f.clip + ", " + fmt(this.vrange.vmax, d) + " " + f.unit;
      if (f.gap) stats += "; gap (red, the drives cannot hold the load): " + gap + " points";
      this.title.textContent = title;
      this.stats.textContent = stats;
      this.stats.dataset.min = lo; this.stats.dataset.max = hi; this.stats.dataset.count = n;
      if (f.gap) this.stats.dataset.gap = gap;
      this.canvas.setAttribute("aria-label", title);
    }
    rowsShown() {
      // the static figures' y limits: the rows with a workspace point, +- crop_y
      const m = this.m, nx = m.x.n, ny = m.y.n, v = this.values;
      let j0 = ny, j1 = -1;
      for (let j = 0; j < ny; j++) for (let i = 0; i < nx; i++) {
        const k = j * nx + i;
        if (isFinite(v[k]) || (this.inside && this.inside[k] > 0)) { if (j < j0) j0 = j; if (j > j1) j1 = j; break; }
      }
      if (j1 < 0 || m.crop_y === undefined) return [m.y.start - m.y.step / 2, m.y.start + (ny - 0.5) * m.y.step];
      const y0 = m.y.start + j0 * m.y.step - m.crop_y, y1 = m.y.start + j1 * m.y.step + m.crop_y;
      return [Math.max(y0, m.y.start - m.y.step / 2), Math.min(y1, m.y.start + (ny - 0.5) * m.y.step)];
    }
    color(x) {
      const f = this.field, c = f.colors, r = this.vrange;
      if (f.scale === "sign") return x < 0 ? c[0] : (x > 0 ? c[1] : null);
      let t;
      if (f.scale === "log") t = x > 0 ? (Math.log(x) - Math.log(r.vmin)) / (Math.log(r.vmax) - Math.log(r.vmin)) : NaN;
      else t = (x - r.vmin) / (r.vmax - r.vmin);
      if (!isFinite(t)) t = (r.vmax === r.vmin) ? 0.5 : t;
      if (!isFinite(t)) return null;
      t = Math.min(1, Math.max(0, t));
      return c[Math.min(c.length - 1, Math.floor(t * c.length))];
    }
    layout() {
      const w = Math.max(300, this.canvas.parentElement.clientWidth || 600);
      const h = Math.round(Math.min(520, Math.max(240, w * 0.5)));
      const narrow = w < 520;  // a phone: the colour bar goes below the map, across
      return { w, h, l: narrow ? 52 : 64, r: narrow ? 14 : 92, t: 10, b: narrow ? 44 + 64 : 44, below: narrow };
    }
    draw() {
      if (!this.values) return;
      const m = this.m, L = this.layout(), cv = this.canvas, dpr = window.devicePixelRatio || 1;
      const yrShown = this.rowsShown();
      if (!L.below) L.r = this.colorbarSpace(cv.getContext("2d"), L.h - L.t - L.b);  // the colour bar, its ticks and its label fit
      if (m.equal_aspect) {  // both axes in the same unit: one mm is as long across as up
        const xr0 = m.x.n * m.x.step, pw0 = L.w - L.l - L.r;
        L.h = Math.round(L.t + L.b + Math.min(640, pw0 * (yrShown[1] - yrShown[0]) / xr0));
      }
      cv.width = L.w * dpr; cv.height = L.h * dpr; cv.style.width = L.w + "px"; cv.style.height = L.h + "px";
      const g = cv.getContext("2d");
      g.setTransform(dpr, 0, 0, dpr, 0, 0);
      g.clearRect(0, 0, L.w, L.h);
      const nx = m.x.n, ny = m.y.n;
      const xr = [m.x.start - m.x.step / 2, m.x.start + (nx - 0.5) * m.x.step];
      const yr = yrShown;
      this.view = { L, xr, yr };
      const pw = L.w - L.l - L.r, ph = L.h - L.t - L.b;
      // the map at grid resolution, then scaled without smoothing (each node one cell, "nearest")
      const off = document.createElement("canvas");
      off.width = nx; off.height = ny;
      const og = off.getContext("2d"), img = og.createImageData(nx, ny);
      const cache = {};
      for (let j = 0; j < ny; j++) for (let i = 0; i < nx; i++) {
        const k = j * nx + i, x = this.values[k];
        let col = isFinite(x) ? this.color(x) : null;
        if (!isFinite(x) && this.field.gap && this.inside && this.inside[k] > 0) col = "#d62728";
        if (!col) continue;
        const rgb = cache[col] || (cache[col] = [parseInt(col.slice(1, 3), 16), parseInt(col.slice(3, 5), 16), parseInt(col.slice(5, 7), 16)]);
        const o = ((ny - 1 - j) * nx + i) * 4;
        img.data[o] = rgb[0]; img.data[o + 1] = rgb[1]; img.data[o + 2] = rgb[2]; img.data[o + 3] = 255;
      }
      og.putImageData(img, 0, 0);
      g.save();
      g.beginPath(); g.rect(L.l, L.t, pw, ph); g.clip();
      g.imageSmoothingEnabled = false;
      const yTop = m.y.start + (ny - 0.5) * m.y.step, yBot = m.y.start - m.y.step / 2;
      const sy = ph / (yr[1] - yr[0]);
      g.drawImage(off, L.l, L.t - (yTop - yr[1]) * sy, pw, (yTop - yBot) * sy);
      if (this.hoverAt) {
        const [hx, hy] = this.toPixel(this.hoverAt[0], this.hoverAt[1]);
        g.strokeStyle = "#000"; g.lineWidth = 1;
        g.beginPath(); g.arc(hx, hy, 5, 0, 2 * Math.PI); g.stroke();
      }
      g.restore();
      g.strokeStyle = "#333"; g.lineWidth = 1; g.strokeRect(L.l + 0.5, L.t + 0.5, pw, ph);
      g.fillStyle = "#222"; g.font = "12px sans-serif";
      g.textAlign = "center"; g.textBaseline = "top";
      for (const t of niceTicks(xr[0], xr[1], Math.max(3, Math.floor(pw / 70)))) {
        const px = L.l + (t - xr[0]) / (xr[1] - xr[0]) * pw;
        g.fillRect(px, L.t + ph, 1, 4); g.fillText(tickText(t), px, L.t + ph + 6);
      }
      g.fillText(m.x.label + ", " + m.x.unit, L.l + pw / 2, L.t + ph + 24);
      g.textAlign = "right"; g.textBaseline = "middle";
      for (const t of niceTicks(yr[0], yr[1], Math.max(3, Math.floor(ph / 45)))) {
        const py = L.t + ph - (t - yr[0]) / (yr[1] - yr[0]) * ph;
        g.fillRect(L.l - 4, py, 4, 1); g.fillText(tickText(t), L.l - 6, py);
      }
      g.save(); g.translate(12, L.t + ph / 2); g.rotate(-Math.PI / 2); g.textAlign = "center";
      g.fillText(m.y.label + ", " + m.y.unit, 0, 0); g.restore();
      if (L.below) this.drawColorbarBelow(g, L.l, L.t + ph + 44 + 4, pw, 12);
      else this.drawColorbar(g, L.w - L.r + 12, L.t, 14, ph);
    }
    /** The colour bar's tick values (in the bar's own scale: log10 for a log map) and texts. */
    colorbarTicks(h) {
      const f = this.field, r = this.vrange;
      if (f.scale === "sign" || r.vmin === undefined || r.vmin === null) return { ticks: [], texts: [] };
      const lg = f.scale === "log";
      const a = lg ? Math.log10(r.vmin) : r.vmin, b = lg ? Math.log10(r.vmax) : r.vmax;
      let ticks;
      if (lg) { ticks = []; for (let e = Math.ceil(a); e <= Math.floor(b); e++) ticks.push(e); }
      else ticks = niceTicks(a, b, Math.max(2, Math.floor(h / 40)));
      return { ticks, texts: ticks.map((t) => lg ? "1e" + t : tickText(t)), a, b };
    }
    /** Width (CSS px) right of the plot that the colour bar needs: gap, bar, ticks, their widest text, label. */
    colorbarSpace(g, h) {
      g.font = "12px sans-serif";
      const f = this.field;
      const texts = f.scale === "sign" ? [] : this.colorbarTicks(h).texts;
      const tw = f.scale === "sign" ? 14 : Math.max(0, ...texts.map((t) => g.measureText(t).width));
      this.cbTickWidth = tw;
      return Math.ceil(12 + 14 + 5 + tw + 6 + 14 + 4);
    }
    drawColorbar(g, x0, y0, w, h) {
      const f = this.field, r = this.vrange, c = f.colors;
      g.textAlign = "left"; g.textBaseline = "middle"; g.fillStyle = "#222";
      if (f.scale === "sign") {
        g.fillStyle = c[0]; g.fillRect(x0, y0 + h / 2, w, h / 2);
        g.fillStyle = c[1]; g.fillRect(x0, y0, w, h / 2);
        const lab = f.sign_labels || ["< 0", "> 0"];
        g.fillStyle = "#222";
        g.save(); g.translate(x0 + w + 12, y0 + h / 4); g.rotate(-Math.PI / 2); g.textAlign = "center"; g.fillText(lab[1], 0, 0); g.restore();
        g.save(); g.translate(x0 + w + 12, y0 + 3 * h / 4); g.rotate(-Math.PI / 2); g.textAlign = "center"; g.fillText(lab[0], 0, 0); g.restore();
      } else if (r.vmin !== undefined && r.vmin !== null) {
        for (let k = 0; k < h; k++) { g.fillStyle = c[Math.min(c.length - 1, Math.floor((1 - k / h) * c.length))]; g.fillRect(x0, y0 + k, w, 1.5); }
        g.fillStyle = "#222";
        const { ticks, texts, a, b } = this.colorbarTicks(h);
        ticks.forEach((t, k) => {
          const py = y0 + h - (t - a) / ((b - a) || 1) * h;
          g.fillRect(x0 + w, py, 3, 1);
          g.fillText(texts[k], x0 + w + 5, py);
        });
      }
      g.strokeStyle = "#333"; g.strokeRect(x0 + 0.5, y0 + 0.5, w, h);
      // the label, turned, right of the widest tick text; smaller type if it is longer than the canvas is high
      const label = f.symbol + (f.unit ? ", " + f.unit : "");
      const room = h + 16, lw = g.measureText(label).width;  // it is centred on the bar, L.t above it
      if (lw > room) g.font = Math.max(9, Math.floor(12 * room / lw)) + "px sans-serif";
      const lx = x0 + w + 5 + (this.cbTickWidth || 0) + 6 + 7, fs = parseFloat(g.font);
      g.save(); g.translate(lx, y0 + h / 2); g.rotate(-Math.PI / 2); g.textAlign = "center";
      g.fillText(label, 0, 0); g.restore();
      // where the turned label lies on the canvas (CSS px; for the tests: it must be inside)
      const half = g.measureText(label).width / 2;
      this.view.colorbarLabel = { left: lx - fs / 2, right: lx + fs / 2, top: y0 + h / 2 - half, bottom: y0 + h / 2 + half, width: this.view.L.w, height: this.view.L.h };
      g.font = "12px sans-serif";
    }
    /** The colour bar across, below the map (narrow screens): bar, tick texts under it, the label under them. */
    drawColorbarBelow(g, x0, y0, w, h) {
      const f = this.field, r = this.vrange, c = f.colors, L = this.view.L;
      g.font = "12px sans-serif"; g.fillStyle = "#222"; g.textAlign = "center"; g.textBaseline = "top";
      if (f.scale === "sign") {
        g.fillStyle = c[0]; g.fillRect(x0, y0, w / 2, h);
        g.fillStyle = c[1]; g.fillRect(x0 + w / 2, y0, w / 2, h);
        const lab = f.sign_labels || ["< 0", "> 0"];
        g.fillStyle = "#222";
        g.fillText(lab[0], x0 + w / 4, y0 + h + 4); g.fillText(lab[1], x0 + 3 * w / 4, y0 + h + 4);
      } else if (r.vmin !== undefined && r.vmin !== null) {
        for (let k = 0; k < w; k++) { g.fillStyle = c[Math.min(c.length - 1, Math.floor(k / w * c.length))]; g.fillRect(x0 + k, y0, 1.5, h); }
        g.fillStyle = "#222";
        const { ticks, texts, a, b } = this.colorbarTicks(w * 2 / 3);
        ticks.forEach((t, k) => {
          const px = x0 + (t - a) / ((b - a) || 1) * w;
          g.fillRect(px, y0 + h, 1, 3);
          g.fillText(texts[k], px, y0 + h + 4);
        });
      }
      g.strokeStyle = "#333"; g.strokeRect(x0 + 0.5, y0 + 0.5, w, h);
      const label = f.symbol + (f.unit ? ", " + f.unit : ""), room = L.w - 4, lw = g.measureText(label).width;
      if (lw > room) g.font = Math.max(9, Math.floor(12 * room / lw)) + "px sans-serif";
      const cx = Math.min(Math.max(x0 + w / 2, g.measureText(label).width / 2 + 2), L.w - g.measureText(label).width / 2 - 2);
      const ly = y0 + h + 22, half = g.measureText(label).width / 2, fs = parseFloat(g.font);
      g.fillText(label, cx, ly);
      this.view.colorbarLabel = { left: cx - half, right: cx + half, top: ly, bottom: ly + fs, width: L.w, height: L.h };
      g.font = "12px sans-serif";
    }
    toPixel(x, y) {
      const { L, xr, yr } = this.view, pw = L.w - L.l - L.r, ph = L.h - L.t - L.b;
      return [L.l + (x - xr[0]) / (xr[1] - xr[0]) * pw, L.t + ph - (y - yr[0]) / (yr[1] - yr[0]) * ph];
    }
    /** Canvas offset (CSS pixels from its top-left corner) of the grid node nearest (x, y). */
    pixelFor(x, y) {
      const { L } = this.view, p = this.toPixel(x, y);
      const inPlot = p[0] >= L.l && p[0] <= L.w - L.r && p[1] >= L.t && p[1] <= L.h - L.b;
      return inPlot ? p : null;
    }
    nodeAt(px, py) {
      const m = this.m, { L, xr, yr } = this.view, pw = L.w - L.l - L.r, ph = L.h - L.t - L.b;
      if (px < L.l || px > L.l + pw || py < L.t || py > L.t + ph) return null;
      const x = xr[0] + (px - L.l) / pw * (xr[1] - xr[0]);
      const y = yr[0] + (L.t + ph - py) / ph * (yr[1] - yr[0]);
      const i = Math.round((x - m.x.start) / m.x.step), j = Math.round((y - m.y.start) / m.y.step);
      if (i < 0 || j < 0 || i >= m.x.n || j >= m.y.n) return null;
      return [i, j];
    }
    hover(ev) {
      if (!this.view) return;
      const rect = this.canvas.getBoundingClientRect();
      const node = this.nodeAt(ev.clientX - rect.left, ev.clientY - rect.top);
      if (!node) { this.readout.textContent = "Hover over the map for the pose and the value."; return; }
      this.showNode(node[0], node[1]);
    }
    showNode(i, j) {
      const m = this.m, f = this.field, k = j * m.x.n + i, v = this.values[k];
      const x = m.x.start + i * m.x.step, y = m.y.start + j * m.y.step;
      this.hoverAt = [x, y];
      let val;
      if (isFinite(v)) {
        val = f.symbol + " = " + fmt(v, f.digits || 4) + (f.unit ? " " + f.unit : "");
        if (f.scale === "sign") val += f.sign_labels ? " (" + f.sign_labels[v < 0 ? 0 : 1] + ")" : (v < 0 ? " (< 0)" : " (> 0)");
      } else if (f.gap && this.inside && this.inside[k] > 0) val = "gap: the drives cannot hold the load";
      else val = f.empty || "outside the workspace";
      this.readout.textContent = m.x.label + " = " + withUnit(x.toFixed(m.x.digits), m.x.unit) + ", " +
        m.y.label + " = " + withUnit(y.toFixed(m.y.digits), m.y.unit) + ": " + val + "  (" + this.paramText() + ")";
      this.readout.dataset.value = isFinite(v) ? v : "NaN";
      this.readout.dataset.x = x; this.readout.dataset.y = y;
      this.draw();
    }
  }

  // ---------- an affine map of sliders to outputs, computed exactly on the page ----------
  class LinearFigure {
    constructor(el, manifest) {
      this.el = el; this.m = manifest;
      this.controls = manifest.controls;
      this.values = this.controls.map((c) => c.paper);
      this.build();
      this.update();
      window.addEventListener("resize", () => this.draw());
    }
    build() {
      const el = this.el, m = this.m;
      el.innerHTML = "";
      el.classList.add("pk-ready");
      const mk = (tag, cls, parent) => { const e = document.createElement(tag); if (cls) e.className = cls; (parent || el).appendChild(e); return e; };
      this.title = mk("div", "pk-title");
      this.banner = mk("div", "pk-banner");
      this.banner.setAttribute("role", "status");
      const box = mk("div", "pk-controls");
      this.inputs = this.controls.map((c, i) => {
        const row = mk("label", "pk-control", box);
        row.dataset.name = c.name;
        mk("span", "pk-control-label", row).textContent = c.label + " (" + c.unit + ", along " + c.axis + ")";
        const input = mk("input", "pk-slider", row);
        input.type = "range"; input.min = c.min; input.max = c.max; input.step = c.step; input.value = c.paper;
        input.name = c.name; input.setAttribute("aria-label", c.label);
        const value = mk("output", "pk-control-value", row);
        const on = () => { this.values[i] = Number(input.value); this.update(); };
        input.addEventListener("input", on); input.addEventListener("change", on);
        return { input, value };
      });
      const wrap = mk("div", "pk-canvas-wrap");
      this.canvas = mk("canvas", "pk-canvas", wrap);
      this.canvas.setAttribute("role", "img");
      this.table = mk("table", "pk-values");
      this.readout = mk("div", "pk-readout");
      this.readout.textContent = "Hover over a bar for its value.";
      const rr = mk("div", "pk-rerun");
      rr.appendChild(document.createTextNode("Re-run with these values: "));
      this.rerun = mk("code", "pk-rerun-command", rr);
      mk("div", "pk-note").textContent = "Computed on the page: " + m.resolution + ". Fixed: " + m.fixed + ".";
      this.canvas.addEventListener("mousemove", (ev) => this.hover(ev));
    }
    outputs() {
      const G = this.m.G, c = this.m.c, P = this.values;
      return G.map((row, k) => row.reduce((s, g, i) => s + g * P[i], 0) + c[k]);
    }
    num(v) { const t = v.toFixed(this.m.digits); return /^-0\.?0*$/.test(t) ? t.slice(1) : t; }
    update() {
      const m = this.m;
      this.controls.forEach((c, i) => { this.inputs[i].value.textContent = fmtControl(c, this.values[i]) + " N"; this.inputs[i].input.value = this.values[i]; });
      const Ptext = "(" + this.values.map((v, i) => fmtControl(this.controls[i], v)).join(", ") + ") N";
      this.title.textContent = m.title + " at P = " + Ptext;
      const paper = this.controls.every((c, i) => this.values[i] === c.paper);
      this.el.dataset.paper = paper ? "true" : "false";
      this.banner.hidden = paper;
      this.banner.textContent = paper ? "" : "Not the paper's parameters: P = " + Ptext + " (paper (" + this.controls.map((c) => fmtControl(c, c.paper)).join(", ") + ") N).";
      this.rerun.textContent = "make rerun NB=" + m.notebook + " PARAMS='-p " + m.param + ' "[' + this.values.map((v, i) => fmtControl(this.controls[i], v)).join(", ") + "]\"'";
      this.out = this.outputs();
      this.table.innerHTML = "";
      m.outputs.forEach((o, k) => {  // one row per output: name, value, unit (fits a phone)
        const tr = document.createElement("tr");
        const th = document.createElement("th"); th.textContent = o.label; tr.appendChild(th);
        const td = document.createElement("td"); td.className = "pk-value"; td.textContent = this.num(this.out[k]);
        td.dataset.name = o.name; td.dataset.value = this.out[k]; tr.appendChild(td);
        const tu = document.createElement("td"); tu.textContent = o.unit; tr.appendChild(tu);
        this.table.appendChild(tr);
      });
      this.draw();
      this.el.dataset.loading = "false";
    }
    layout() {
      const w = Math.max(260, this.canvas.parentElement.clientWidth || 600), stacked = w < 560;
      const ph = Math.round(Math.min(360, Math.max(200, (stacked ? w * 0.6 : w * 0.4))));
      return { w, h: stacked ? 2 * ph : ph, ph, stacked, t: 18, b: 30 };
    }
    draw() {
      const L = this.layout(), cv = this.canvas, dpr = window.devicePixelRatio || 1, m = this.m;
      cv.width = L.w * dpr; cv.height = L.h * dpr; cv.style.width = L.w + "px"; cv.style.height = L.h + "px";
      const g = cv.getContext("2d");
      g.setTransform(dpr, 0, 0, dpr, 0, 0); g.clearRect(0, 0, L.w, L.h);
      g.font = "12px sans-serif";
      this.bars = [];
      const panels = [[0, 3, "linear acceleration, " + m.outputs[0].unit], [3, 6, "angular acceleration, " + m.outputs[3].unit]];
      const pw = L.stacked ? L.w : L.w / 2;
      panels.forEach(([a, b, label], n) => {  // side by side, or one above the other on a narrow screen
        const col = L.stacked ? 0 : n, top = L.stacked ? n * L.ph : 0;
        const x0 = col * pw + 56, x1 = (col + 1) * pw - 12, y0 = top + L.t, y1 = top + L.ph - L.b;
        const vals = this.out.slice(a, b);
        // a symmetric range that holds the paper's values too, so bars can be compared when moving
        let lim = 1.2 * Math.max(1e-9, ...vals.map(Math.abs));  // room for the value labels
        const ticks = niceTicks(-lim, lim, 4); const step = ticks.length > 1 ? ticks[1] - ticks[0] : lim;
        lim = Math.max(Math.ceil(lim / step) * step, step);
        const ys = (v) => y0 + (lim - v) / (2 * lim) * (y1 - y0);
        g.strokeStyle = "#333"; g.strokeRect(x0 + 0.5, y0 + 0.5, x1 - x0, y1 - y0);
        g.fillStyle = "#222"; g.textAlign = "right"; g.textBaseline = "middle";
        for (const t of niceTicks(-lim, lim, 4)) { g.fillRect(x0 - 4, ys(t), 4, 1); g.fillText(tickText(t), x0 - 6, ys(t)); }
        g.fillStyle = "#999"; g.fillRect(x0, ys(0), x1 - x0, 1);
        const bw = (x1 - x0) / 3;
        vals.forEach((v, k) => {
          const bx = x0 + k * bw + bw * 0.2, top = Math.min(ys(0), ys(v)), hgt = Math.abs(ys(v) - ys(0));
          g.fillStyle = v >= 0 ? "#1f77b4" : "#d62728"; g.fillRect(bx, top, bw * 0.6, Math.max(hgt, 1));
          this.bars.push({ x: bx, y: top, w: bw * 0.6, h: Math.max(hgt, 4), k: a + k });
          g.fillStyle = "#222"; g.textAlign = "center"; g.textBaseline = "top";
          g.fillText(m.outputs[a + k].label, bx + bw * 0.3, y1 + 4);
          g.textBaseline = v >= 0 ? "bottom" : "top";
          g.fillText(this.num(v), bx + bw * 0.3, v >= 0 ? top - 2 : top + hgt + 2);
        });
        g.textAlign = "left"; g.textBaseline = "top"; g.fillStyle = "#222";
        g.fillText(label, x0 + 4, top + 2);
      });
    }
    hover(ev) {
      const r = this.canvas.getBoundingClientRect(), x = ev.clientX - r.left, y = ev.clientY - r.top;
      const bar = (this.bars || []).find((b) => x >= b.x && x <= b.x + b.w && y >= b.y - 6 && y <= b.y + b.h + 6);
      if (!bar) return;
      const o = this.m.outputs[bar.k];
      this.readout.textContent = o.label + " = " + this.num(this.out[bar.k]) + " " + o.unit + " at P = (" + this.values.map((v, i) => fmtControl(this.controls[i], v)).join(", ") + ") N";
    }
  }

  // ---------- data ----------
  function loadManifest(base, id) { return loadScript(base + "/manifest.js", id).then(() => store[id]); }
  async function loadChunk(base, id, key) {
    const name = id + "/" + key;
    await loadScript(base + "/" + key + ".js", name);
    const raw = store[name];
    if (!raw.decoded) {
      raw.decoded = (async () => {
        const out = {};
        for (const [k, f] of Object.entries(raw.payload)) out[k] = Object.assign({}, f, { values: await decode(f.data) });
        return out;
      })();
    }
    return raw.decoded;
  }

  const api = {
    started: true,
    figures: [],
    kinds: { map: MapFigure, linear: LinearFigure },
    manifest(id, m) { store[id] = m; slot(id).resolve(m); },
    data(id, key, payload) { store[id + "/" + key] = { payload }; slot(id + "/" + key).resolve(); },
    mount(el) {
      if (el.pkFigure || el.dataset.mounting) return;
      el.dataset.mounting = "true";
      const base = el.dataset.src;
      const id = base.replace(/\/+$/, "").split("/").pop();
      loadManifest(base, id).then((m) => {
        const Kind = api.kinds[m.kind || "map"];
        el.pkFigure = new Kind(el, m, base);
        api.figures.push(el.pkFigure);
      }).catch((e) => { console.error("pk-explore:", e); el.textContent = "The interactive figure could not be loaded."; });
    },
    mountAll() { document.querySelectorAll(".pk-explore").forEach((el) => api.mount(el)); },
    fmt, withUnit, fmtControl, niceTicks, decode, loadChunk,
  };
  window.pkExplore = api;
  // lazily: each figure's manifest and data load when it comes near the viewport
  function start() {
    const els = document.querySelectorAll(".pk-explore");
    if ("IntersectionObserver" in window) {
      const io = new IntersectionObserver((entries) => entries.forEach((e) => { if (e.isIntersecting) { io.unobserve(e.target); api.mount(e.target); } }), { rootMargin: "400px" });
      els.forEach((el) => io.observe(el));
    } else els.forEach((el) => api.mount(el));
  }
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start); else start();
})();
