// Drawing one driving scene on a canvas (plain ES module, no build step): the driving domain's
// scene, which the generic player (../player.js) animates; it follows the contract every
// scenes/<domain>.js does (docs/domains.md "The web side").
//
// World units are feet: x grows to the right, y forward (drawn upwards). The world's sizes
// (lane width and centres, left to right; the road's half-width; the cars' length and width)
// come with the scene data as env.world (teaching/domains/driving/page.py scene_sizes, from
// WORLD), so this file holds none of its own. Robot states are [x, y, heading, v, steer]
// rows every `dt` seconds; the other car's rows are [x, y]. Playback interpolates between
// rows at the display's frame rate (requestAnimationFrame), so it is smooth at 60 fps.

import { Layout, tag } from "../labels.js";
import { colors as palette } from "../palette.js";

const VIEW_W_FT = 60;         // feet shown across the reference canvas
// Every canvas of a study is drawn at one scale (px per ft): the one at which a test option's
// canvas (the smallest a participant gets, --scene-ref-w wide, 3:4) holds the study's largest
// framed span (env.study_span).  A larger canvas (a training example) shows more road around the
// cars at the same scale, so the same speeds and gaps look the same in training and at test.
const REF_W = 144;
// The other car within this distance along the road counts as interacting: the camera frames
// both cars while it is (and at their closest approach in any case), so the participant sees
// the merge ahead of or behind it, or the pass, instead of an edge marker.
const INTERACTION_FT = 150;
const MARGIN_FT = 10;         // road shown beyond each framed car
const MAX_SQUEEZE = 3;        // the forward axis is compressed at most 3:1 against the lateral one
// Colours are the domain's palette (../palette.js: the page's --scene-* properties), so the legend's
// swatches are the canvas's colours. Not colour alone (issue 22): the goal lane is dark and hatched
// against a light road, the autonomous car light with a black outline, the other car dark with a
// white outline, so each stays apart in greyscale (tests/browser/test_scene_legibility.py measures it).
const NAMES = ["grass", "road", "line", "goal", "goalHatch", "goalEdge", "outline", "robot", "robotEdge", "other",
  "otherEdge"];
function colors() {
  return palette(NAMES);
}
// a test option's canvas width (study.css --scene-ref-w): every canvas is drawn at the px/ft it gives
function refWidth() {
  return parseFloat(getComputedStyle(document.documentElement).getPropertyValue("--scene-ref-w")) || REF_W;
}

function lerp(a, b, f) { return a + (b - a) * f; }

// Position of a trajectory at time t (seconds), linearly interpolated; heading interpolated too.
export function sample(rows, t, dt) {
  const last = rows.length - 1;
  const k = Math.max(0, Math.min(t / dt, last));
  const i = Math.min(Math.floor(k), last - 1 < 0 ? 0 : last - 1);
  const f = last === 0 ? 0 : k - i;
  const a = rows[i], b = rows[Math.min(i + 1, last)];
  return { x: lerp(a[0], b[0], f), y: lerp(a[1], b[1], f), h: a.length > 2 ? lerp(a[2], b[2], f) : Math.PI / 2 };
}

export class Scene {
  constructor(canvas, env, robot) {
    this.canvas = canvas;
    this.env = env;          // {goal, other: [[x, y]...], dt, world}
    if (!env.world) throw new Error("scene data without the world's sizes (env.world)");
    this.world = env.world;  // {lane_width, lane_centres, road_half_width, car_length, car_width} in ft
    this.robot = robot;      // [[x, y, heading, v, steer]...]
    this.dt = env.dt;        // s per row (WORLD.dt)
    this.duration = (robot.length - 1) * this.dt;
    this.mode = "frame";     // "frame" | "trail"
    this.t = 0;
    this.span = framedSpan(robot, env.other);
    this.viewSpan = Math.max(this.span, Number(env.study_span) || 0);  // the study's, where the page gives it
    this.boxes = [];         // every label and mark drawn last (labels.js), for the tests
    this.lastFrame = null;   // screen positions drawn last: {robot: [x, y], other: [x, y] | null}
    this.resize();
  }

  resize() {
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(120, Math.round(this.canvas.clientWidth || this.canvas.width));
    const h = Math.round(w * 4 / 3);
    if (this.canvas.width !== Math.round(w * dpr) || this.canvas.height !== Math.round(h * dpr)) {
      this.canvas.width = Math.round(w * dpr);
      this.canvas.height = Math.round(h * dpr);
    }
    this.w = w; this.h = h; this.dpr = dpr;
  }

  // camera: {cy (world y at the anchor), anchor (fraction of height), xs, ys (px per ft across / along)}
  // The animation uses xs == ys; the still trail view compresses y (at most 3:1) to fit the whole drive.
  toScreen(cam, x, y) {
    return [this.w / 2 + x * cam.xs, this.h * cam.anchor - (y - cam.cy) * cam.ys];
  }

  // Centre (ft) of the lane the drive starts in and the forward goal keeps: the middle one.
  centreLane() {
    const lanes = this.world.lane_centres;
    return lanes[Math.floor(lanes.length / 2)];
  }

  drawRoad(cam) {
    const ctx = this.ctx, s = cam.xs;
    const { lane_width: laneW, lane_centres: lanes, road_half_width: roadHalf } = this.world;
    ctx.fillStyle = colors().grass;
    ctx.fillRect(0, 0, this.w, this.h);
    const [left] = this.toScreen(cam, -roadHalf, 0);
    ctx.fillStyle = colors().road;
    ctx.fillRect(left, 0, 2 * roadHalf * s, this.h);
    // goal: the right lane (merge) or the centre lane straight ahead (forward), in blue
    if (this.env.goal === 0) {
      const [gx] = this.toScreen(cam, lanes[lanes.length - 1] - laneW / 2, 0);
      this.goalLane(gx, 0, laneW * s, this.h);
    } else {
      const [gx, gy] = this.toScreen(cam, this.centreLane() - laneW / 2, 0);
      this.goalLane(gx, 0, laneW * s, Math.max(0, gy));
    }
    // lane markings: solid edges, dashed separators (halfway between lane centres) scrolling with the world
    ctx.strokeStyle = colors().line;
    ctx.lineWidth = Math.max(1, 0.5 * s);
    for (const x of [-roadHalf + 0.5, roadHalf - 0.5]) {
      const [sx] = this.toScreen(cam, x, 0);
      ctx.setLineDash([]);
      ctx.beginPath(); ctx.moveTo(sx, 0); ctx.lineTo(sx, this.h); ctx.stroke();
    }
    const dash = 10 * cam.ys, gap = 15 * cam.ys;
    const [, y0] = this.toScreen(cam, 0, 0);
    ctx.setLineDash([dash, gap]);
    ctx.lineDashOffset = -(y0 % (dash + gap));
    for (const x of lanes.slice(1).map((c, i) => (lanes[i] + c) / 2)) {
      const [sx] = this.toScreen(cam, x, 0);
      ctx.beginPath(); ctx.moveTo(sx, 0); ctx.lineTo(sx, this.h); ctx.stroke();
    }
    ctx.setLineDash([]);
  }

  // The goal lane: dark, hatched with light diagonals (a pattern, not only a colour).
  goalLane(x, y, w, h) {
    const ctx = this.ctx;
    ctx.fillStyle = colors().goal;
    ctx.fillRect(x, y, w, h);
    ctx.save();
    ctx.beginPath(); ctx.rect(x, y, w, h); ctx.clip();
    ctx.strokeStyle = colors().goalHatch;
    ctx.lineWidth = 2;
    for (let k = -h; k < w + h; k += 9) {
      ctx.beginPath(); ctx.moveTo(x + k, y + h); ctx.lineTo(x + k + h, y); ctx.stroke();
    }
    ctx.restore();
  }

  // Goal marks, drawn after the cars: the arrow straight ahead (forward) and a "goal" tag on the lane.
  goalMarks(cam, layout) {
    const ctx = this.ctx, s = cam.xs;
    const lanes = this.world.lane_centres;
    const laneX = this.env.goal === 0 ? lanes[lanes.length - 1] : this.centreLane();
    const [ax] = this.toScreen(cam, laneX, 0);
    if (this.env.goal !== 0) {
      const top = 4, size = Math.max(6, 4 * s);
      layout.reserve("goal-arrow", ax - size, top, 2 * size, size * 1.4);
      ctx.fillStyle = colors().goalEdge;
      ctx.strokeStyle = colors().outline;
      ctx.lineWidth = 1.5;
      ctx.beginPath();
      ctx.moveTo(ax, top); ctx.lineTo(ax - size, top + size * 1.4); ctx.lineTo(ax + size, top + size * 1.4);
      ctx.closePath(); ctx.fill(); ctx.stroke();
      tag(ctx, layout, "goal-label", "goal", (w) => [[ax + size + 3, top], [ax - size - 3 - w, top],
        [ax - w / 2, top + size * 1.4 + 2]]);
    } else {
      tag(ctx, layout, "goal-label", "goal", (w) => [[ax - w / 2, 4], [ax - w / 2, 22], [this.w - w - 2, 4]]);
    }
  }

  car(cam, x, y, heading, kind, alpha = 1) {
    const ctx = this.ctx;
    const [sx, sy] = this.toScreen(cam, x, y);
    let len = this.world.car_length * cam.ys, wid = this.world.car_width * cam.xs;
    if (cam.xs !== cam.ys) { len = Math.max(len, 14); wid = Math.min(wid, 0.45 * len); }
    if (sy < -len || sy > this.h + len) return false;
    ctx.save();
    ctx.globalAlpha = alpha;
    ctx.translate(sx, sy);
    ctx.rotate(-Math.atan2(Math.sin(heading) * cam.ys, Math.cos(heading) * cam.xs));
    ctx.fillStyle = colors()[kind];
    ctx.strokeStyle = colors()[`${kind}Edge`];
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.rect(-len / 2, -wid / 2, len, wid);
    ctx.fill(); ctx.stroke();
    ctx.fillStyle = kind === "robot" ? "rgba(30, 40, 60, 0.55)" : "rgba(255, 255, 255, 0.55)";  // windscreen: the front
    ctx.fillRect(len * 0.12, -wid * 0.38, len * 0.16, wid * 0.76);
    ctx.restore();
    return true;
  }

  // The other car outside the view: an arrow at the edge, and its distance on a white tag beside
  // it, on whichever side (or row) is free of the other labels and marks.
  offscreen(cam, x, y, ry, layout) {
    const ctx = this.ctx;
    const [sx, sy] = this.toScreen(cam, x, y);
    const above = sy < 0, dir = above ? 1 : -1;
    const edge = above ? 4 : this.h - 4;
    let top = above ? edge : edge - 12;
    let arrow = { kind: "other-arrow", x: sx - 8, y: top, w: 16, h: 13 };
    while (!layout.fits(arrow) && top > 0 && top < this.h - 13) {  // below the goal arrow or its tag
      top += above ? 4 : -4;
      arrow = { ...arrow, y: top };
    }
    layout.reserve(arrow.kind, arrow.x, arrow.y, arrow.w, arrow.h);
    const tip = above ? top : top + 12;
    ctx.fillStyle = colors().other;
    ctx.strokeStyle = colors().otherEdge;
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    ctx.moveTo(sx, tip); ctx.lineTo(sx - 7, tip + dir * 12); ctx.lineTo(sx + 7, tip + dir * 12);
    ctx.closePath(); ctx.fill(); ctx.stroke();
    const text = `other car ${Math.round(Math.abs(y - ry))} ft ${above ? "ahead" : "behind"}`;
    tag(ctx, layout, "other-label", text, (w, h) => {
      const rows = above ? [top, top + h + 2, top + 2 * (h + 2)] : [top - 2, top - h - 4, top - 2 * (h + 2) - 2];
      return rows.flatMap((ty) => [[sx + 10, ty], [sx - 10 - w, ty], [this.w - w - 2, ty], [2, ty]]);
    });
  }

  begin() {
    this.resize();
    this.ctx = this.canvas.getContext("2d");
    this.ctx.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
  }

  // The camera for time t: one scale for the whole drive (the road does not zoom in and out),
  // wide enough along the road to hold both cars whenever they interact; it centres between
  // them, and on the robot alone (with the other car at the edge) when they are further apart.
  camera(r, o) {
    const { xs, ys } = this.scale();
    const dy = Math.max(-this.span, Math.min(this.span, o.y - r.y));
    return { cy: r.y + dy / 2, anchor: 0.5, xs, ys };
  }

  // px per ft across (xs) and along (ys) the road: the reference canvas's (or this one's, if smaller),
  // holding the study's largest framed span with room for the goal arrow above and the time below.
  scale() {
    const refW = Math.min(this.w, refWidth());
    const base = refW / VIEW_W_FT;
    const usable = refW * 4 / 3 - 36;
    const ys = Math.min(base, usable / (this.viewSpan + this.world.car_length + 2 * MARGIN_FT));
    return { xs: Math.min(base, MAX_SQUEEZE * ys), ys };
  }

  // One animation frame at time t.
  drawFrame(t) {
    this.t = t;
    this.begin();
    const r = sample(this.robot, t, this.dt);
    const o = sample(this.env.other, t, this.dt);
    const cam = this.camera(r, o);
    this.drawRoad(cam);
    const otherShown = this.car(cam, o.x, o.y, Math.PI / 2, "other");
    this.car(cam, r.x, r.y, r.h, "robot");
    const layout = new Layout(this.w, this.h);
    this.goalMarks(cam, layout);
    this.label(layout, `t = ${t.toFixed(1)} s`);
    if (!otherShown) this.offscreen(cam, o.x, o.y, r.y, layout);
    this.boxes = layout.boxes;
    this.lastFrame = { robot: this.toScreen(cam, r.x, r.y), other: otherShown ? this.toScreen(cam, o.x, o.y) : null };
  }

  // Still view of the whole drive: earlier positions faint, later ones more opaque.
  drawTrail() {
    this.begin();
    const robotY = this.robot.map((s) => s[1]);
    const lo = Math.min(...robotY) - 20, hi = Math.max(...robotY) + 20;
    const ys = Math.min(this.w / VIEW_W_FT, (this.h - 16) / (hi - lo));
    const cam = { cy: (lo + hi) / 2, anchor: 0.5, xs: Math.min(this.w / VIEW_W_FT, 3 * ys), ys };
    this.drawRoad(cam);
    const last = this.robot.length - 1;
    for (let k = 0; k <= last; k += (last % 2 === 0 ? 2 : 1)) {
      const alpha = 0.12 + 0.88 * (k / last);
      const o = this.env.other[k], r = this.robot[k];
      this.car(cam, o[0], o[1], Math.PI / 2, "other", alpha);
      this.car(cam, r[0], r[1], r[2], "robot", alpha);
    }
    const layout = new Layout(this.w, this.h);
    this.goalMarks(cam, layout);
    this.label(layout, "trail: whole drive");
    this.boxes = layout.boxes;
  }

  // The time (or view) label: bottom left, else bottom right, else the first free row.
  label(layout, text) {
    tag(this.ctx, layout, "time-label", text, (w, h) => [[4, this.h - h - 4], [this.w - w - 4, this.h - h - 4]],
      { size: 12 });
  }

  redraw() {
    if (this.mode === "trail") this.drawTrail(); else this.drawFrame(this.t);
  }
}

// Along-road distance (ft) the animation's view must hold between the two cars: the largest
// gap while they interact (within INTERACTION_FT), and at least the gap at their closest approach.
export function framedSpan(robot, other) {
  const gaps = robot.map((r, k) => Math.abs(other[Math.min(k, other.length - 1)][1] - r[1]));
  const closest = Math.min(...gaps);
  const near = gaps.filter((g) => g <= INTERACTION_FT);
  return Math.max(closest, near.length ? Math.max(...near) : 0);
}
