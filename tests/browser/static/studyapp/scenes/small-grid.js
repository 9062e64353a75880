// The small grid test domain's scene (tests/teaching/small_grid_domain.py), served only by the test
// that registers the domain: on the grid scene (/static/studyapp/scenes/grid.js) it draws only its
// field (puddles filled, sand dotted) and S and D; the robot is the grid scene's disc.

import { GridScene } from "/static/studyapp/scenes/grid.js";

const PUDDLE = 1, SAND = 2;   // small_grid_domain.py's codes (0: free)
// the palette colours this scene reads beside the grid scene's own (check-domain reads this list)
const NAMES = ["free", "puddle", "sand", "sandMark"];

export class Scene extends GridScene {
  constructor(canvas, env, robot) {
    if (!env.field) throw new Error("scene data without a field (env.field)");
    super(canvas, env, robot, env.field.cells, NAMES);
    this.field = env.field;
  }

  drawWorld() {
    const { ctx, cell: s, c } = this;
    this.drawCells((kind, r, col, x, y) => {
      ctx.fillStyle = kind === PUDDLE ? c.puddle : kind === SAND ? c.sand : c.free;
      ctx.fillRect(x, y, s, s);
      if (kind === SAND) this.dots(x, y, c.sandMark);
    });
  }

  drawMarks() {
    this.letters([[this.field.start, "S"], [this.field.goal, "D"]], this.c.free);
  }
}
