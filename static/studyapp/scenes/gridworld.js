// Drawing and animating one delivery-yard scene on a canvas (plain ES module, no build step).
//
// The yard is seen from above, one square per cell, row 0 at the top (as the staff contact
// sheet, teaching/domains/gridworld/sheet.py, draws it): walls dark, mud brown and dotted, the dog
// a red disc with the cells next to it hatched red, the cart a blue square, the start S and the
// drop-off D.  The robot's rows are [col, row] cells, one per move.  The path is one line, thin
// while the robot carries the parcel by hand and thick once it pushes the cart, as on the sheet.
// Not colour alone: every kind of cell also differs in lightness, a pattern or a word, so the yard
// reads in greyscale too.  Sizing, playback, patterns, labels and the trail are the grid scene's
// (./grid.js); this module draws the yard, the path's two widths and the robot.

import { gettext } from "../i18n.js";
import { GridScene, WORDS_FROM } from "./grid.js";

const WALL = 1, MUD = 2, DOG = 3, CART = 4;   // teaching/domains/gridworld/world.py's codes (0: free)
const NAMES = ["free", "wall", "mud", "mudMark", "near", "nearMark", "dog", "cart"];

export class Scene extends GridScene {
  constructor(canvas, env, robot) {
    // env: {dt, yard: {cells, near_dog, start, goal}}; robot: first the start, last the drop-off
    if (!env.yard) throw new Error("scene data without a yard (env.yard)");
    super(canvas, env, robot, env.yard.cells, NAMES);
    this.yard = env.yard;
    // The row at which the robot enters the cart's cell (it pushes the cart from then on), else none.
    const k = robot.findIndex((p) => this.yard.cells[p[1]][p[0]] === CART);
    this.fetched = k < 0 ? Infinity : k;
  }

  // The yard: cells, their patterns, the grid, the dog and the cart (unless the robot has it).
  drawWorld(k) {
    const { ctx, cell: s, c } = this;
    const near = this.yard.near_dog;
    this.drawCells((kind, r, col, x, y) => {
      ctx.fillStyle = kind === WALL ? c.wall : kind === MUD ? c.mud : near[r][col] ? c.near : c.free;
      ctx.fillRect(x, y, s, s);
      if (kind === MUD) this.dots(x, y, c.mudMark);
      else if (kind !== WALL && near[r][col]) this.hatch(x, y, c.nearMark);
    });
    const words = s >= WORDS_FROM;
    this.cells.forEach((line, r) => line.forEach((kind, col) => {
      const [x, y] = this.toScreen(col, r);
      if (kind === DOG) {
        ctx.fillStyle = c.dog;
        ctx.beginPath(); ctx.arc(x, y, 0.38 * s, 0, 2 * Math.PI); ctx.fill();
        if (words) this.word(gettext("dog"), x, y, 0.27 * s, c.free);
      } else if (kind === CART && k < this.fetched) {
        this.cart(x, y, 0.66 * s);
        if (words) this.word(gettext("cart"), x, y, 0.25 * s, c.free);
      }
    }));
  }

  // S and D over the path, haloed in the free cells' colour.
  drawMarks() {
    this.letters([[this.yard.start, "S"], [this.yard.goal, "D"]], this.c.free);
  }

  cart(x, y, size) {
    this.ctx.fillStyle = this.c.cart;
    this.ctx.fillRect(x - size / 2, y - size / 2, size, size);
  }

  // The path up to row index `to` (fractional): thin while carrying by hand, thick from the cart on.
  drawPath(to) {
    const s = this.cell;
    this.ctx.strokeStyle = this.c.path;
    this.ctx.lineCap = "round"; this.ctx.lineJoin = "round";
    this.strokePath(0, Math.min(to, this.fetched), Math.max(1.5, 0.06 * s));
    this.strokePath(this.fetched, to, Math.max(3.5, 0.15 * s));
  }

  // The robot at row index k: a light disc with a dark outline, the parcel on it, on the cart once fetched.
  drawRobot(k) {
    const { ctx, cell: s, c } = this;
    const [x, y] = this.toScreen(...this.at(k));
    if (k >= this.fetched) this.cart(x, y, 0.78 * s);
    this.disc(x, y);
    const p = Math.max(3, 0.24 * s);   // the parcel: a small outlined square, cardboard-coloured
    ctx.fillStyle = c.mudMark;         // (the palette's tan; no colour of its own)
    ctx.lineWidth = Math.max(1, s / 36);
    ctx.fillRect(x - p / 2, y - p / 2, p, p);
    ctx.strokeRect(x - p / 2, y - p / 2, p, p);
    return [x, y];
  }
}
