// Drawing one driving scene on a canvas (plain ES module, no build step): the driving domain's
// scene, which the generic player (../player.js) animates; it follows the contract every
// scenes/<domain>.js does (docs/domains.md "The web side").
//
// World units are feet: x across the road (right positive), y forward.  The road runs left to
// right across a landscape canvas, the right lane at the bottom (as the staff contact sheet,
// teaching/domains/driving/sheet.py, draws it): a drive is long and the road narrow, so a wide
// canvas gives the cars the room a tall one wasted on grass.  The world's sizes (lane width and
// centres, left to right; the road's half-width; the cars' length and width) come with the scene
// data as env.world (teaching/domains/driving/page.py scene_sizes, from WORLD), so this file holds
// none of its own. Robot states are [x, y, heading, v, steer] rows every `dt` seconds; the other
// car's rows are [x, y]. Playback interpolates between rows at the display's frame rate
// (requestAnimationFrame), so it is smooth at 60 fps.

import { gettext, interpolate } from "../i18n.js";
import { Layout, tag } from "../labels.js";
import { colors as palette } from "../palette.js";

// Every canvas of a study is drawn at one scale (px per ft): the one at which a test option's
// canvas (the page's --scene-ref-w wide, at most --scene-ref-h tall) holds the study's largest
// framed span (env.study_span) along the road and the road's width across it.  A wider canvas (a
// training example) shows more road around the cars at the same scale, so the same speeds and gaps
// look the same in training and at test.  The canvas is as tall as the road at that scale plus a
// band of grass above and below, where the labels go (never over the cars).
const REF_W = 144;            // a page without --scene-ref-w (a bare canvas)
const BAND = 18;              // px of grass above and below the road: one row of labels each
// The other car within this distance along the road counts as interacting: the camera frames
// both cars while it is, so the participant sees the merge ahead of or behind it, or the pass;
// further away it is an arrow at the edge with its distance (framing a car that never comes
// nearer than, say, 240 ft would shrink every canvas of the study to hold that gap).
const INTERACTION_FT = 150;
const MARGIN_FT = 10;         // road shown beyond each framed car
const MAX_SQUEEZE = 3;        // the trail compresses the road at most 3:1 along against across
// Colours are the domain's palette (../palette.js: the page's --scene-* properties), so the legend's
// swatches are the canvas's colours. Not colour alone: the goal lane is dark and hatched against a
// light road, the autonomous car light with a black outline, the other car dark with a white outline,
// so each stays apart in greyscale (tests/browser/test_scene_legibility.py measures it).
const NAMES = ["grass", "road", "line", "goal", "goalHatch", "goalEdge", "outline", "robot", "robotEdge", "other",
  "otherEdge"];
function colors() {
  return palette(NAMES);
}
// The page's reference sizes (study.css and scenes/driving.css register them as <length>, so the
// computed value is in px whatever the rule says: vw, vh, min()); 0 where the page sets none.
function refSize(name) {
  return parseFloat(getComputedStyle(document.documentElement).getPropertyValue(name)) || 0;
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
    this.cars = [];          // the cars' boxes drawn last: no label goes over them
    this.lastFrame = null;   // drawn last: {robot: [x, y], other: [x, y] | null, robotLength: px}
    this.resize();
  }

  // The canvas: its CSS width is the page's; its height the road's at the study's scale plus the
  // two label bands (set here, so the page never stretches the drawing).
  resize() {
    const dpr = window.devicePixelRatio || 1;
    const css = Math.round(this.canvas.clientWidth || this.canvas.width);
    const w = Math.max(120, css);
    this.w = w;
    this.s = this.scale();
    const h = Math.round(2 * this.world.road_half_width * this.s + 2 * BAND);
    const cssH = `${Math.round(h * css / w)}px`;  // a canvas narrower than the drawing shows it scaled down whole
    if (this.canvas.style.height !== cssH) this.canvas.style.height = cssH;
    if (this.canvas.width !== Math.round(w * dpr) || this.canvas.height !== Math.round(h * dpr)) {
      this.canvas.width = Math.round(w * dpr);
      this.canvas.height = Math.round(h * dpr);
    }
    this.h = h; this.dpr = dpr;
  }

  // px per ft, the same across and along the road: the reference canvas's (or this one's, if
  // narrower) holding the study's largest framed span, and no more than the reference height allows.
  scale() {
    const refW = Math.min(this.w, refSize("--scene-ref-w") || REF_W);
    const refH = refSize("--scene-ref-h");
    let s = refW / (this.viewSpan + this.world.car_length + 2 * MARGIN_FT);
    if (refH > 2 * BAND) s = Math.min(s, (refH - 2 * BAND) / (2 * this.world.road_half_width));
    return s;
  }

  // camera: {cy (world y at the anchor), anchor (fraction of width), xs, ys (px per ft across / along)}
  // The animation uses xs == ys; the still trail view compresses y (at most 3:1) to fit the whole drive.
  toScreen(cam, x, y) {
    return [this.w * cam.anchor + (y - cam.cy) * cam.ys, this.h / 2 + x * cam.xs];
  }

  // Centre (ft) of the lane the drive starts in and the forward goal keeps: the middle one.
  centreLane() {
    const lanes = this.world.lane_centres;
    return lanes[Math.floor(lanes.length / 2)];
  }

  // The road between two bands of grass, across the whole canvas.
  road(cam) {
    const [, top] = this.toScreen(cam, -this.world.road_half_width, 0);
    return { x: 0, y: top, w: this.w, h: 2 * this.world.road_half_width * cam.xs };
  }

  drawRoad(cam) {
    const ctx = this.ctx, s = cam.xs;
    const { lane_width: laneW, lane_centres: lanes, road_half_width: roadHalf } = this.world;
    ctx.fillStyle = colors().grass;
    ctx.fillRect(0, 0, this.w, this.h);
    const road = this.road(cam);
    ctx.fillStyle = colors().road;
    ctx.fillRect(road.x, road.y, road.w, road.h);
    // goal: the right lane (merge) or the centre lane ahead of the start (forward), dark and hatched
    if (this.env.goal === 0) {
      const [, gy] = this.toScreen(cam, lanes[lanes.length - 1] - laneW / 2, 0);
      this.goalLane(0, gy, this.w, laneW * s);
    } else {
      const [gx, gy] = this.toScreen(cam, this.centreLane() - laneW / 2, 0);
      const from = Math.max(0, gx);
      this.goalLane(from, gy, Math.max(0, this.w - from), laneW * s);
    }
    // lane markings: solid edges, dashed separators (halfway between lane centres) scrolling with the world
    ctx.strokeStyle = colors().line;
    ctx.lineWidth = Math.max(1, 0.5 * s);
    for (const x of [-roadHalf + 0.5, roadHalf - 0.5]) {
      const [, sy] = this.toScreen(cam, x, 0);
      ctx.setLineDash([]);
      ctx.beginPath(); ctx.moveTo(0, sy); ctx.lineTo(this.w, sy); ctx.stroke();
    }
    const dash = 10 * cam.ys, gap = 15 * cam.ys;
    const [x0] = this.toScreen(cam, 0, 0);
    ctx.setLineDash([dash, gap]);
    ctx.lineDashOffset = -(x0 % (dash + gap));
    for (const x of lanes.slice(1).map((c, i) => (lanes[i] + c) / 2)) {
      const [, sy] = this.toScreen(cam, x, 0);
      ctx.beginPath(); ctx.moveTo(0, sy); ctx.lineTo(this.w, sy); ctx.stroke();
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

  // Top-left y of a label h px tall centred in the grass band above (top) or below the road.
  bandY(h, top) {
    return top ? Math.max(0, (BAND - h) / 2) : this.h - BAND + Math.max(0, (BAND - h) / 2);
  }

  // Goal marks, drawn after the cars: for "forward" an arrow at the far end of the centre lane
  // (else in the band above the road, where a car is there), and a "goal" tag in the band beside
  // the goal lane: below the road for the right lane, above it for the centre lane.
  goalMarks(cam, layout) {
    const ctx = this.ctx;
    const lanes = this.world.lane_centres;
    const forward = this.env.goal !== 0;
    const laneX = forward ? this.centreLane() : lanes[lanes.length - 1];
    const [, ay] = this.toScreen(cam, laneX, 0);
    let right = this.w - 4;
    if (forward) {
      const size = Math.max(7, Math.min(0.3 * this.world.lane_width * cam.xs, 14));
      const box = layout.place("goal-arrow", Math.round(1.4 * size), Math.round(2 * size),
        [[this.w - 1.4 * size - 4, ay - size], [this.w - 1.4 * size - 4, this.bandY(2 * size, true)]]);
      const tip = box.x + box.w, mid = box.y + box.h / 2, half = box.h / 2;
      ctx.fillStyle = colors().goalEdge;
      ctx.strokeStyle = colors().outline;
      ctx.lineWidth = 1.5;
      ctx.beginPath();
      ctx.moveTo(tip, mid); ctx.lineTo(box.x, mid - half); ctx.lineTo(box.x, mid + half);
      ctx.closePath(); ctx.fill(); ctx.stroke();
      right = box.x - 4;
    }
    tag(ctx, layout, "goal-label", gettext("goal"), (w, h) => {
      const near = this.bandY(h, forward), far = this.bandY(h, !forward);
      return [[right - w, near], [this.w - w - 4, near], [this.w - w - 4, far]];
    });
  }

  // A car: a rectangle with a windscreen at the front; returns its box on the canvas, or null
  // where it is outside the view.
  car(cam, x, y, heading, kind, alpha = 1) {
    const ctx = this.ctx;
    const [sx, sy] = this.toScreen(cam, x, y);
    let len = this.world.car_length * cam.ys, wid = this.world.car_width * cam.xs;
    if (cam.xs !== cam.ys) { len = Math.max(len, 14); wid = Math.min(wid, 0.45 * len); }
    if (sx < -len || sx > this.w + len) return null;
    const angle = Math.atan2(Math.cos(heading) * cam.xs, Math.sin(heading) * cam.ys);
    ctx.save();
    ctx.globalAlpha = alpha;
    ctx.translate(sx, sy);
    ctx.rotate(angle);
    ctx.fillStyle = colors()[kind];
    ctx.strokeStyle = colors()[`${kind}Edge`];
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.rect(-len / 2, -wid / 2, len, wid);
    ctx.fill(); ctx.stroke();
    ctx.fillStyle = kind === "robot" ? "rgba(30, 40, 60, 0.55)" : "rgba(255, 255, 255, 0.55)";  // windscreen: the front
    ctx.fillRect(len * 0.12, -wid * 0.38, len * 0.16, wid * 0.76);
    ctx.restore();
    const c = Math.abs(Math.cos(angle)), s = Math.abs(Math.sin(angle));
    const bw = len * c + wid * s + 2, bh = len * s + wid * c + 2;  // + the outline
    return { kind: `${kind}-car`, x: sx - bw / 2, y: sy - bh / 2, w: bw, h: bh, len, angle };
  }

  // The other car outside the view: an arrow at that edge in its lane, and its distance on a white
  // tag in the band beside its lane, on whichever side (or row) is free of the other labels and marks.
  offscreen(cam, x, y, ry, layout) {
    const ctx = this.ctx;
    const [sx, sy] = this.toScreen(cam, x, y);
    const ahead = sx > this.w, dir = ahead ? 1 : -1;
    const ax = ahead ? this.w - 4 - 13 : 4;
    const arrow = layout.place("other-arrow", 13, 16, [[ax, sy - 8], [ax, sy - 26], [ax, sy + 10]]);
    const tip = ahead ? arrow.x + 13 : arrow.x, mid = arrow.y + 8;
    ctx.fillStyle = colors().other;
    ctx.strokeStyle = colors().otherEdge;
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    ctx.moveTo(tip, mid); ctx.lineTo(tip - dir * 12, mid - 7); ctx.lineTo(tip - dir * 12, mid + 7);
    ctx.closePath(); ctx.fill(); ctx.stroke();
    const distance = { feet: Math.round(Math.abs(y - ry)) };
    const text = ahead ? interpolate(gettext("other car %(feet)s ft ahead"), distance, true)
      : interpolate(gettext("other car %(feet)s ft behind"), distance, true);
    tag(ctx, layout, "other-label", text, (w, h) => {
      const top = sy < this.h / 2, near = this.bandY(h, top), far = this.bandY(h, !top);
      const edge = ahead ? this.w - w - 4 : 4, other = ahead ? 4 : this.w - w - 4;
      return [[edge, near], [this.w / 2 - w / 2, near], [other, near], [edge, far], [this.w / 2 - w / 2, far]];
    });
  }

  begin() {
    this.resize();
    this.ctx = this.canvas.getContext("2d");
    this.ctx.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
  }

  // The camera for time t: one scale for the whole drive (the road does not zoom in and out),
  // wide enough along the road to hold both cars whenever they interact; it centres between
  // them while this canvas holds both (a wide one holds them further apart than they interact),
  // and keeps the robot in view with the other car towards the edge when they are further apart.
  camera(r, o) {
    const holds = Math.max(this.span, this.w / this.s - this.world.car_length - 2 * MARGIN_FT);
    const dy = Math.max(-holds, Math.min(holds, o.y - r.y));
    return { cy: r.y + dy / 2, anchor: 0.5, xs: this.s, ys: this.s };
  }

  // One animation frame at time t.
  drawFrame(t) {
    this.t = t;
    this.begin();
    const r = sample(this.robot, t, this.dt);
    const o = sample(this.env.other, t, this.dt);
    const cam = this.camera(r, o);
    this.drawRoad(cam);
    const other = this.car(cam, o.x, o.y, Math.PI / 2, "other");
    const robot = this.car(cam, r.x, r.y, r.h, "robot");
    const layout = new Layout(this.w, this.h);
    for (const box of [other, robot]) if (box) layout.avoid(box);
    this.goalMarks(cam, layout);
    this.label(layout, interpolate(gettext("t = %(seconds)s s"), { seconds: t.toFixed(1) }, true));
    if (!other) this.offscreen(cam, o.x, o.y, r.y, layout);
    this.boxes = layout.boxes;
    this.cars = layout.obstacles;
    this.lastFrame = { robot: this.toScreen(cam, r.x, r.y), other: other ? this.toScreen(cam, o.x, o.y) : null,
      robotLength: robot ? robot.len : 0, robotAngle: robot ? robot.angle : 0 };
  }

  // Still view of the whole drive: earlier positions faint, later ones more opaque.
  drawTrail() {
    this.begin();
    const robotY = this.robot.map((s) => s[1]);
    const lo = Math.min(...robotY) - 20, hi = Math.max(...robotY) + 20;
    const ys = Math.max(this.s / MAX_SQUEEZE, Math.min(this.s, (this.w - 16) / (hi - lo)));
    const cam = { cy: (lo + hi) / 2, anchor: 0.5, xs: this.s, ys };
    this.drawRoad(cam);
    const layout = new Layout(this.w, this.h);
    const last = this.robot.length - 1;
    for (let k = 0; k <= last; k += (last % 2 === 0 ? 2 : 1)) {
      const alpha = 0.12 + 0.88 * (k / last);
      const o = this.env.other[k], r = this.robot[k];
      for (const box of [this.car(cam, o[0], o[1], Math.PI / 2, "other", alpha),
        this.car(cam, r[0], r[1], r[2], "robot", alpha)]) if (box) layout.avoid(box);
    }
    this.goalMarks(cam, layout);
    this.label(layout, gettext("trail: whole drive"));
    this.boxes = layout.boxes;
    this.cars = layout.obstacles;
  }

  // The time (or view) label: in the band below the road at the left, else above it, else at the right.
  label(layout, text) {
    tag(this.ctx, layout, "time-label", text, (w, h) => [[4, this.bandY(h, false)], [4, this.bandY(h, true)],
      [this.w - w - 4, this.bandY(h, false)]], { size: 12 });
  }

  redraw() {
    if (this.mode === "trail") this.drawTrail(); else this.drawFrame(this.t);
  }
}

// Along-road distance (ft) the animation's view must hold between the two cars: the largest
// gap while they interact (within INTERACTION_FT); 0 where they never do.
export function framedSpan(robot, other) {
  const gaps = robot.map((r, k) => Math.abs(other[Math.min(k, other.length - 1)][1] - r[1]));
  const near = gaps.filter((g) => g <= INTERACTION_FT);
  return near.length ? Math.max(...near) : 0;
}
