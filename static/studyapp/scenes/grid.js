// What every grid domain's scene shares (plain ES module, no build step): a world of square cells
// seen from above, row 0 at the top, a robot moving one cell per row of its path every `dt` seconds.
//
// GridScene sizes the canvas (its buffer's aspect is the grid's, plus a strip under it for the
// "move k of n" label), interpolates the robot between cells at the display's frame rate, draws
// grid lines, dot and hatch patterns, words on marks, letters with a halo, the path line and the
// label, and plays a frame or the whole trail.  A domain's scene extends it and draws only its own
// world (drawWorld), marks over the path (drawMarks), the path if it is not one plain line
// (drawPath) and what it adds to the robot, a light disc with a dark outline (drawRobot, disc).  The player (../player.js) uses only the members of Scene:
// duration, mode, t, boxes, lastFrame, resize(), drawFrame(t), drawTrail(), redraw().

import { gettext, interpolate, ngettext } from "../i18n.js";
import { Layout, tag } from "../labels.js";
import { colors } from "../palette.js";

export const STRIP = 16;        // px kept free under the grid for the "move k of n" label
export const WORDS_FROM = 22;   // cells at least this wide (px) carry words; smaller ones are too small to read
// the palette colours this base draws with; a scene adds its own (camelCase: robotEdge is --scene-robot-edge)
const NAMES = ["grid", "path", "text", "robot", "robotEdge"];

export class GridScene {
  // cells: the world's (rows, cols) cell codes; names: the palette colours the domain's scene reads.
  constructor(canvas, env, robot, cells, names) {
    this.canvas = canvas;
    this.env = env;
    this.cells = cells;
    this.names = [...new Set([...NAMES, ...names])];
    this.robot = robot;        // [[col, row]...], first the start, last the end
    this.dt = env.dt;          // s per move
    this.duration = (robot.length - 1) * this.dt;
    this.mode = "frame";       // "frame" | "trail"
    this.t = 0;
    this.boxes = [];           // every label drawn last (labels.js), for the tests
    this.lastFrame = null;     // screen position drawn last: {robot: [x, y]}
    this.resize();
  }

  // Canvas buffer in device pixels, drawing in CSS px.  The canvas's width is the page's; its height
  // is the grid's at that width plus the label strip (set here), so the grid fills the canvas.
  resize() {
    const dpr = window.devicePixelRatio || 1;
    const rows = this.cells.length, cols = this.cells[0].length;
    const css = Math.round(this.canvas.clientWidth || this.canvas.width);
    const w = Math.max(120, css);
    const h = Math.round(w * rows / cols) + STRIP;
    const cssH = `${Math.round(h * css / w)}px`;  // a canvas narrower than the drawing shows it scaled down whole
    if (this.canvas.style.height !== cssH) this.canvas.style.height = cssH;
    if (this.canvas.width !== Math.round(w * dpr) || this.canvas.height !== Math.round(h * dpr)) {
      this.canvas.width = Math.round(w * dpr);
      this.canvas.height = Math.round(h * dpr);
    }
    this.w = w; this.h = h; this.dpr = dpr;
    // Square cells of whole px (crisp grid lines), the grid centred above the label strip.
    this.cell = Math.max(1, Math.floor(Math.min(w / cols, (h - STRIP) / rows)));
    this.ox = Math.floor((w - cols * this.cell) / 2);
    this.oy = Math.floor((h - STRIP - rows * this.cell) / 2);
  }

  begin() {
    this.resize();
    this.ctx = this.canvas.getContext("2d");
    this.ctx.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
    this.c = colors(this.names);
  }

  // Screen position (CSS px) of a cell's centre; fractional cells interpolate.
  toScreen(col, row) {
    return [this.ox + (col + 0.5) * this.cell, this.oy + (row + 0.5) * this.cell];
  }

  // The robot's cell position at fractional row index k (0 .. robot.length - 1).
  at(k) {
    const last = this.robot.length - 1;
    k = Math.max(0, Math.min(k, last));
    const i = Math.min(Math.floor(k), Math.max(0, last - 1)), f = last === 0 ? 0 : k - i;
    const a = this.robot[i], b = this.robot[Math.min(i + 1, last)];
    return [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f];
  }

  // The surround, then fill(kind, row, col, x, y) for every cell (x, y its top left, CSS px), then the
  // grid lines: 1 px on each cell boundary, the outer edge too, so the grid's edge stays visible on
  // any page background.
  drawCells(fill) {
    const { ctx, cell: s, c, cells } = this;
    ctx.fillStyle = c.grid;
    ctx.fillRect(0, 0, this.w, this.h);
    cells.forEach((line, r) => line.forEach((kind, col) => fill(kind, r, col, this.ox + col * s, this.oy + r * s)));
    const rows = cells.length, cols = cells[0].length;
    ctx.fillStyle = c.grid;
    for (let col = 0; col <= cols; col++) ctx.fillRect(this.ox + col * s - (col === cols ? 1 : 0), this.oy, 1, rows * s);
    for (let r = 0; r <= rows; r++) ctx.fillRect(this.ox, this.oy + r * s - (r === rows ? 1 : 0), cols * s, 1);
  }

  // Letters ([[[col, row], "S"], ...]) bold, with a halo of `halo`'s colour, so the line that starts
  // and ends in their cells does not cut through them (the robot, drawn last, may cover one).
  letters(marks, halo) {
    const { ctx, cell: s, c } = this;
    ctx.font = `700 ${Math.max(9, Math.round(0.5 * s))}px system-ui, sans-serif`;
    ctx.textAlign = "center"; ctx.textBaseline = "middle";
    ctx.lineJoin = "round";
    ctx.lineWidth = Math.max(2, s / 10);
    ctx.strokeStyle = halo;
    ctx.fillStyle = c.text;
    for (const [[col, r], letter] of marks) {
      const [x, y] = this.toScreen(col, r);
      ctx.strokeText(letter, x, y + 0.5);
      ctx.fillText(letter, x, y + 0.5);
    }
    ctx.textAlign = "start"; ctx.textBaseline = "alphabetic";
  }

  // Dots of `colour` on a regular grid that keeps clear of the cell's edges and corners.
  dots(x, y, colour) {
    const { ctx, cell: s } = this;
    // about 7 px apart at any size; the radius stops growing at 1.6 px so that on a large cell the dots
    // stay dots on the kind's colour instead of running together into a pale fill
    const n = Math.max(2, Math.round(s / 7)), step = s / n, r = Math.max(0.8, Math.min(s / 28, 1.6));
    ctx.fillStyle = colour;
    for (let i = 0; i < n; i++) {
      for (let j = 0; j < n; j++) {
        ctx.beginPath(); ctx.arc(x + (i + 0.5) * step, y + (j + 0.5) * step, r, 0, 2 * Math.PI); ctx.fill();
      }
    }
  }

  // A diagonal hatch of `colour` (the sheet's "////" and the legend's swatch), clipped to the cell.
  hatch(x, y, colour) {
    const { ctx, cell: s } = this;
    const step = Math.max(5, s / 4.5);   // sparse enough at small cells to keep a mark in the cell apart
    ctx.save();
    ctx.beginPath(); ctx.rect(x, y, s, s); ctx.clip();
    ctx.strokeStyle = colour;
    ctx.lineWidth = Math.max(0.8, s / 36);
    ctx.beginPath();
    for (let k = step / 2; k < 2 * s; k += step) { ctx.moveTo(x + k, y); ctx.lineTo(x + k - s, y + s); }
    ctx.stroke();
    ctx.restore();
  }

  // A word in `colour` centred on a mark (x, y its centre, CSS px).
  word(text, x, y, size, colour) {
    const ctx = this.ctx;
    ctx.font = `700 ${Math.round(size)}px system-ui, sans-serif`;
    ctx.fillStyle = colour;
    ctx.textAlign = "center"; ctx.textBaseline = "middle";
    ctx.fillText(text, x, y + 0.5);
    ctx.textAlign = "start"; ctx.textBaseline = "alphabetic";
  }

  // The path line from row index a to b (fractional), `width` px wide, in the current strokeStyle.
  strokePath(a, b, width) {
    if (b <= a) return;
    const ctx = this.ctx;
    const pts = [this.at(a)];
    for (let k = Math.floor(a) + 1; k < b; k++) pts.push(this.robot[k]);
    pts.push(this.at(b));
    ctx.beginPath();
    pts.map((p) => this.toScreen(p[0], p[1])).forEach(([x, y], i) => (i ? ctx.lineTo(x, y) : ctx.moveTo(x, y)));
    ctx.lineWidth = width;
    ctx.stroke();
  }

  // The path up to row index `to`: one line of the palette's path colour.
  drawPath(to) {
    this.ctx.strokeStyle = this.c.path;
    this.ctx.lineCap = "round"; this.ctx.lineJoin = "round";
    this.strokePath(0, to, Math.max(1.5, 0.06 * this.cell));
  }

  // The robot as every grid scene draws it: a light disc with a dark outline, centred at (x, y) CSS px.
  disc(x, y) {
    const { ctx, cell: s, c } = this;
    ctx.fillStyle = c.robot;
    ctx.strokeStyle = c.robotEdge;
    ctx.lineWidth = Math.max(1.5, s / 22);
    ctx.beginPath(); ctx.arc(x, y, 0.32 * s, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
  }

  // What a domain draws: its world at row index k (under the path), marks over the path, the robot
  // at k (returning its screen position; by default the disc alone).
  drawWorld(k) {}
  drawMarks() {}
  drawRobot(k) {
    const [x, y] = this.toScreen(...this.at(k));
    this.disc(x, y);
    return [x, y];
  }

  draw(k) {
    this.drawWorld(k);
    this.drawPath(k);
    this.drawMarks();
    return this.drawRobot(k);
  }

  // One animation frame at time t: the path so far and the robot where it is.
  drawFrame(t) {
    this.t = t;
    this.begin();
    const n = this.robot.length - 1;
    const k = Math.max(0, Math.min(t / this.dt, n));
    const robot = this.draw(k);
    this.label(interpolate(gettext("move %(k)s of %(n)s"), { k: Math.min(n, Math.ceil(k - 1e-9)), n }, true));
    this.lastFrame = { robot };
  }

  // A way a participant is showing (the show page): the whole path so far, labelled by its steps.
  drawShown() {
    this.t = this.duration;
    this.begin();
    const n = this.robot.length - 1;
    this.lastFrame = { robot: this.draw(n) };
    this.label(n ? interpolate(ngettext("the way so far: %(n)s move", "the way so far: %(n)s moves", n), { n }, true)
      : gettext("the robot at its start"));
  }

  // Still view of the whole path, the robot at its end.
  drawTrail() {
    this.begin();
    this.draw(this.robot.length - 1);
    this.label(gettext("trail: whole path"));
  }

  // The move (or view) label, in the strip under the grid: bottom left, else bottom right.
  label(text) {
    const layout = new Layout(this.w, this.h);
    tag(this.ctx, layout, "time-label", text, (w, h) => [[this.ox, this.h - h], [this.w - w - this.ox, this.h - h]],
      { size: 12 });
    this.boxes = layout.boxes;
  }

  redraw() {
    if (this.mode === "trail") this.drawTrail(); else this.drawFrame(this.t);
  }
}
