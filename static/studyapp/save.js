// Sending a step's answer without leaving the page, so that a lost connection loses nothing.
//
// Every participant form marked data-save is posted with fetch (the same fields to the same
// URL, asking for JSON). Accepted: go on to the next step. Refused because the page is out of
// date (answered in another tab): go to the current step. Refused (4xx): show the server's
// reason and let the participant try again. No answer, a 5xx (a 503 during a database outage)
// or a 429: keep the answer, say so in a banner and send it again with exponential backoff,
// at once when the browser reports it is back online. Re-sending is safe: the server stores
// an answer once and accepts the same answer again without writing. Without JavaScript the
// forms post as plain HTML forms. When the answer and the next page together take longer than
// SLOW_MS (a busy server, or a closed loop deciding the next example), the banner says the next
// page is being prepared, so that the participant waits on a message, not a frozen page.

import { gettext, interpolate } from "./i18n.js";

const FIRST_DELAY_MS = 1000;
const MAX_DELAY_MS = 30000;
const MAX_RETRY_AFTER_MS = 120000;  // a misconfigured Retry-After must not strand a participant
const OFFLINE = gettext("Connection lost — your answer is kept and will be sent automatically; please keep this page open.");
const BUSY = gettext("The study server is busy — your answer is kept and will be sent automatically; please keep this page open.");
const PREPARING = gettext("Your answer is saved; preparing your next page — one moment, please.");
const SENDING = gettext("Sending your answer — one moment, please.");
const SLOW_MS = 1000;

const banner = document.querySelector("[data-save-banner]");

function showBanner(text) {
  if (banner && banner.textContent !== text) banner.textContent = text;
}

// Retry-After is either seconds or an HTTP date.
function retryAfterMs(response) {
  const value = response.headers.get("Retry-After");
  if (!value) return 0;
  const ms = /^\d+$/.test(value.trim()) ? Number(value) * 1000 : Date.parse(value) - Date.now();
  return Number.isFinite(ms) ? Math.min(Math.max(ms, 0), MAX_RETRY_AFTER_MS) : 0;
}

// One attempt: {next} when stored, {error} when refused for good, {retry, wait} otherwise.
async function post(url, body) {
  let response;
  try {
    response = await fetch(url, {
      method: "POST", body, credentials: "same-origin", headers: { Accept: "application/json" },
    });
  } catch (err) {
    return { retry: OFFLINE, wait: 0 };
  }
  const reply = await response.json().catch(() => null);
  if (response.ok && reply && reply.ok) return { next: reply.next };
  // an out-of-date page (answered in another tab): go where the participant is; that page says why
  if (reply && reply.moved && reply.next) return { next: reply.next };
  if (response.status >= 400 && response.status < 500 && response.status !== 429) {
    return {
      error: (reply && reply.error) || interpolate(
        gettext("Your answer was not accepted (HTTP %(status)s). Please reload the page."), { status: response.status }, true),
    };
  }
  return { retry: BUSY, wait: retryAfterMs(response) };
}

// All steps share one URL, and navigating to the page's own URL would replace its history
// entry; push one first, as a plain form post does, so Back shows the current step again
// instead of leaving the study. replace() (not reload()) so no browser refills the new form.
function go(next) {
  const url = new URL(next, location.href);
  if (url.href === location.href) {
    history.pushState(null, "", url);
    location.replace(url);
  } else {
    location.assign(url);
  }
}

export function enhance(form) {
  const buttons = [...form.querySelectorAll('button[type="submit"]')];
  const error = document.createElement("p");
  error.className = "error save-error";
  error.setAttribute("role", "alert");
  (form.querySelector(".actions") || form).append(error);

  let pending = null;   // the answer being sent, as given when the button was pressed
  let attempt = 0;
  let timer = 0;
  let sending = false;
  let ready;            // body[data-ready] ("controls wired") is withdrawn while the answer is away
  let slow = 0;         // the timer that shows the progress message
  let saved = false;    // the answer is stored: the next page is on its way

  function refused(message) {
    clearTimeout(slow);
    pending = null;
    showBanner("");
    error.textContent = message;
    for (const b of buttons) b.disabled = false;
    if (ready !== undefined) document.body.dataset.ready = ready;
  }

  async function send() {
    clearTimeout(timer);
    sending = true;
    const outcome = await post(form.action, pending);
    sending = false;
    if (outcome.next) {
      pending = null;
      saved = true;
      showBanner(banner && banner.textContent === SENDING ? PREPARING : "");
      form.dispatchEvent(new CustomEvent("studyapp:saved"));
      go(outcome.next);
    } else if (outcome.error) {
      refused(outcome.error);
    } else {
      showBanner(outcome.retry);
      // equal jitter: participants cut off together do not all come back at the same instant
      const backoff = Math.min(MAX_DELAY_MS, FIRST_DELAY_MS * 2 ** attempt++);
      timer = setTimeout(send, Math.max(outcome.wait, backoff * (0.5 + Math.random() / 2)));
    }
  }

  form.addEventListener("submit", (event) => {
    // the consent refusal is answered with a page, not JSON: let the browser post it
    if (event.submitter && event.submitter.hasAttribute("data-plain-submit")) return;
    event.preventDefault();
    if (pending) return;  // already being sent: a second press must not send a second answer
    pending = new FormData(form);
    // the pressed button's name=value is part of the answer (consent, instructions)
    if (event.submitter && event.submitter.name) pending.append(event.submitter.name, event.submitter.value);
    for (const b of buttons) b.disabled = true;
    ready = document.body.dataset.ready;
    delete document.body.dataset.ready;
    error.textContent = "";
    attempt = 0;
    saved = false;
    clearTimeout(slow);
    // a retry's banner (offline, busy) says more than this one: shown only over an empty banner
    slow = setTimeout(() => { if (banner && !banner.textContent) showBanner(saved ? PREPARING : SENDING); }, SLOW_MS);
    send();
  });
  window.addEventListener("online", () => { if (pending && !sending) send(); });
  window.addEventListener("beforeunload", (event) => { if (pending) event.preventDefault(); });
}

for (const form of document.querySelectorAll("form[data-save]")) enhance(form);
