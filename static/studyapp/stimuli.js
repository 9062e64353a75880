// The stimulus sheet (researchers only): every training example and test option on its own
// canvas, drawn as its whole trajectory (a contact sheet); each Play animates it as a participant
// sees it, Trail returns to the whole trajectory, and "Play all" starts a section's or a test's together.
// The scene data are the page's application/json blocks (one per condition, one for the tests).
import { mountScene, prepareScenes, readJSON, sceneClass } from "./player.js";

const Scene = await sceneClass();

const blocks = new Map();
function block(id) {
  if (!blocks.has(id)) blocks.set(id, readJSON(id));
  return blocks.get(id);
}

function robotOf(cell) {
  const item = block(cell.dataset.scene)[Number(cell.dataset.item)];
  return cell.dataset.option === undefined ? item.scene.robot : item.options[Number(cell.dataset.option)].robot;
}

const cells = [...document.querySelectorAll(".cell[data-scene]")];
await prepareScenes(Scene, cells.map(robotOf));
for (const cell of cells) {
  const item = block(cell.dataset.scene)[Number(cell.dataset.item)];
  const robot = robotOf(cell);
  const player = mountScene(Scene, cell, item.scene, robot);
  // a contact sheet: the whole trajectory until the researcher plays it
  cell.querySelector('[data-action="trail"]').setAttribute("aria-pressed", "true");
  player.showTrail(true);
}

for (const button of document.querySelectorAll('[data-action="play-all"]')) {
  const scope = button.closest(".test-row, .sheet-section");
  button.addEventListener("click", () => {
    for (const play of scope.querySelectorAll('.cell [data-action="play"]')) play.click();
  });
}

document.body.dataset.ready = "1";
