"""The delivery yard's scene (static/studyapp/scenes/gridworld.js) in Debian's Chromium: the robot is
drawn at the centre of the cell its path names at each move's time and halfway between two cells
halfway through a move; the walls, the mud and the free cells are drawn in the palette's colours
(the page's --scene-* properties, from the domain's Python palette), on an undistorted canvas as tall
as the yard at its width plus the label strip;
the move label stays in its strip under the yard; and once the robot has entered the cart's cell the
cart goes with it (it is no longer drawn where it stood).  The yards are real ones
(get_domain("gridworld").scene_payload), the paths built here by a breadth-first search, so the test
depends on no planner.  A grid of scenes at the widths participants get is written to
test-output/gridworld_scene.png to look at."""
from __future__ import annotations

from collections import Counter, deque
from pathlib import Path

import pytest

from studyapp.scenes import palette_css
from teaching.api import get_domain

OUT = Path(__file__).resolve().parents[2] / "test-output"
WALL, MUD, DOG, CART = 1, 2, 3, 4  # teaching/domains/gridworld/world.py's cell codes
STRIP = 16  # px under the yard for the move label (gridworld.js)
WIDTHS = (108, 144, 320)  # a phone's test option, a laptop's, a training example

pytestmark = [pytest.mark.browser, pytest.mark.slow]


def env_id(start_row: int, goal_row: int, obstacle: int, cart: int) -> int:
    """The id of a yard by its parts (teaching/domains/gridworld/environments.py's enumeration)."""
    return ((start_row * 6 + goal_row) * 97 + obstacle) * 5 + cart


def bfs(cells: list[list[int]], a: tuple[int, int], b: tuple[int, int]) -> list[list[int]]:
    """A shortest path of [col, row] cells from a to b, walls and the dog impassable."""
    h, w = len(cells), len(cells[0])
    prev = {a: None}
    queue = deque([a])
    while queue:
        c, r = queue.popleft()
        for dc, dr in ((1, 0), (0, 1), (-1, 0), (0, -1)):
            n = (c + dc, r + dr)
            if 0 <= n[0] < w and 0 <= n[1] < h and n not in prev and cells[n[1]][n[0]] not in (WALL, DOG):
                prev[n] = (c, r)
                queue.append(n)
    path, at = [], b
    while at is not None:
        path.append(list(at))
        at = prev[at]
    return path[::-1]


def find(cells, code) -> list[tuple[int, int]]:
    return [(c, r) for r, line in enumerate(cells) for c, v in enumerate(line) if v == code]


def cases() -> list[dict]:
    """Yards with mud, a wall and a dog, and carts; one path straight to D, and two via the cart."""
    domain = get_domain("gridworld")
    out = []
    for name, parts, via_cart in (("mud, via the cart", (0, 5, 10, 3), True),
                                  ("dog and wall, direct", (2, 3, 87, 2), False),
                                  ("dog and wall, via the cart", (2, 3, 87, 2), True),
                                  ("dog, direct", (4, 1, 83, 0), False)):
        env = domain.scene_payload(env_id(*parts))
        yard = env["yard"]
        start, goal = tuple(yard["start"]), tuple(yard["goal"])
        if via_cart:
            (cart,) = find(yard["cells"], CART)
            robot = bfs(yard["cells"], start, cart) + bfs(yard["cells"], cart, goal)[1:]
        else:
            robot = bfs(yard["cells"], start, goal)
        assert all(abs(a[0] - b[0]) + abs(a[1] - b[1]) == 1 for a, b in zip(robot, robot[1:], strict=False))
        out.append({"name": name, "env": env, "robot": robot})
    kinds = {v for case in out for line in case["env"]["yard"]["cells"] for v in line}
    assert {WALL, MUD, DOG, CART} <= kinds  # the enumeration still gives these yards
    return out


def rgb(hex_colour: str) -> tuple[int, int, int]:
    return tuple(int(hex_colour[i:i + 2], 16) for i in (1, 3, 5))


def near(got, want: str, tol: int = 8) -> bool:
    return all(abs(g - w) <= tol for g, w in zip(got[:3], rgb(want), strict=True))


# Per case and width: the canvas's sizes, where the robot was drawn at each move's time and halfway
# through each move, the label boxes of a frame and of the trail, and pixels (in device px, read
# from the buffer) at given CSS px points, before the robot starts and after it passed the cart.
CHECK = """async ({cases, widths}) => {
  const { Scene } = await import("/static/studyapp/scenes/gridworld.js");
  const out = [];
  for (const width of widths) {
    const canvas = document.createElement("canvas");
    canvas.style.width = width + "px";
    document.body.replaceChildren(canvas);
    for (const c of cases) {
      const scene = new Scene(canvas, c.env, c.robot);
      const ctx = canvas.getContext("2d");
      const pixel = ([x, y]) => Array.from(
        ctx.getImageData(Math.floor(x * scene.dpr), Math.floor(y * scene.dpr), 1, 1).data);
      const patch = (x, y, w, h) => {
        const d = ctx.getImageData(Math.round(x * scene.dpr), Math.round(y * scene.dpr),
                                   Math.round(w * scene.dpr), Math.round(h * scene.dpr)).data;
        const px = [];
        for (let i = 0; i < d.length; i += 4) px.push([d[i], d[i + 1], d[i + 2]]);
        return px;
      };
      const dt = c.env.dt, n = c.robot.length - 1;
      const at = [], half = [];
      for (let k = 0; k <= n; k++) {
        scene.drawFrame(k * dt); at.push(scene.lastFrame.robot);
        if (k < n) { scene.drawFrame((k + 0.5) * dt); half.push(scene.lastFrame.robot); }
      }
      scene.drawFrame(0);
      const rect = canvas.getBoundingClientRect();
      const r = {name: c.name, width, w: scene.w, h: scene.h, bufW: canvas.width, bufH: canvas.height,
                 cssW: rect.width, cssH: rect.height, dpr: scene.dpr, duration: scene.duration, at, half,
                 frameBoxes: scene.boxes, before: c.points.map(pixel),
                 patches: c.patches.map(([x, y, w, h]) => patch(x, y, w, h))};
      scene.drawFrame(c.after * dt);
      r.after = c.points.map(pixel);
      r.afterRobot = scene.lastFrame.robot;
      scene.mode = "trail"; scene.redraw();
      r.trailBoxes = scene.boxes;
      out.push(r);
    }
  }
  return out;
}"""


def geometry(w: int, h: int, cols: int, rows: int) -> tuple[int, int, int]:
    """Cell size and the yard's top-left corner (CSS px): whole-px square cells as large as fit above
    the label strip, the yard centred."""
    s = int(min(w / cols, (h - STRIP) / rows))
    return s, (w - cols * s) // 2, (h - STRIP - rows * s) // 2


def probes(case: dict, w: int, h: int) -> tuple[list, list, int | None]:
    """Points (CSS px) to read: a wall cell's centre, a free cell's centre (off the path), four
    points inside the cart square off its centre lines; patches: a mud cell's top-left corner area."""
    cells = case["env"]["yard"]["cells"]
    rows, cols = len(cells), len(cells[0])
    s, ox, oy = geometry(w, h, cols, rows)
    centre = lambda c, r, dx=0.0, dy=0.0: [ox + (c + 0.5 + dx) * s, oy + (r + 0.5 + dy) * s]  # noqa: E731
    yard = case["env"]["yard"]
    on_path = {tuple(p) for p in case["robot"]}
    free = next((c, r) for c, r in find(cells, 0)
                if (c, r) not in on_path and not yard["near_dog"][r][c] and [c, r] not in (yard["start"], yard["goal"]))
    points = {"free": centre(*free)}
    for cell in find(cells, WALL)[:1]:
        points["wall"] = centre(*cell)
    carts = find(cells, CART)
    fetched = next((k for k, p in enumerate(case["robot"]) if tuple(p) in carts), None)
    for i, (dx, dy) in enumerate(((-0.22, -0.22), (0.22, -0.22), (-0.22, 0.22), (0.22, 0.22))):
        if carts:
            points[f"cart{i}"] = centre(*carts[0], dx, dy)
    patches = {}
    for c, r in find(cells, MUD)[:1]:
        patches["mud"] = [ox + c * s + 1, oy + r * s + 1, s * 0.3, s * 0.3]
    return points, patches, fetched


def test_the_yard_scene_draws_cells_robot_and_cart_where_the_data_say(live_server, browser):
    palette = get_domain("gridworld").palette
    base = cases()
    results = {}
    shots = []
    for dpr in (1, 2):
        page = browser.new_page(viewport={"width": 1500, "height": 900}, device_scale_factor=dpr)
        errors = []
        page.on("pageerror", lambda exc, errors=errors: errors.append(str(exc)))
        page.goto(f"{live_server.url}/static/studyapp/study.css")  # same origin as the module
        page.add_style_tag(content=palette_css(get_domain("gridworld")))  # as a page writes it
        for width in WIDTHS:
            w = max(120, width)  # the scene's smallest drawing (a narrower canvas is scaled down)
            h = round(w * 3 / 4) + STRIP  # the 8 x 6 yard at that width, and the label strip
            batch = []
            meta = []
            for case in base:
                points, patches, fetched = probes(case, w, h)
                n = len(case["robot"]) - 1
                after = min(n, fetched + 1) if fetched is not None else 0
                batch.append({**case, "points": list(points.values()), "patches": list(patches.values()),
                              "after": after})
                meta.append((case, list(points), list(patches), fetched, after))
            got = page.evaluate(CHECK, {"cases": batch, "widths": [width]})
            for r, m in zip(got, meta, strict=True):
                results[(dpr, width, r["name"])] = (r, m)
        assert not errors, errors
        if dpr == 1:
            shots.append(page)
        else:
            page.close()
    screenshot(shots[0], base)

    for (dpr, width, name), (r, (case, point_names, patch_names, fetched, _after)) in results.items():
        where = (dpr, width, name)
        cells = case["env"]["yard"]["cells"]
        rows, cols = len(cells), len(cells[0])
        # the canvas: the yard at its width plus the label strip, in CSS px and in its buffer (device
        # px), not distorted on the page
        assert r["dpr"] == dpr, where
        assert r["w"] == max(120, width) and r["h"] == round(r["w"] * rows / cols) + STRIP, where
        assert (r["bufW"], r["bufH"]) == (r["w"] * dpr, r["h"] * dpr), where
        assert r["cssW"] == width and r["cssH"] / r["cssW"] == pytest.approx(r["h"] / r["w"], abs=0.02), where
        # 3. the duration: one dt per move
        dt = case["env"]["dt"]
        assert r["duration"] == pytest.approx((len(case["robot"]) - 1) * dt), where
        # 1. the robot at its cell's centre at each move's time, halfway between two cells halfway through
        s, ox, oy = geometry(r["w"], r["h"], cols, rows)
        def centre(c, row, s=s, ox=ox, oy=oy):
            return ox + (c + 0.5) * s, oy + (row + 0.5) * s
        assert len(r["at"]) == len(case["robot"]), where
        for k, (got, (c, row)) in enumerate(zip(r["at"], case["robot"], strict=True)):
            want = centre(c, row)
            assert abs(got[0] - want[0]) <= 1 and abs(got[1] - want[1]) <= 1, (where, k, got, want)
        for k, got in enumerate(r["half"]):
            a, b = centre(*case["robot"][k]), centre(*case["robot"][k + 1])
            want = ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)
            assert abs(got[0] - want[0]) <= 1 and abs(got[1] - want[1]) <= 1, (where, k, got, want)
        # 2. the palette's colours where the yard has a wall, mud and a free cell (before the robot moves)
        before = dict(zip(point_names, r["before"], strict=True))
        assert near(before["free"], palette["free"]), (where, before["free"])
        if "wall" in before:
            assert near(before["wall"], palette["wall"]), (where, before["wall"])
        for pname, px in zip(patch_names, r["patches"], strict=True):
            assert pname == "mud"
            common, _ = Counter(map(tuple, px)).most_common(1)[0]
            assert near(common, palette["mud"]), (where, common)  # the cell is mud ...
            assert not near(common, palette["free"]), where
        # 3. the label boxes: inside the canvas, apart, and under the yard (not over its cells)
        for boxes in (r["frameBoxes"], r["trailBoxes"]):
            assert [b["kind"] for b in boxes] == ["time-label"], (where, boxes)
            for i, b in enumerate(boxes):
                assert b["x"] >= 0 and b["y"] >= 0 and b["x"] + b["w"] <= r["w"] and b["y"] + b["h"] <= r["h"], where
                assert b["y"] >= oy + rows * s - 1, (where, b)
                for o in boxes[i + 1:]:
                    assert not (b["x"] < o["x"] + o["w"] and o["x"] < b["x"] + b["w"]
                                and b["y"] < o["y"] + o["h"] and o["y"] < b["y"] + b["h"]), (where, b, o)
        # 4. the cart: in its cell before the robot comes; gone from it once the robot has passed through
        cart_names = [p for p in point_names if p.startswith("cart")]
        after_px = dict(zip(point_names, r["after"], strict=True))
        for p in cart_names:
            assert near(before[p], palette["cart"]), (where, p, before[p])
            if fetched is not None:
                assert not near(after_px[p], palette["cart"], tol=40), (where, p, after_px[p])
            else:  # a path that never enters the cart's cell leaves it where it is
                assert near(after_px[p], palette["cart"]), (where, p, after_px[p])
    assert any(m[3] is not None for _, m in results.values())  # some path went through the cart


# The scenes to look at: a row per case; per width, a frame halfway through the path and the trail.
GRID = """async ({cases, widths}) => {
  const { Scene } = await import("/static/studyapp/scenes/gridworld.js");
  const grid = document.createElement("div");
  grid.id = "yard-grid";
  grid.style.cssText = "display: grid; grid-template-columns: repeat(" + (2 * widths.length) + ", max-content);"
    + " gap: 10px; padding: 8px; align-items: end; background: #fff";
  document.body.replaceChildren(grid);
  for (const c of cases) {
    for (const width of widths) {
      for (const mode of ["frame", "trail"]) {
        const cell = document.createElement("div");
        cell.style.cssText = "font: 10px sans-serif; width: " + width + "px";
        cell.textContent = (mode === "frame" ? "mid-way" : "trail") + ", " + width + " px: " + c.name;
        const canvas = document.createElement("canvas");
        canvas.style.cssText = "display: block; width: " + width + "px";
        cell.append(canvas);
        grid.append(cell);
        const scene = new Scene(canvas, c.env, c.robot);
        scene.mode = mode;
        scene.t = scene.duration / 2;
        scene.redraw();
      }
    }
  }
}"""


def screenshot(page, base: list[dict]) -> None:
    page.evaluate(GRID, {"cases": base, "widths": list(WIDTHS)})
    OUT.mkdir(exist_ok=True)
    page.locator("#yard-grid").screenshot(path=str(OUT / "gridworld_scene.png"))
