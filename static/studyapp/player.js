// The generic player (plain ES module, no build step): plays, pauses and shows the trail of any
// domain's scene, mounts it on a page's .scene element, and keeps a step's progress across a reload.
// The scene itself is the study's domain's (static/studyapp/scenes/<domain>.js, named by the page's
// <meta name="scene-module">): a class Scene(canvas, env, robot) with duration, mode, t, boxes,
// lastFrame, resize(), drawFrame(t), drawTrail() and redraw() (docs/domains.md "The web side").  A scene
// that plays recordings of its own (scenes/video.js) also brings its Player (static Player), its surface
// (the element shown in the canvas's place), says it has no trail (static trail = false) and loads its
// recordings before the page is used (static prepare(robots), see prepareScenes).

import { gettext, interpolate } from "./i18n.js";

let SCENE = null;

// The page's domain's Scene class (loaded once).
export async function sceneClass() {
  if (!SCENE) {
    const meta = document.querySelector('meta[name="scene-module"]');
    if (!meta) throw new Error("the page names no scene module (<meta name=\"scene-module\">)");
    SCENE = (await import(meta.content)).Scene;
  }
  return SCENE;
}

// What every canvas of the study shares (the page's "scene-view" block: Domain.study_view's values), added
// to each scene's data.
export function withView(env) {
  const block = document.getElementById("scene-view");
  return block ? { ...JSON.parse(block.textContent), ...env } : env;
}

// Plays a Scene in real time; calls onPlayed once the animation has reached its end. A running
// animation can be paused where it is and resumed from there (togglePause: the canvas, clicked or
// Space / Enter on it); Play always starts from the beginning.
export class Player {
  constructor(scene, { onPlayed = () => {}, onState = () => {} } = {}) {
    this.scene = scene;
    this.onPlayed = onPlayed;
    this.onState = onState;
    this.playing = false;
    this.paused = false;
    this.played = false;
    this.raf = 0;
    scene.drawFrame(0);
    if (typeof ResizeObserver !== "undefined") {
      new ResizeObserver(() => { if (!this.playing) scene.redraw(); }).observe(scene.canvas);
    }
  }

  play(from = 0) {
    cancelAnimationFrame(this.raf);
    this.scene.mode = "frame";
    this.playing = true;
    this.paused = false;
    this.onState("playing");
    let start = null;
    const tick = (now) => {
      if (start === null) start = now - from * 1000;
      const t = Math.min((now - start) / 1000, this.scene.duration);
      this.scene.drawFrame(t);
      if (t < this.scene.duration) {
        this.raf = requestAnimationFrame(tick);
      } else {
        this.ended();
      }
    };
    this.raf = requestAnimationFrame(tick);
  }

  // The animation has reached its end: onPlayed the first time.
  ended() {
    this.playing = false;
    const first = !this.played;
    this.played = true;
    this.onState("ended");
    if (first) this.onPlayed();
  }

  togglePause() {
    if (this.playing) {
      cancelAnimationFrame(this.raf);
      this.playing = false;
      this.paused = true;
      this.onState("paused");
    } else if (this.paused) {
      this.play(this.scene.t);
    }
  }

  showTrail(on) {
    cancelAnimationFrame(this.raf);
    this.paused = false;
    if (this.playing) { this.playing = false; this.onState("stopped"); }
    this.scene.mode = on ? "trail" : "frame";
    if (on) this.scene.drawTrail(); else this.scene.drawFrame(this.played ? this.scene.duration : 0);
  }
}

// What the Play button says once the example has played: "Replay", "Replay B" for the page's "Play",
// "Play B" (the template's English, or the same words already in the study's language); any other label stays.
function replayText(label, option) {
  const english = /^Play(?: (.+))?$/.exec(label);
  if (english) return english[1] ? interpolate(gettext("Replay %(option)s"), { option: english[1] }, true) : gettext("Replay");
  if (label === gettext("Play")) return gettext("Replay");
  if (option && label === interpolate(gettext("Play %(option)s"), { option }, true)) {
    return interpolate(gettext("Replay %(option)s"), { option }, true);
  }
  return label;
}

// Before any scene of the page is mounted: what `robots` (every robot the page shows) need loaded first.
export async function prepareScenes(Scene, robots) {
  if (Scene.prepare) await Scene.prepare(robots);
}

// Wire a .scene element's Play / Show trail buttons to a Player (Scene: sceneClass()'s).  trailAfter: once an
// animation has played to its end, its whole path stays drawn (the Trail button on), as the study asks.
export function mountScene(Scene, root, env, robot, onPlayed, { trailAfter = false } = {}) {
  const canvas = root.querySelector("canvas");
  const playBtn = root.querySelector('[data-action="play"]');
  const trailBtn = root.querySelector('[data-action="trail"]');
  const baseLabel = playBtn.textContent.trim();
  const trailLabel = trailBtn.textContent.trim();  // "Show trail" toggles to "Hide trail"; a short label stays
  const scene = new Scene(canvas, withView(env), robot);
  canvas.scene = scene;  // for the browser tests, which read what each frame drew (lastFrame)
  const replayLabel = replayText(baseLabel, root.closest("[data-option]")?.dataset.option);
  const player = new (Scene.Player || Player)(scene, {
    onPlayed,
    onState: (state) => {
      root.dataset.state = state;
      if (state !== "playing") playBtn.textContent = replayLabel;
      if (state === "ended" && trailAfter) showTrail(true);
    },
  });
  // the page's label, in English or already in the study's language
  const toggles = trailLabel === "Show trail" || trailLabel === gettext("Show trail");
  const trailText = (on) => (toggles ? (on ? gettext("Hide trail") : gettext("Show trail")) : trailLabel);
  playBtn.addEventListener("click", () => {
    trailBtn.setAttribute("aria-pressed", "false");
    trailBtn.textContent = trailText(false);
    player.play();
  });
  function showTrail(on) {
    trailBtn.setAttribute("aria-pressed", String(on));
    trailBtn.textContent = trailText(on);
    player.showTrail(on);
  }
  trailBtn.addEventListener("click", () => showTrail(trailBtn.getAttribute("aria-pressed") !== "true"));
  if (Scene.trail === false) trailBtn.hidden = true;  // a recording has no trail to show
  // pause and resume: a click on the animation, or Space / Enter on it (it is in the tab order)
  const surface = scene.surface || canvas;
  surface.tabIndex = 0;
  surface.title = gettext("Click (or press Space) to pause or resume the animation");
  surface.addEventListener("click", () => player.togglePause());
  surface.addEventListener("keydown", (event) => {
    if (event.key === " " || event.key === "Enter") {
      event.preventDefault();
      player.togglePause();
    }
  });
  return player;
}

export function readJSON(id) {
  return JSON.parse(document.getElementById(id).textContent);
}

// Guard against double submission (the server is idempotent anyway).
export function lockOnSubmit(form) {
  form.addEventListener("submit", () => {
    for (const b of form.querySelectorAll('button[type="submit"]')) b.disabled = true;
  });
}

// Within-step progress kept in localStorage (keyed by the form's answer URL, which names the
// participant and the step), so a reload or a second tab shows the step exactly as it was left.
export function stepMemory(form) {
  const key = `studyapp:${new URL(form.action, location.href).pathname}`;
  const read = () => {
    try { return JSON.parse(localStorage.getItem(key)) || {}; } catch (err) { return {}; }
  };
  return {
    load: read,
    save(patch) {
      try { localStorage.setItem(key, JSON.stringify({ ...read(), ...patch })); } catch (err) { /* private mode */ }
    },
    clear() {
      try { localStorage.removeItem(key); } catch (err) { /* ignore */ }
    },
  };
}
