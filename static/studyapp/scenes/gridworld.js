// Drawing and animating one delivery-yard scene on a canvas (plain ES module, no build step).
//
// The yard is seen from above, one square per cell, row 0 at the top (as the staff contact
// sheet, teaching/domains/gridworld/sheet.py, draws it): walls dark, mud brown and dotted, the dog
// a red disc with the cells next to it hatched red, the cart a blue square, the start S and the
// drop-off D.  The robot's rows are [col, row] cells, one per move, every `dt` seconds; playback
// interpolates between them at the display's frame rate.  The path is one line, thin while the
// robot carries the parcel by hand and thick once it pushes the cart, as on the sheet.
// Not colour alone: every kind of cell also differs in lightness, a pattern or a word, so the yard
// reads in greyscale too.  The player (../player.js) uses only the members of Scene.

import { Layout, tag } from "../labels.js";
import { colors } from "../palette.js";

const WALL = 1, MUD = 2, DOG = 3, CART = 4;   // teaching/domains/gridworld/world.py's codes (0: free)
const STRIP = 16;        // px kept free under the yard for the "move k of n" label
const WORDS_FROM = 22;   // cells at least this wide (px) carry "dog" / "cart"; smaller ones are too small to read
const NAMES = ["free", "grid", "wall", "mud", "mudMark", "near", "nearMark", "dog", "cart", "robot",
  "robotEdge", "path", "text"];

export class Scene {
  constructor(canvas, env, robot) {
    this.canvas = canvas;
    this.env = env;            // {dt, yard: {cells, near_dog, start, goal}}
    if (!env.yard) throw new Error("scene data without a yard (env.yard)");
    this.yard = env.yard;
    this.robot = robot;        // [[col, row]...], first the start, last the drop-off
    this.dt = env.dt;          // s per move
    this.duration = (robot.length - 1) * this.dt;
    this.mode = "frame";       // "frame" | "trail"
    this.t = 0;
    this.boxes = [];           // every label drawn last (labels.js), for the tests
    this.lastFrame = null;     // screen position drawn last: {robot: [x, y]}
    // The row at which the robot enters the cart's cell (it pushes the cart from then on), else none.
    const at = (p) => this.yard.cells[p[1]][p[0]];
    const k = robot.findIndex((p) => at(p) === CART);
    this.fetched = k < 0 ? Infinity : k;
    this.resize();
  }

  // Canvas buffer in device pixels, drawing in CSS px.  The canvas's width is the page's; its height
  // is the yard's at that width plus the label strip (set here), so the yard fills the canvas.
  resize() {
    const dpr = window.devicePixelRatio || 1;
    const rows = this.yard.cells.length, cols = this.yard.cells[0].length;
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
    // Square cells of whole px (crisp grid lines), the yard centred above the label strip.
    this.cell = Math.max(1, Math.floor(Math.min(w / cols, (h - STRIP) / rows)));
    this.ox = Math.floor((w - cols * this.cell) / 2);
    this.oy = Math.floor((h - STRIP - rows * this.cell) / 2);
  }

  begin() {
    this.resize();
    this.ctx = this.canvas.getContext("2d");
    this.ctx.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
    this.c = colors(NAMES);
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

  // The yard: cells, their patterns, the grid, the dog and the cart (unless the robot has it).
  drawYard(cartTaken) {
    const { ctx, cell: s, c } = this;
    const { cells, near_dog: near } = this.yard;
    ctx.fillStyle = c.grid;     // the surround: the yard's edge stays visible on any page background
    ctx.fillRect(0, 0, this.w, this.h);
    cells.forEach((line, r) => line.forEach((kind, col) => {
      const x = this.ox + col * s, y = this.oy + r * s;
      ctx.fillStyle = kind === WALL ? c.wall : kind === MUD ? c.mud : near[r][col] ? c.near : c.free;
      ctx.fillRect(x, y, s, s);
      if (kind === MUD) this.dots(x, y);
      else if (kind !== WALL && near[r][col]) this.hatch(x, y);
    }));
    // Grid lines, 1 px on each cell boundary (on the yard's outer edge too).
    const rows = cells.length, cols = cells[0].length;
    ctx.fillStyle = c.grid;
    for (let col = 0; col <= cols; col++) ctx.fillRect(this.ox + col * s - (col === cols ? 1 : 0), this.oy, 1, rows * s);
    for (let r = 0; r <= rows; r++) ctx.fillRect(this.ox, this.oy + r * s - (r === rows ? 1 : 0), cols * s, 1);
    const words = s >= WORDS_FROM;
    cells.forEach((line, r) => line.forEach((kind, col) => {
      const [x, y] = this.toScreen(col, r);
      if (kind === DOG) {
        ctx.fillStyle = c.dog;
        ctx.beginPath(); ctx.arc(x, y, 0.38 * s, 0, 2 * Math.PI); ctx.fill();
        if (words) this.word("dog", x, y, 0.27 * s);
      } else if (kind === CART && !cartTaken) {
        this.cart(x, y, 0.66 * s);
        if (words) this.word("cart", x, y, 0.25 * s);
      }
    }));
  }

  // S and D: bold, drawn over the path with a halo of the cell's colour, so the line that starts
  // and ends in their cells does not cut through them (the robot, drawn last, may cover one).
  drawLetters() {
    const { ctx, cell: s, c } = this;
    ctx.font = `700 ${Math.max(9, Math.round(0.5 * s))}px system-ui, sans-serif`;
    ctx.textAlign = "center"; ctx.textBaseline = "middle";
    ctx.lineJoin = "round";
    ctx.lineWidth = Math.max(2, s / 10);
    ctx.strokeStyle = c.free;
    ctx.fillStyle = c.text;
    for (const [[col, r], letter] of [[this.yard.start, "S"], [this.yard.goal, "D"]]) {
      const [x, y] = this.toScreen(col, r);
      ctx.strokeText(letter, x, y + 0.5);
      ctx.fillText(letter, x, y + 0.5);
    }
    ctx.textAlign = "start"; ctx.textBaseline = "alphabetic";
  }

  // Mud: light dots on a regular grid that keeps clear of the cell's edges and corners.
  dots(x, y) {
    const { ctx, cell: s } = this;
    const n = Math.max(2, Math.round(s / 7)), step = s / n, r = Math.max(0.8, s / 28);
    ctx.fillStyle = this.c.mudMark;
    for (let i = 0; i < n; i++) {
      for (let j = 0; j < n; j++) {
        ctx.beginPath(); ctx.arc(x + (i + 0.5) * step, y + (j + 0.5) * step, r, 0, 2 * Math.PI); ctx.fill();
      }
    }
  }

  // Next to the dog: diagonal hatch (as the sheet's "////"), clipped to the cell.
  hatch(x, y) {
    const { ctx, cell: s } = this;
    const step = Math.max(5, s / 4.5);   // sparse enough at small cells to keep the dog apart
    ctx.save();
    ctx.beginPath(); ctx.rect(x, y, s, s); ctx.clip();
    ctx.strokeStyle = this.c.nearMark;
    ctx.lineWidth = Math.max(0.8, s / 36);
    ctx.beginPath();
    for (let k = step / 2; k < 2 * s; k += step) { ctx.moveTo(x + k, y); ctx.lineTo(x + k - s, y + s); }
    ctx.stroke();
    ctx.restore();
  }

  cart(x, y, size) {
    this.ctx.fillStyle = this.c.cart;
    this.ctx.fillRect(x - size / 2, y - size / 2, size, size);
  }

  // A light word (the free cells' near-white) centred on a dark mark (the dog, the cart).
  word(text, x, y, size) {
    const ctx = this.ctx;
    ctx.font = `700 ${Math.round(size)}px system-ui, sans-serif`;
    ctx.fillStyle = this.c.free;
    ctx.textAlign = "center"; ctx.textBaseline = "middle";
    ctx.fillText(text, x, y + 0.5);
    ctx.textAlign = "start"; ctx.textBaseline = "alphabetic";
  }

  // The path up to row index `to` (fractional): thin while carrying by hand, thick from the cart on.
  drawPath(to) {
    const ctx = this.ctx, s = this.cell;
    const stroke = (a, b, width) => {
      if (b <= a) return;
      const pts = [this.at(a)];
      for (let k = Math.floor(a) + 1; k < b; k++) pts.push(this.robot[k]);
      pts.push(this.at(b));
      ctx.beginPath();
      pts.map((p) => this.toScreen(p[0], p[1])).forEach(([x, y], i) => (i ? ctx.lineTo(x, y) : ctx.moveTo(x, y)));
      ctx.lineWidth = width;
      ctx.stroke();
    };
    ctx.strokeStyle = this.c.path;
    ctx.lineCap = "round"; ctx.lineJoin = "round";
    stroke(0, Math.min(to, this.fetched), Math.max(1.5, 0.06 * s));
    stroke(this.fetched, to, Math.max(3.5, 0.15 * s));
  }

  // The robot at row index k: a light disc with a dark outline, the parcel on it, on the cart once fetched.
  drawRobot(k) {
    const { ctx, cell: s, c } = this;
    const [x, y] = this.toScreen(...this.at(k));
    if (k >= this.fetched) this.cart(x, y, 0.78 * s);
    ctx.fillStyle = c.robot;
    ctx.strokeStyle = c.robotEdge;
    ctx.lineWidth = Math.max(1.5, s / 22);
    ctx.beginPath(); ctx.arc(x, y, 0.32 * s, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
    const p = Math.max(3, 0.24 * s);   // the parcel: a small outlined square, cardboard-coloured
    ctx.fillStyle = c.mudMark;         // (the palette's tan; no colour of its own)
    ctx.lineWidth = Math.max(1, s / 36);
    ctx.fillRect(x - p / 2, y - p / 2, p, p);
    ctx.strokeRect(x - p / 2, y - p / 2, p, p);
    return [x, y];
  }

  // One animation frame at time t: the path so far and the robot where it is.
  drawFrame(t) {
    this.t = t;
    this.begin();
    const n = this.robot.length - 1;
    const k = Math.max(0, Math.min(t / this.dt, n));
    this.drawYard(k >= this.fetched);
    this.drawPath(k);
    this.drawLetters();
    const robot = this.drawRobot(k);
    this.label(`move ${Math.min(n, Math.ceil(k - 1e-9))} of ${n}`);
    this.lastFrame = { robot };
  }

  // Still view of the whole path, the robot at the drop-off.
  drawTrail() {
    this.begin();
    const n = this.robot.length - 1;
    this.drawYard(n >= this.fetched);
    this.drawPath(n);
    this.drawLetters();
    this.drawRobot(n);
    this.label("trail: whole path");
  }

  // The move (or view) label, in the strip under the yard: bottom left, else bottom right.
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
