// Where a scene's labels go (plain ES module): every label and mark drawn on a canvas is a box in
// one Layout, and a label is put in the first of its candidate places that is inside the canvas
// and overlaps no box already there, else stacked in the first free row; so no two labels of a
// canvas overlap and none covers a mark the scene drew first or a thing the scene asked it to
// avoid (the robot, what it meets). The boxes stay on the scene (scene.boxes) for the browser tests to check.

export function intersects(a, b) {
  return a.x < b.x + b.w && b.x < a.x + a.w && a.y < b.y + b.h && b.y < a.y + a.h;
}

export class Layout {
  constructor(w, h) {
    this.w = w;
    this.h = h;
    this.boxes = [];  // {kind, x, y, w, h} in CSS px
    this.obstacles = [];  // what no label may cover, though it is not one (the robot): {kind, x, y, w, h}
  }

  avoid(box) {
    this.obstacles.push(box);
  }

  reserve(kind, x, y, w, h) {
    const box = { kind, x, y, w, h };
    this.boxes.push(box);
    return box;
  }

  fits(box) {
    return box.x >= 0 && box.y >= 0 && box.x + box.w <= this.w && box.y + box.h <= this.h
      && !this.boxes.some((b) => intersects(b, box)) && !this.obstacles.some((b) => intersects(b, box));
  }

  // The first free place among `candidates` ([x, y] top-left corners), else the first free one
  // scanning rows upwards from the bottom (left and right edge of each row); reserves it.
  place(kind, w, h, candidates) {
    for (const [x, y] of candidates) {
      const box = { kind, x: Math.round(x), y: Math.round(y), w, h };
      if (this.fits(box)) return this.reserve(kind, box.x, box.y, w, h);
    }
    for (let y = this.h - h - 2; y >= 2; y -= 4) {
      for (const x of [4, this.w - w - 4, (this.w - w) / 2]) {
        const box = { kind, x: Math.round(x), y, w, h };
        if (this.fits(box)) return this.reserve(kind, box.x, y, w, h);
      }
    }
    const [x, y] = candidates[0];  // a canvas too small for every label: at least draw it
    return this.reserve(kind, Math.round(x), Math.round(y), w, h);
  }
}

// A text tag: dark text on a near-white box (at least 13:1 on any background), placed by `layout`.
export function tag(ctx, layout, kind, text, candidates, { size = 11, bold = false } = {}) {
  ctx.font = `${bold ? "700 " : ""}${size}px system-ui, sans-serif`;
  const w = Math.ceil(ctx.measureText(text).width) + 6, h = size + 4;
  const box = layout.place(kind, w, h, candidates(w, h));
  ctx.fillStyle = "rgba(255, 255, 255, 0.94)";
  ctx.fillRect(box.x, box.y, box.w, box.h);
  ctx.fillStyle = "#111";
  ctx.textBaseline = "alphabetic";
  ctx.fillText(text, box.x + 3, box.y + size);
  return box;
}
