// Showing a robot by its lab's own recordings (plain ES module, no build step): the scene of every table
// imported with videos (teaching/importing/robot.py), in the generic player's contract (../player.js).
//
// robot: {video: "<sha256>.webm"}, an opaque name (the file's content hash: nothing of an environment or an
// objective), served under the page's <meta name="media-base">.  Before the page is used, prepare() fetches
// every video the page shows whole, with a progress bar, and plays each from a blob: URL, so a video never
// stalls half-way and a replay costs nothing.  A video is muted, has no controls of its own (the page's Play
// and Replay buttons, a click to pause), and plays inline; it counts as watched once it has played to its end
// (VideoPlayer's onPlayed, as an animation's).  Autoplay is the page's (training.js: never under reduced
// motion).

import { gettext, interpolate } from "../i18n.js";
import { Player } from "../player.js";

const loaded = new Map();  // name -> {url, duration, width, height}

function mediaBase() {
  const meta = document.querySelector('meta[name="media-base"]');
  if (!meta) throw new Error("the page names no media base (<meta name=\"media-base\">)");
  return meta.content;
}

// The bytes of `url`, reporting each chunk's length to onBytes (a progress bar's).
async function fetchBytes(url, onBytes) {
  const response = await fetch(url, { credentials: "same-origin" });
  if (!response.ok) throw new Error(`${response.status} for a video`);
  const total = Number(response.headers.get("content-length")) || 0;
  const reader = response.body.getReader();
  const chunks = [];
  for (;;) {
    const { done, value } = await reader.read();
    if (done) break;
    chunks.push(value);
    onBytes(value.length, total);
  }
  return new Blob(chunks, { type: response.headers.get("content-type") || "video/webm" });
}

// A blob's duration and size, read by a video element that is then let go.
function metadata(url) {
  return new Promise((resolve, reject) => {
    const probe = document.createElement("video");
    probe.muted = true;
    probe.preload = "metadata";
    probe.onloadedmetadata = () => resolve({ duration: probe.duration, width: probe.videoWidth, height: probe.videoHeight });
    probe.onerror = () => reject(new Error("a video the browser cannot play"));
    probe.src = url;
  });
}

// The progress bar at the top of the page, the page's buttons off until every video is here.
function loadingBar() {
  const box = document.createElement("div");
  box.className = "video-loading card";
  box.setAttribute("role", "status");
  box.innerHTML = '<progress max="1" value="0"></progress> <span></span>';
  const main = document.querySelector("main") || document.body;
  const heading = main.querySelector("h1");
  if (heading) heading.after(box); else main.prepend(box);
  const bar = box.querySelector("progress"), text = box.querySelector("span");
  // the buttons on now, off while loading and on again after (a page's script decides the others)
  const buttons = [...document.querySelectorAll("button")].filter((b) => !b.disabled);
  for (const b of buttons) b.disabled = true;
  for (const b of document.querySelectorAll('.scene [data-action="trail"]')) b.hidden = true;  // a video has none
  return {
    show(fraction) {
      bar.value = fraction;
      text.textContent = interpolate(gettext("Loading the videos: %(percent)s %"), { percent: Math.floor(100 * fraction) }, true);
    },
    fail(retry) {
      text.textContent = gettext("The videos could not be loaded. Check your connection and try again.");
      const again = document.createElement("button");
      again.type = "button";
      again.textContent = gettext("Try again");
      again.addEventListener("click", () => { again.remove(); retry(); });
      box.append(again);
    },
    done() {
      box.remove();
      for (const b of buttons) b.disabled = false;
    },
  };
}

// Every video of `robots` fetched whole before the page is used (retried on the participant's word).
async function prepare(robots) {
  const base = mediaBase();
  const names = [...new Set(robots.filter((r) => r && r.video).map((r) => r.video))].filter((n) => !loaded.has(n));
  if (!names.length) return;
  const bar = loadingBar();
  // each video's share loaded (its bytes against its length; 0 until that is known, 1 once it is here)
  const share = new Map(names.map((n) => [n, 0]));
  const report = () => bar.show([...share.values()].reduce((a, b) => a + b, 0) / names.length);
  report();
  for (;;) {
    try {
      await Promise.all(names.filter((n) => !loaded.has(n)).map(async (name) => {
        let got = 0;
        share.set(name, 0);
        const blob = await fetchBytes(base + encodeURIComponent(name), (n, total) => {
          got += n;
          share.set(name, total ? Math.min(1, got / total) : 0);
          report();
        });
        const url = URL.createObjectURL(blob);
        loaded.set(name, { url, ...(await metadata(url)) });
        share.set(name, 1);
        report();
      }));
      bar.done();
      return;
    } catch (err) {
      await new Promise((resolve) => bar.fail(resolve));
    }
  }
}

// Plays a recording as Player (../player.js) plays an animation, the video's own clock in place of the
// animation frames': Play from the start, a click to pause and resume, onPlayed once it first reaches its end.
class VideoPlayer extends Player {
  constructor(scene, callbacks) {
    super(scene, callbacks);
    const video = scene.video;
    video.addEventListener("ended", () => this.ended());
    video.addEventListener("timeupdate", () => { scene.t = video.currentTime; });
  }

  play(from = 0) {
    this.scene.mode = "frame";
    this.scene.video.currentTime = from;
    this.playing = true;
    this.paused = false;
    this.onState("playing");
    this.scene.video.play().catch(() => { this.playing = false; this.onState("stopped"); });
  }

  togglePause() {
    if (this.playing) this.scene.video.pause();
    this.scene.t = this.scene.video.currentTime;  // resumed from where the video is, not its last timeupdate
    super.togglePause();
  }

  // No trail: "on" shows the last frame (where the robot ended), "off" the first or, once played, the last.
  showTrail(on) {
    this.scene.video.pause();
    super.showTrail(on);
  }
}

export class Scene {
  static Player = VideoPlayer;
  static trail = false;
  static prepare = prepare;

  constructor(canvas, env, robot) {
    const clip = robot && loaded.get(robot.video);
    if (!clip) throw new Error("a video scene mounted before its video was loaded (prepareScenes)");
    this.canvas = canvas;
    this.env = env;
    this.duration = clip.duration;
    this.mode = "frame";
    this.t = 0;
    this.boxes = [];
    this.lastFrame = null;
    const video = document.createElement("video");
    video.muted = true;
    video.defaultMuted = true;
    video.playsInline = true;
    video.preload = "auto";
    video.disablePictureInPicture = true;
    video.setAttribute("aria-label", canvas.getAttribute("aria-label") || gettext("Video of the robot"));
    video.width = clip.width;
    video.height = clip.height;
    video.src = clip.url;
    canvas.hidden = true;  // the video stands in the canvas's place, at its size (video.css)
    canvas.after(video);
    this.video = video;
    this.surface = video;
  }

  resize() {}

  drawFrame(t) {
    this.t = t;
    this.video.currentTime = Math.min(t, this.duration);
  }

  drawTrail() {
    this.drawFrame(this.duration);
  }

  redraw() {}
}
