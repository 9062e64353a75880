// Training step: one animated example; "continue" unlocks once it was played to the end.
import { gettext } from "./i18n.js";
import { lockOnSubmit, mountScene, prepareScenes, readJSON, sceneClass, stepMemory } from "./player.js";

const Scene = await sceneClass();

const root = document.querySelector(".scene[data-scene]");
const env = readJSON(root.dataset.scene);
await prepareScenes(Scene, [env.robot]);
const form = document.querySelector("form[data-require-played]");
const submit = form.querySelector('button[type="submit"]');
const hint = form.querySelector(".hint");
const memory = stepMemory(form);

function unlock() {
  form.querySelector('input[name="played"]').value = "1";
  submit.disabled = false;
  hint.textContent = gettext("You can replay the example or continue.");
}

const player = mountScene(Scene, root, env, env.robot, () => {
  memory.save({ played: true });
  unlock();
});
lockOnSubmit(form);
// forget this step only once the server has it: a failed save keeps it for a reload
form.addEventListener("studyapp:saved", () => memory.clear());
if (memory.load().played) {
  player.played = true;
  unlock();
} else if (root.dataset.autoplay && !matchMedia("(prefers-reduced-motion: reduce)").matches) {
  player.play();
} else {
  // reduced motion asked for (or no autoplay): nothing moves until the participant presses Play
  hint.textContent = gettext("Press Play to watch the example; watch it to the end to continue.");
}
document.body.dataset.ready = "1";
