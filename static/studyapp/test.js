// Test step: four animated options; continue only once each was played and all are rated.
import { lockOnSubmit, mountScene, readJSON, stepMemory } from "./scene.js";

const scene = readJSON("scene-data");
const robots = readJSON("option-robots");
const form = document.querySelector("form[data-test-form]");
const submit = form.querySelector('button[type="submit"]');
const hint = form.querySelector("[data-hint]");
const options = [...form.querySelectorAll("fieldset[data-option]")];
const memory = stepMemory(form);

function label(fieldset) {
  return fieldset.querySelector(".scene").dataset.robot;
}

function missing() {
  const out = [];
  const unplayed = options.filter((o) => !o.querySelector('input[name="played"]').checked);
  if (unplayed.length) out.push(`play option ${unplayed.map(label).join(", ")}`);
  if (!form.querySelector('input[name="choice"]:checked')) out.push("choose the matching option");
  const unrated = options.filter((o) => !o.querySelector(".rating input:checked"));
  if (unrated.length) out.push(`rate option ${unrated.map(label).join(", ")}`);
  return out;
}

function update() {
  const todo = missing();
  submit.disabled = todo.length > 0;
  hint.textContent = todo.length ? `To continue: ${todo.join("; ")}.` : "All done: you can continue.";
}

function markPlayed(fieldset) {
  fieldset.querySelector('input[name="played"]').checked = true;
  fieldset.querySelector(".played-flag").textContent = "✓ played";
  fieldset.classList.add("played");
}

function remember() {
  const checked = [...form.querySelectorAll('input[type="radio"]:checked')].map((i) => [i.name, i.value]);
  const played = [...form.querySelectorAll('input[name="played"]:checked')].map((i) => i.value);
  memory.save({ checked, played });
}

for (const fieldset of options) {
  const root = fieldset.querySelector(".scene");
  mountScene(root, scene, robots[root.dataset.robot], () => {
    markPlayed(fieldset);
    remember();
    update();
  });
}

// restore what this participant already did on this step (reload, new tab)
const saved = memory.load();
for (const [name, value] of saved.checked || []) {
  const input = form.querySelector(`input[type="radio"][name="${CSS.escape(name)}"][value="${CSS.escape(value)}"]`);
  if (input) input.checked = true;
}
for (const fieldset of options) {
  if ((saved.played || []).includes(fieldset.dataset.option)) markPlayed(fieldset);
}

form.addEventListener("change", () => { remember(); update(); });
// forget this step only once the server has it: a failed save keeps it for a reload
form.addEventListener("studyapp:saved", () => memory.clear());
lockOnSubmit(form);
update();
document.body.dataset.ready = "1";
