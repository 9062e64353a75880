// "Show the way" test step: the participant moves the robot from its start, one action at a time (arrow
// keys, the on-screen arrows, or a tap on the next cell; Backspace or Undo steps back), until the episode
// ends, and submits the actions.  The page offers only what the world allows (the page's "show-rules":
// Domain.show_rules, the same rules as the server's planner); the server replays and scores the actions
// again and refuses any it does not allow, whatever this page let through.
import { gettext, interpolate, ngettext } from "./i18n.js";
import { lockOnSubmit, readJSON, sceneClass, stepMemory, withView } from "./player.js";

const Scene = await sceneClass();

const env = withView(readJSON("scene-data"));
const rules = readJSON("show-rules");
const world = env.world;
const root = document.querySelector("[data-show-scene]");
const canvas = root.querySelector("canvas");
const form = document.getElementById("show-form");
const field = form.querySelector('input[name="moves"]');
const submit = form.querySelector('button[type="submit"]');
const hint = form.querySelector("[data-hint]");
const status = document.querySelector("[data-status]");
const why = document.querySelector("[data-why]");
const memory = stepMemory(form);

// (d_col, d_row) on screen, row 0 at the top
const STEPS = { right: [1, 0], up: [0, -1], down: [0, 1], left: [-1, 0] };
const same = (a, b) => Array.isArray(a) && Array.isArray(b) && a[0] === b[0] && a[1] === b[1];
const isGoal = (cell) => world.goals.some((g) => same(g, cell));

// The state after `moves` from the start: where the robot is, where the object is ("held", a cell or
// null), the rows drawn ([col, row, holding] per action) and how the episode ended (null: it goes on);
// null if a move is not allowed where it is taken or comes after the end.
function replay(moves) {
  let at = world.start, place = world.object, ended = null;
  const rows = [[...at, place === "held" ? 1 : 0]];
  for (const move of moves) {
    const next = ended ? null : after(at, place, move);
    if (!next) return null;
    [at, place, ended] = next;
    if (move !== "exit") rows.push([...at, place === "held" ? 1 : 0]);
  }
  return { at, place, ended, rows };
}

// [cell, object's place, ending or null] after `move` from (at, place); null if the world does not allow it.
function after(at, place, move) {
  if (STEPS[move]) {
    const cell = [at[0] + STEPS[move][0], at[1] + STEPS[move][1]];
    const inside = cell[1] >= 0 && cell[1] < rules.blocked.length && cell[0] >= 0 && cell[0] < rules.blocked[0].length;
    if (!inside || rules.blocked[cell[1]][cell[0]]) return null;
    return [cell, place, isGoal(cell) ? "goal" : null];
  }
  if (move === "pickup") return Array.isArray(place) && same(place, at) ? [at, "held", null] : null;
  if (move === "drop") {
    if (place !== "held") return null;
    return [at, [...at], rules.deliver && same(world.destination, at) ? "delivered" : null];
  }
  if (move === "exit") return rules.exit ? [at, place, "exit"] : null;
  return null;
}

// a remembered way the page would not allow (another version of the page) is dropped whole, not half-kept
const saved = memory.load().moves;
let moves = Array.isArray(saved) && replay(saved) ? saved : [];

const ENDINGS = {
  goal: gettext("the robot reached a goal"),
  // the object's name is the domain's (show_rules), in the study's language (the view translates it)
  delivered: rules.object ? interpolate(gettext("the robot delivered the %(object)s"), { object: rules.object }, true)
    : gettext("the robot delivered the object"),
  exit: gettext("you stopped here"),
};

function render() {
  const state = replay(moves);
  const scene = new Scene(canvas, env, state.rows);
  canvas.scene = scene;  // for the browser tests
  if (scene.drawShown) scene.drawShown(); else scene.drawFrame(scene.duration);
  field.value = moves.join(" ");
  for (const button of document.querySelectorAll("[data-move]")) {
    button.disabled = Boolean(state.ended) || moves.length >= rules.max_actions
      || !after(state.at, state.place, button.dataset.move);
  }
  document.querySelector('[data-action="undo"]').disabled = moves.length === 0;
  document.querySelector('[data-action="restart"]').disabled = moves.length === 0;
  const steps = { n: moves.length };
  status.textContent = state.ended
    ? interpolate(ngettext("Finished in %(n)s step: %(ending)s.", "Finished in %(n)s steps: %(ending)s.", moves.length),
      { ...steps, ending: ENDINGS[state.ended] }, true)
    : interpolate(ngettext("%(n)s step so far; not finished yet.", "%(n)s steps so far; not finished yet.", moves.length),
      steps, true);
  submit.disabled = !state.ended;
  hint.textContent = state.ended ? gettext("You can undo, or continue.") : gettext("Move the robot until it has finished to continue.");
  root.dataset.moves = field.value;
  root.dataset.ended = state.ended || "";
  memory.save({ moves });
}

// Why `move` does nothing from `state` (a sentence for the participant), or "" when it can be made.
function refusal(state, move) {
  if (state.ended) return gettext("The robot has finished: undo a step to change the way.");
  if (moves.length >= rules.max_actions) return gettext("That is as many steps as a way may have: undo some.");
  if (after(state.at, state.place, move)) return "";
  if (STEPS[move]) return gettext("The robot cannot go there: a wall or the edge of the grid.");
  if (move === "pickup") return gettext("There is nothing to pick up where the robot is.");
  if (move === "drop") return gettext("The robot is not holding anything to put down.");
  return gettext("That move is not possible here.");
}

function act(move) {
  const state = replay(moves);
  const no = refusal(state, move);
  why.textContent = no;
  if (no) return false;
  moves.push(move);
  render();
  return true;
}

function undo() {
  if (moves.length) { moves.pop(); render(); }
}

for (const button of document.querySelectorAll("[data-move]")) {
  button.addEventListener("click", () => act(button.dataset.move));
}
document.querySelector('[data-action="undo"]').addEventListener("click", () => { why.textContent = ""; undo(); });
document.querySelector('[data-action="restart"]').addEventListener("click", () => {
  why.textContent = "";
  moves = [];
  render();
});

const KEYS = { ArrowRight: "right", ArrowUp: "up", ArrowDown: "down", ArrowLeft: "left" };
document.addEventListener("keydown", (event) => {
  if (event.altKey || event.ctrlKey || event.metaKey || event.target.matches("input, textarea, select")) return;
  if (KEYS[event.key]) {
    event.preventDefault();  // the page does not scroll while the robot moves
    act(KEYS[event.key]);
  } else if (event.key === "Backspace") {
    event.preventDefault();
    undo();
  }
});

// A tap (or click) on the cell next to the robot moves it there; on the robot's own cell it picks the
// object up or puts it down.
canvas.addEventListener("click", (event) => {
  const scene = canvas.scene, box = canvas.getBoundingClientRect();
  const x = (event.clientX - box.left) * scene.w / box.width, y = (event.clientY - box.top) * scene.h / box.height;
  const cell = [Math.floor((x - scene.ox) / scene.cell), Math.floor((y - scene.oy) / scene.cell)];
  const { at } = replay(moves);
  const step = Object.entries(STEPS).find(([, d]) => cell[0] === at[0] + d[0] && cell[1] === at[1] + d[1]);
  if (step) act(step[0]);
  else if (same(cell, at)) {
    if (!act("pickup") && !act("drop")) why.textContent = gettext("There is nothing to pick up or put down here.");
  } else why.textContent = gettext("Tap a square right next to the robot (not across a corner) to move it there.");
});

if (typeof ResizeObserver !== "undefined") new ResizeObserver(() => render()).observe(canvas);
// forget this step only once the server has it: a failed save keeps it for a reload
form.addEventListener("studyapp:saved", () => memory.clear());
lockOnSubmit(form);
render();
document.body.dataset.ready = "1";
