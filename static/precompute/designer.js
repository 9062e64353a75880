// The study designer's summary, kept up to date as the researcher fills in the sections above it:
// what "Build" will make, in a few lines, right above the button. It reads the form and writes
// text only (textContent), so nothing typed into a field can become markup here.

const form = document.querySelector("form[data-designer]");
const list = form && form.querySelector("[data-design-summary]");

function value(name) {
  const el = form.elements.namedItem(name);
  return el && "value" in el ? el.value.trim() : "";
}

function chosenText(name) {
  const el = form.elements.namedItem(name);
  return el && el.selectedOptions && el.selectedOptions.length ? el.selectedOptions[0].textContent.trim() : "";
}

// Each ticked row's condition, with the parameters the researcher changed from their defaults.
function tickedConditions() {
  const out = [];
  for (const row of form.querySelectorAll("tr[data-condition]")) {
    const box = row.querySelector('input[type="checkbox"]');
    if (!box || !box.checked) continue;
    const changed = [...row.querySelectorAll("input:not([type=checkbox])")]
      .filter((input) => input.value.trim() !== "" && input.value.trim() !== input.defaultValue.trim())
      .map((input) => `${input.labels.length ? input.labels[0].textContent.trim() : input.name} ${input.value.trim()}`);
    out.push(changed.length ? `${row.dataset.condition} (${changed.join("; ")})` : row.dataset.condition);
  }
  if (value("hand_picked_env_ids")) {
    const ids = value("hand_picked_env_ids").split(/[\s,]+/).filter(Boolean).length;
    out.push(`${value("hand_picked_name") || "hand-picked"} (hand-picked: ${ids} environment${ids === 1 ? "" : "s"})`);
  }
  if (value("loop_name")) out.push(`${value("loop_name")} (closed loop: ${chosenText("loop_model")})`);
  return out;
}

function outcomeCodes() {
  const named = [["excluded_code", "failed attention check"], ["screened_out_code", "screened out"],
    ["timed_out_code", "timed out"]].filter(([name]) => value(name)).map(([name, what]) => `${what} ${value(name)}`);
  return named.length ? named.join("; ") : "none of their own";
}

function bonusText() {
  const parts = [];
  if (parseFloat(value("bonus_per_correct")) > 0) parts.push(`${value("bonus_per_correct")} per correct test`);
  if (parseFloat(value("bonus_per_point")) > 0) parts.push(`${value("bonus_per_point")} per confidence point`);
  if (!parts.length) return "none";
  const cap = parseFloat(value("bonus_cap")) > 0 ? `, at most ${value("bonus_cap")}` : ", no cap";
  return `${parts.join(" + ")}${cap} (${value("bonus_currency") || "GBP"})`;
}

function comprehensionText() {
  const box = form.elements.namedItem("comprehension_check");
  if (!box || !box.checked) return "none";
  const questions = value("comprehension_questions").split(/\n\s*\n/).filter((q) => q.trim()).length;
  const attempts = value("comprehension_attempts") || "3";
  return `${questions} question${questions === 1 ? "" : "s"} after the instructions, ${attempts} attempt`
    + `${attempts === "1" ? "" : "s"} (then screened out)`;
}

function entries() {
  const conditions = tickedConditions();
  const target = parseInt(value("target_per_condition"), 10);
  const people = target >= 1 && conditions.length
    ? `${target} per condition × ${conditions.length} = ${(target * conditions.length).toLocaleString("en")} participants`
    : "give the participants per condition and at least one condition";
  const code = value("completion_code");
  const tests = [chosenText("test_kind") || "choose the robot's way among four",
    value("test_difficulty") && value("test_difficulty") !== "none" ? `${value("test_difficulty")} difficulty`
      : "any difficulty",
    `θ*-regret ≥ ${value("min_regret") || "the default"}`];
  if (value("min_distance") && value("test_kind") !== "show") tests.push(`options ≥ ${value("min_distance")} apart`);
  return [
    ["Table", chosenText("table") || "none chosen"],
    ["Study", `${value("name") || "(no name)"} — /s/${value("slug") || "…"}/`],
    [`Conditions (${conditions.length})`, conditions.length ? conditions.join(", ") : "none: tick at least one row"],
    ["Tests", tests.join("; ")],
    ["Participants", people],
    ["Recruitment", `${chosenText("recruitment")}${code ? `, completion code ${code}` : ""}`],
    ["Payment and time", `${[value("payment_amount") && `${value("payment_amount")} (${value("bonus_currency") || "GBP"})`,
      value("payment")].filter(Boolean).join(", ") || "no payment given"}, about ${value("estimated_minutes") || "?"} minutes`
      + (parseInt(value("time_limit_minutes"), 10) > 0 ? `, at most ${value("time_limit_minutes")} (then timed out)` : "")],
    ["Codes when ending early", outcomeCodes()],
    ["Comprehension check", comprehensionText()],
    ["Devices", `${chosenText("devices") || "any device"}`
      + (parseInt(value("min_screen_width"), 10) > 0 ? `, screens at least ${value("min_screen_width")} px wide` : "")],
    ["Bonus", bonusText()],
    ["Participants' language", chosenText("language") || "English"],
  ];
}

function render() {
  const items = [];
  for (const [term, description] of entries()) {
    const dt = document.createElement("dt");
    dt.textContent = term;
    const dd = document.createElement("dd");
    dd.textContent = description;
    items.push(dt, dd);
  }
  list.replaceChildren(...items);
}

if (list) {
  form.addEventListener("input", render);
  form.addEventListener("change", render);
  render();
}

// The comprehension questions start as the chosen table's robot's own: another table chosen swaps them for
// its robot's, unless the researcher has written their own.
const questions = form && form.querySelector("textarea[data-comprehension-defaults]");
const tableSelect = form && form.elements.namedItem("table");
if (questions && tableSelect) {
  const defaults = JSON.parse(questions.dataset.comprehensionDefaults);
  let shown = tableSelect.value;
  tableSelect.addEventListener("change", () => {
    const before = (defaults[shown] || "").trim();
    if (questions.value.trim() === before && defaults[tableSelect.value] !== undefined) {
      questions.value = defaults[tableSelect.value];
    }
    shown = tableSelect.value;
  });
}

// Beside the test fields: how many environments of the chosen table could hold each test cluster's test, in
// all and per difficulty, before training takes its examples (precompute/supply.py). Asked again when the
// table, the kind or a threshold changes; the answer for a large table takes some seconds the first time.
const supplyBox = form && form.querySelector("[data-test-supply]");
let supplyAsked = "";
let supplyData = null;

function supplyParagraph(text, className) {
  const p = document.createElement("p");
  p.textContent = text;
  if (className) p.className = className;
  return p;
}

async function showSupply() {
  const params = new URLSearchParams({ table: value("table"), kind: value("test_kind") || "choose",
    min_regret: value("min_regret"), min_distance: value("min_distance") });
  const asked = params.toString();
  if (!value("table")) return;
  if (asked === supplyAsked) {
    if (supplyData) renderSupply(supplyData); // the difficulty changed: its line only
    return;
  }
  supplyAsked = asked;
  supplyData = null;
  supplyBox.replaceChildren(supplyParagraph("Counting the environments that could hold each test…"));
  let data;
  try {
    const response = await fetch(`${supplyBox.dataset.testSupply}?${asked}`, { headers: { Accept: "application/json" } });
    data = await response.json();
  } catch (error) {
    data = { error: "The counts could not be fetched; \"Build\" checks them in any case." };
  }
  if (asked !== supplyAsked) return; // another choice was made meanwhile
  if (data.error) {
    supplyBox.replaceChildren(supplyParagraph(data.error, "error"));
    return;
  }
  supplyData = data;
  renderSupply(data);
}

function renderSupply(data) {
  const head = document.createElement("tr");
  for (const text of ["Test of", "Any difficulty", "Low", "Medium", "High"]) {
    const th = document.createElement("th");
    th.textContent = text;
    head.append(th);
  }
  const rows = data.clusters.map((name, i) => {
    const tr = document.createElement("tr");
    for (const text of [name, data.hosts[i], data.by_level.low[i], data.by_level.medium[i], data.by_level.high[i]]) {
      const td = document.createElement("td");
      td.textContent = String(text);
      if (text === 0) td.className = "none";
      tr.append(td);
    }
    return tr;
  });
  const table = document.createElement("table");
  table.className = "data";
  table.append(document.createElement("thead"), document.createElement("tbody"));
  table.tHead.append(head);
  table.tBodies[0].append(...rows);
  const needs = data.kind === "show" ? "A show test set needs one strategy with an environment"
    : "A choice test set needs an environment for every row";
  const said = [supplyParagraph(`Environments of this table that could hold each test, before training takes its `
    + `examples. ${needs}; training may still use the last ones of a level, and the build then says so.`)];
  const chosen = value("test_difficulty") || "none";
  if (data.problems[chosen]) said.push(supplyParagraph(data.problems[chosen], "error"));
  supplyBox.replaceChildren(...said, table);
}

if (supplyBox) {
  form.addEventListener("change", showSupply);
  showSupply();
}
