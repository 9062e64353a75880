// The consent page of a study with device rules (studyapp/participant/devices.py): what this screen is, sent with the
// answer so the server can check it, and, when it may not take part, why, before the participant agrees.
// The server checks again what is sent here and keeps no place for a device it refuses.
import { readJSON } from "./player.js";

const rules = readJSON("device-rules");
const form = document.querySelector("form[data-save]");
const width = Math.round(window.screen.width || window.innerWidth);
// a touch screen without a fine pointer is a phone or a tablet; the shorter side tells them apart
const touch = matchMedia("(pointer: coarse)").matches && !matchMedia("(any-pointer: fine)").matches;
const phone = navigator.userAgentData?.mobile === true
  || (touch && Math.min(window.screen.width, window.screen.height) < 600);
const device = phone ? "phone" : touch ? "tablet" : "computer";
form.querySelector('input[name="screen_width"]').value = String(width);
form.querySelector('input[name="device"]').value = device;

// the server's own messages (studyapp/participant/devices.py rules), so the page and a refusal say the same
let problem = "";
if (device === "phone" && !rules.phones) problem = rules.messages.phone;
else if (device === "tablet" && !rules.tablets) problem = rules.messages.tablet;
else if (width < rules.min_width) problem = rules.messages.width.replace("{width}", String(width));
if (problem) {
  const note = document.querySelector("[data-device-problem]");
  note.textContent = problem;
  note.hidden = false;
  for (const b of form.querySelectorAll('button[name="consent"]')) b.hidden = b.value !== "device";
  form.querySelector("[data-device-leave]").hidden = false;
}
document.body.dataset.ready = "1";
