// The 1D transfer function editor: control points (value, opacity,
// colour) drawn over the volume's histogram; its text is vol-render's
// transfer function format (domain, then one `point` line per point).
"use strict";

class TfEditor {
  constructor(canvas, colourInput, onChange) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.colour = colourInput;
    this.onChange = onChange;
    this.points = [];
    this.selected = -1;
    this.drag = -1;
    this.lo = 0;
    this.hi = 1;
    this.counts = [];
    // Kept as loaded: the domain and reference step the text states,
    // and the constant ranges (drawn, not edited).
    this.domain = null;
    this.step = null;
    this.ranges = [];
    canvas.addEventListener("pointerdown", (e) => this.down(e));
    canvas.addEventListener("pointermove", (e) => this.move(e));
    canvas.addEventListener("pointerup", () => this.up());
    canvas.addEventListener("dblclick", (e) => this.add(e));
    canvas.addEventListener("contextmenu", (e) => { e.preventDefault(); this.remove(e); });
    colourInput.addEventListener("input", () => this.recolour());
  }

  // The value range and histogram the editor spans; a grey ramp to start.
  setHistogram(lo, hi, counts) {
    this.lo = lo;
    this.hi = hi > lo ? hi : lo + 1;
    this.counts = counts || [];
    this.load(null);
  }

  // Start from transfer function `tf` as the server describes it
  // (domain, step, points [v, r, g, b, a], ranges [lo, hi, r, g, b, a]);
  // null: a grey ramp over the histogram's range.
  load(tf) {
    if (!tf) {
      this.domain = null;
      this.step = null;
      this.ranges = [];
      this.points = [
        { v: this.lo, a: 0, c: [255, 255, 255] },
        { v: this.hi, a: 0.5, c: [255, 255, 255] },
      ];
    } else {
      this.domain = tf.domain;
      this.step = tf.step;
      this.ranges = tf.ranges.map((r) => r.slice());
      this.points = tf.points.map(([v, r, g, b, a]) => ({ v, a, c: [r, g, b] }));
    }
    this.selected = -1;
    this.drag = -1;
    this.draw();
  }

  x(v) { return ((v - this.lo) / (this.hi - this.lo)) * this.canvas.width; }
  y(a) { return (1 - a) * (this.canvas.height - 8) + 4; }
  at(e) {
    const r = this.canvas.getBoundingClientRect();
    const px = ((e.clientX - r.left) / r.width) * this.canvas.width;
    const py = ((e.clientY - r.top) / r.height) * this.canvas.height;
    const v = this.lo + (px / this.canvas.width) * (this.hi - this.lo);
    const a = Math.min(1, Math.max(0, 1 - (py - 4) / (this.canvas.height - 8)));
    return { px, py, v, a };
  }
  nearest(p) {
    let best = -1, dist = 12;
    this.points.forEach((q, i) => {
      const d = Math.hypot(this.x(q.v) - p.px, this.y(q.a) - p.py);
      if (d < dist) { dist = d; best = i; }
    });
    return best;
  }
  down(e) {
    const i = this.nearest(this.at(e));
    this.selected = i;
    this.drag = i;
    if (i >= 0) {
      const c = this.points[i].c;
      this.colour.value = "#" + c.map((v) => v.toString(16).padStart(2, "0")).join("");
      this.canvas.setPointerCapture(e.pointerId);
    }
    this.draw();
  }
  move(e) {
    if (this.drag < 0) return;
    const p = this.at(e);
    const q = this.points[this.drag];
    q.v = Math.min(this.hi, Math.max(this.lo, p.v));
    q.a = p.a;
    this.sort();
    this.draw();
    this.onChange(true);
  }
  up() {
    if (this.drag >= 0) this.onChange(false);
    this.drag = -1;
  }
  add(e) {
    const p = this.at(e);
    this.points.push({ v: p.v, a: p.a, c: [255, 255, 255] });
    this.selected = this.points.length - 1;
    this.sort();
    this.draw();
    this.onChange(false);
  }
  remove(e) {
    const i = this.nearest(this.at(e));
    if (i >= 0 && this.points.length > (this.ranges.length ? 0 : 2)) {
      this.points.splice(i, 1);
      this.selected = -1;
      this.draw();
      this.onChange(false);
    }
  }
  recolour() {
    if (this.selected < 0) return;
    const h = this.colour.value;
    this.points[this.selected].c = [1, 3, 5].map((i) => parseInt(h.slice(i, i + 2), 16));
    this.draw();
    this.onChange(false);
  }
  sort() {
    const sel = this.points[this.selected];
    const drag = this.points[this.drag];
    this.points.sort((p, q) => p.v - q.v);
    this.selected = this.points.indexOf(sel);
    this.drag = this.points.indexOf(drag);
  }

  // vol-render's transfer function text: the domain, step and ranges as
  // loaded, and the points. Loaded values are written as they came (the
  // shortest text of each f32, read back to the same f32), so the text
  // of an unedited function renders as the function did.
  text() {
    // Six digits when they name the same f32, else all of them.
    const n = (v) => {
      const r = Number(v.toPrecision(6));
      return Math.fround(r) === Math.fround(v) ? r : v;
    };
    const [lo, hi] = this.domain || [n(this.lo), n(this.hi)];
    const lines = [`domain ${lo} ${hi}`];
    if (this.step != null) lines.push(`step ${this.step}`);
    for (const r of this.ranges) lines.push(`range ${r.join(" ")}`);
    for (const p of this.points) {
      lines.push(`point ${n(p.v)} ${p.c[0]} ${p.c[1]} ${p.c[2]} ${n(p.a)}`);
    }
    return lines.join("\n") + "\n";
  }

  draw() {
    const { ctx, canvas } = this;
    const w = canvas.width, h = canvas.height;
    ctx.clearRect(0, 0, w, h);
    if (this.counts.length) {
      const top = Math.log1p(Math.max(...this.counts));
      ctx.fillStyle = "#3a4250";
      const bw = w / this.counts.length;
      this.counts.forEach((c, i) => {
        const bh = top > 0 ? (Math.log1p(c) / top) * h : 0;
        ctx.fillRect(i * bw, h - bh, Math.ceil(bw), bh);
      });
    }
    for (const [lo, hi, r, g, b, a] of this.ranges) {
      ctx.fillStyle = `rgba(${r},${g},${b},0.6)`;
      const x0 = this.x(lo), x1 = this.x(hi);
      ctx.fillRect(x0, this.y(a), Math.max(1, x1 - x0), h - this.y(a));
    }
    ctx.strokeStyle = "#ddd";
    ctx.beginPath();
    this.points.forEach((p, i) => {
      const f = i ? "lineTo" : "moveTo";
      ctx[f](this.x(p.v), this.y(p.a));
    });
    ctx.stroke();
    this.points.forEach((p, i) => {
      ctx.fillStyle = `rgb(${p.c.join(",")})`;
      ctx.strokeStyle = i === this.selected ? "#fd6" : "#000";
      ctx.lineWidth = 2;
      ctx.beginPath();
      ctx.arc(this.x(p.v), this.y(p.a), 5, 0, 2 * Math.PI);
      ctx.fill();
      ctx.stroke();
    });
    ctx.lineWidth = 1;
  }
}
window.TfEditor = TfEditor;
