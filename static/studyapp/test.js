// Test step: four animated options in a grid (each playable, or all together), one choice and a
// 1-7 rating for each; continue only once each option was played and all are rated.
import { gettext, interpolate } from "./i18n.js";
import { lockOnSubmit, mountScene, prepareScenes, readJSON, sceneClass, stepMemory } from "./player.js";

const Scene = await sceneClass();

const scene = readJSON("scene-data");
const robots = readJSON("option-robots");
await prepareScenes(Scene, Object.values(robots));
const form = document.querySelector("form[data-test-form]");
const submit = form.querySelector('button[type="submit"]');
const hint = form.querySelector("[data-hint]");
const options = [...form.querySelectorAll("section[data-option]")];
const memory = stepMemory(form);

function letter(section) {
  return section.dataset.option;
}

function missing() {
  const out = [];
  const unplayed = options.filter((o) => !o.querySelector('input[name="played"]').checked);
  if (unplayed.length) out.push(interpolate(gettext("play option %(options)s"), { options: unplayed.map(letter).join(", ") }, true));
  if (!form.querySelector('input[name="choice"]:checked')) out.push(gettext("choose the matching option"));
  const unrated = options.filter((o) => !form.querySelector(`.rating[data-option="${letter(o)}"] input:checked`));
  if (unrated.length) out.push(interpolate(gettext("rate option %(options)s"), { options: unrated.map(letter).join(", ") }, true));
  return out;
}

function update() {
  const todo = missing();
  submit.disabled = todo.length > 0;
  hint.textContent = todo.length ? interpolate(gettext("To continue: %(todo)s."), { todo: todo.join("; ") }, true)
    : gettext("All done: you can continue.");
}

function markPlayed(section) {
  section.querySelector('input[name="played"]').checked = true;
  section.querySelector(".played-flag").textContent = gettext("✓ played");
  section.classList.add("played");
}

function remember() {
  const checked = [...form.querySelectorAll('input[type="radio"]:checked')].map((i) => [i.name, i.value]);
  const played = [...form.querySelectorAll('input[name="played"]:checked')].map((i) => i.value);
  memory.save({ checked, played });
}

const players = options.map((section) => {
  const root = section.querySelector(".scene");
  return mountScene(Scene, root, scene, robots[root.dataset.robot], () => {
    markPlayed(section);
    remember();
    update();
  }, { trailAfter: "keepTrails" in form.dataset });
});

// all four at once: the same moments side by side, as the buttons would start them
form.querySelector('[data-action="play-all"]').addEventListener("click", () => {
  for (const section of options) section.querySelector('[data-action="play"]').click();
});

// restore what this participant already did on this step (reload, new tab)
const saved = memory.load();
for (const [name, value] of saved.checked || []) {
  const input = form.querySelector(`input[type="radio"][name="${CSS.escape(name)}"][value="${CSS.escape(value)}"]`);
  if (input) input.checked = true;
}
for (const section of options) {
  if ((saved.played || []).includes(letter(section))) markPlayed(section);
}

// On a phone whose options stand one above another, the answer panel is a screen or more below the first
// option: each option's rating row moves under its own animation, in reach of what it rates.  The inputs are
// the same ones, so the form posts the same answer; a wider screen puts them back in the panel.
const ratingsPanel = form.querySelector("fieldset.ratings");
const phone = window.matchMedia("(max-width: 480px)");
function placeRatings() {
  const formWidth = form.getBoundingClientRect().width;
  const stacked = phone.matches && options.every((o) => o.getBoundingClientRect().width > 0.7 * formWidth);
  for (const section of options) {
    const row = form.querySelector(`.rating[data-option="${letter(section)}"]`);
    const ask = section.querySelector(".rating-ask");
    if (stacked && row.parentElement !== section) {
      if (!ask) {
        const p = document.createElement("p");
        p.className = "rating-ask";
        p.setAttribute("aria-hidden", "true");  // the row's own label says it to a screen reader
        p.textContent = row.getAttribute("aria-label");  // "How well does option B match? 1 = …", translated
        section.append(p);
      }
      section.append(row);
    } else if (!stacked && row.parentElement === section) {
      ask?.remove();
      ratingsPanel.append(row);
    }
  }
  ratingsPanel.hidden = stacked;
  form.classList.toggle("ratings-by-option", stacked);
}
phone.addEventListener("change", placeRatings);
placeRatings();

form.addEventListener("change", () => { remember(); update(); });
// forget this step only once the server has it: a failed save keeps it for a reload
form.addEventListener("studyapp:saved", () => memory.clear());
lockOnSubmit(form);
update();
document.body.dataset.ready = "1";
