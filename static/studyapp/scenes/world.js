// Drawing and animating a grid world from a file (plain ES module, no build step): every world
// described by a TOML file (docs/gridworlds.md) shares this scene, so a new world needs no JavaScript.
//
// The world is seen from above, one square per cell, row 0 at the top: free cells light, walls dark,
// each declared kind of cell in its own colour (the domain's palette, --scene-cell-<kind>) and its
// own pattern (dots, a hatch, both: by its place in the file), so kinds differ in more than hue; S marks the start, G a goal, D the object's destination; the object is a square (on the robot
// while it holds it).  The robot's rows are [col, row, holding], one per action.  Sizing, playback,
// patterns, letters and the trail are the grid scene's (./grid.js).

import { GridScene } from "./grid.js";

const NAMES = ["free", "wall", "object"];
const camel = (name) => name.replace(/-([a-z])/g, (_, ch) => ch.toUpperCase());

export class Scene extends GridScene {
  constructor(canvas, env, robot) {
    // env: {dt, world: {cells, labels, start, object, destination, goals}}; robot: [[col, row, holding]]
    if (!env.world) throw new Error("scene data without a world (env.world)");
    const kinds = [...new Set(env.world.cells.flat())].filter((kind) => kind && kind !== "wall");
    super(canvas, env, robot, env.world.cells, [...NAMES, ...kinds.map((kind) => camel(`cell-${kind}`))]);
    this.world = env.world;
    // Where the object lies before row k: its first place, then wherever the robot last put it down.
    this.places = [];
    let place = env.world.object;
    robot.forEach((p, i) => {
      if (i > 0 && robot[i - 1][2] === 1 && p[2] === 0) place = [p[0], p[1]];
      this.places.push(p[2] === 1 ? "held" : place);
    });
  }

  // The world: cells in their kinds' colours and patterns, the object where it lies at row k.
  drawWorld(k) {
    const { ctx, cell: s, c } = this;
    const order = Object.keys(this.world.labels);
    this.drawCells((kind, r, col, x, y) => {
      ctx.fillStyle = kind === "wall" ? c.wall : kind ? c[camel(`cell-${kind}`)] : c.free;
      ctx.fillRect(x, y, s, s);
      if (!kind || kind === "wall") return;
      // a pattern per kind, in the file's order: dots, a hatch, then both
      const i = order.indexOf(kind) % 3;
      if (i !== 1) this.dots(x, y, c.free);
      if (i !== 0) this.hatch(x, y, c.free);
    });
    // rounded as drawRobot rounds, so the object is on the ground or on the robot, never both
    const place = this.places[Math.min(Math.round(k), this.places.length - 1)];
    if (place && place !== "held") this.object(...this.toScreen(place[0], place[1]), 0.5 * s);
  }

  drawMarks() {
    const marks = [[this.world.start, "S"], ...this.world.goals.map((g) => [g, "G"])];
    if (this.world.destination) marks.push([this.world.destination, "D"]);
    this.letters(marks, this.c.free);
  }

  object(x, y, size) {
    this.ctx.fillStyle = this.c.object;
    this.ctx.fillRect(x - size / 2, y - size / 2, size, size);
  }

  // The robot at row index k (the grid scene's disc), the object on it while it holds it.
  drawRobot(k) {
    const [x, y] = super.drawRobot(k);
    if (this.places[Math.min(Math.round(k), this.places.length - 1)] === "held") this.object(x, y, 0.3 * this.cell);
    return [x, y];
  }
}
