// Drawing an imported robot's recorded path from above (plain ES module, no build step): the scene of every
// table imported with recorded paths (teaching/importing/robot.py), which the generic player (../player.js)
// animates; it follows the contract every scenes/<scene>.js does (docs/domains.md "The web side").
//
// env: {bounds: [xmin, xmax, ymin, ymax], agents: [[[x, y]...]...], obstacles: [[x0, y0, x1, y1]...], dt, unit};
// robot: [[x, y]...], one row every dt seconds.  Bounds are the table's one view, or hold every objective's
// path in the environment, the other agents' and the obstacles with a margin, so the four options of a test
// share one view and one scale.  World y points up (the canvas's down is flipped); obstacles are dark rectangles.
// A light grid every "round" number of units (1, 2 or 5 times a power of ten) and a scale bar give the
// distances; the robot is a light disc with a dark outline, the other agents dark discs, so each stays
// apart in greyscale; the path so far is a line behind the robot.

import { gettext, interpolate } from "../i18n.js";
import { Layout, tag } from "../labels.js";
import { colors } from "../palette.js";

const NAMES = ["ground", "grid", "obstacle", "robot", "path", "agent", "agentPath", "text"];
const STRIP = 18;          // px under the view for the time label and the scale bar
const MIN_ASPECT = 0.45, MAX_ASPECT = 1.0;   // the view's height against its width

function lerp(a, b, f) { return a + (b - a) * f; }

// Position of rows at time t (seconds), linearly interpolated between rows dt apart.
export function sample(rows, t, dt) {
  const last = rows.length - 1;
  const k = Math.max(0, Math.min(t / dt, last));
  const i = Math.min(Math.floor(k), Math.max(0, last - 1)), f = last === 0 ? 0 : k - i;
  const a = rows[i], b = rows[Math.min(i + 1, last)];
  return [lerp(a[0], b[0], f), lerp(a[1], b[1], f)];
}

// The grid's step: 1, 2 or 5 times a power of ten, about a sixth of the span.
export function gridStep(span) {
  const raw = span / 6, p = 10 ** Math.floor(Math.log10(raw));
  return [1, 2, 5, 10].map((m) => m * p).find((s) => s >= raw) || raw;
}

export class Scene {
  constructor(canvas, env, robot) {
    if (!env.bounds) throw new Error("scene data without its bounds (env.bounds)");
    this.canvas = canvas;
    this.env = env;
    this.robot = robot;
    this.agents = env.agents || [];
    this.dt = env.dt;
    this.duration = (robot.length - 1) * this.dt;
    this.mode = "frame";     // "frame" | "trail"
    this.t = 0;
    this.boxes = [];         // every label drawn last (labels.js), for the tests
    this.lastFrame = null;   // drawn last: {robot: [x, y]} in CSS px
    this.view = env.bounds;
    this.resize();
  }

  // The canvas: its CSS width is the page's; its height the view's at that width (within MIN_ASPECT and
  // MAX_ASPECT) plus the label strip.  One scale both ways, the view centred.
  resize() {
    const dpr = window.devicePixelRatio || 1;
    const css = Math.round(this.canvas.clientWidth || this.canvas.width);
    const w = Math.max(120, css);
    const [x0, x1, y0, y1] = this.view;
    const aspect = Math.min(MAX_ASPECT, Math.max(MIN_ASPECT, (y1 - y0) / (x1 - x0)));
    const h = Math.round(w * aspect) + STRIP;
    const cssH = `${Math.round(h * css / w)}px`;
    if (this.canvas.style.height !== cssH) this.canvas.style.height = cssH;
    if (this.canvas.width !== Math.round(w * dpr) || this.canvas.height !== Math.round(h * dpr)) {
      this.canvas.width = Math.round(w * dpr);
      this.canvas.height = Math.round(h * dpr);
    }
    this.w = w; this.h = h; this.dpr = dpr;
    this.s = Math.min(w / (x1 - x0), (h - STRIP) / (y1 - y0));  // px per unit
    this.ox = (w - (x1 - x0) * this.s) / 2 - x0 * this.s;
    this.oy = (h - STRIP + (y1 - y0) * this.s) / 2 + y0 * this.s;
  }

  toScreen(x, y) {
    return [this.ox + x * this.s, this.oy - y * this.s];
  }

  begin() {
    this.resize();
    this.ctx = this.canvas.getContext("2d");
    this.ctx.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
    this.c = colors(NAMES);
    const { ctx, c } = this;
    ctx.fillStyle = c.ground;
    ctx.fillRect(0, 0, this.w, this.h);
    const [x0, x1, y0, y1] = this.view;
    this.step = gridStep(Math.max(x1 - x0, y1 - y0));
    ctx.strokeStyle = c.grid;
    ctx.lineWidth = 1;
    ctx.beginPath();
    for (let x = Math.ceil(x0 / this.step) * this.step; x <= x1; x += this.step) {
      const [sx] = this.toScreen(x, 0);
      ctx.moveTo(Math.round(sx) + 0.5, 0); ctx.lineTo(Math.round(sx) + 0.5, this.h - STRIP);
    }
    for (let y = Math.ceil(y0 / this.step) * this.step; y <= y1; y += this.step) {
      const [, sy] = this.toScreen(0, y);
      ctx.moveTo(0, Math.round(sy) + 0.5); ctx.lineTo(this.w, Math.round(sy) + 0.5);
    }
    ctx.stroke();
    ctx.fillStyle = c.obstacle;
    for (const [ax, ay, bx, by] of this.env.obstacles || []) {
      const [sx, sy] = this.toScreen(ax, by), [ex, ey] = this.toScreen(bx, ay);
      // whole px outwards, so two rectangles that meet leave no seam
      ctx.fillRect(Math.floor(sx), Math.floor(sy), Math.ceil(ex) - Math.floor(sx), Math.ceil(ey) - Math.floor(sy));
    }
    ctx.save();  // what moves stays inside the view, off the label strip (restored by finish)
    ctx.beginPath(); ctx.rect(0, 0, this.w, this.h - STRIP); ctx.clip();
  }

  line(rows, upTo, colour, width) {
    const { ctx } = this;
    ctx.strokeStyle = colour;
    ctx.lineWidth = width;
    ctx.lineCap = "round"; ctx.lineJoin = "round";
    ctx.beginPath();
    const last = Math.min(Math.floor(upTo), rows.length - 1);
    rows.slice(0, last + 1).forEach((p, i) => { const [x, y] = this.toScreen(p[0], p[1]); if (i) ctx.lineTo(x, y); else ctx.moveTo(x, y); });
    if (upTo > last && last < rows.length - 1) ctx.lineTo(...this.toScreen(...sample(rows, upTo * this.dt, this.dt)));
    ctx.stroke();
  }

  disc(x, y, fill, edge, r) {
    const { ctx } = this;
    ctx.fillStyle = fill;
    ctx.strokeStyle = edge;
    ctx.lineWidth = Math.max(1.5, r / 4);
    ctx.beginPath(); ctx.arc(x, y, r, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
  }

  radius() {
    return Math.max(5, Math.min(12, this.w / 40));
  }

  // The agents and the robot at time t, the paths so far behind them.
  drawFrame(t) {
    this.t = t;
    this.begin();
    const k = this.dt > 0 ? t / this.dt : 0, r = this.radius();
    for (const rows of this.agents) this.line(rows, rows.length - 1, this.c.agentPath, 2);
    this.line(this.robot, k, this.c.path, 3);
    const layout = new Layout(this.w, this.h);
    for (const rows of this.agents) {
      const [x, y] = this.toScreen(...sample(rows, t, this.dt));
      this.disc(x, y, this.c.agent, this.c.ground, r * 0.8);
      layout.avoid({ kind: "agent", x: x - r, y: y - r, w: 2 * r, h: 2 * r });
    }
    const [x, y] = this.toScreen(...sample(this.robot, t, this.dt));
    this.disc(x, y, this.c.ground, this.c.robot, r);
    layout.avoid({ kind: "robot", x: x - r, y: y - r, w: 2 * r, h: 2 * r });
    this.finish(layout, interpolate(gettext("t = %(seconds)s s"), { seconds: t.toFixed(1) }, true));
    this.lastFrame = { robot: [x, y] };
  }

  // The whole path at once with a dot each second, the robot at its end, the other agents where they started
  // (their paths faint).
  drawTrail() {
    this.begin();
    const r = this.radius();
    for (const rows of this.agents) this.line(rows, rows.length - 1, this.c.agentPath, 2);
    this.line(this.robot, this.robot.length - 1, this.c.path, 3);
    // a dot where the robot is at each whole second, so a slow way and a fast one along one line differ
    this.ctx.fillStyle = this.c.robot;
    const every = Math.max(1, Math.round(1 / this.dt));
    for (let k = every; k < this.robot.length; k += every) {
      const [x, y] = this.toScreen(...this.robot[k]);
      this.ctx.beginPath(); this.ctx.arc(x, y, 2.2, 0, 2 * Math.PI); this.ctx.fill();
    }
    const layout = new Layout(this.w, this.h);
    for (const rows of this.agents) {
      const [x, y] = this.toScreen(...rows[0]);
      this.disc(x, y, this.c.agent, this.c.ground, r * 0.8);
      layout.avoid({ kind: "agent", x: x - r, y: y - r, w: 2 * r, h: 2 * r });
    }
    const [x, y] = this.toScreen(...this.robot[this.robot.length - 1]);
    this.disc(x, y, this.c.ground, this.c.robot, r);
    layout.avoid({ kind: "robot", x: x - r, y: y - r, w: 2 * r, h: 2 * r });
    this.finish(layout, gettext("trail: whole path"));
  }

  // The label at the left of the strip, the scale bar at its right.
  finish(layout, text) {
    const { ctx, c } = this;
    ctx.restore();
    ctx.fillStyle = c.ground;
    ctx.fillRect(0, this.h - STRIP, this.w, STRIP);
    const bar = this.step * this.s, y = this.h - STRIP / 2;
    ctx.strokeStyle = c.text; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(this.w - 6 - bar, y); ctx.lineTo(this.w - 6, y); ctx.stroke();
    const unit = this.env.unit ? ` ${this.env.unit}` : "";
    tag(ctx, layout, "scale-label", `${+this.step.toPrecision(3)}${unit}`,
      (w) => [[this.w - 10 - bar - w, this.h - STRIP + 1]], { size: 12 });
    tag(ctx, layout, "time-label", text, () => [[4, this.h - STRIP + 1]], { size: 12 });
    this.boxes = layout.boxes;
  }

  redraw() {
    if (this.mode === "trail") this.drawTrail(); else this.drawFrame(this.t);
  }
}
