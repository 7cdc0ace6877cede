// The health strip: one chip per check from the worker's telemetry. A failing check is amber
// ("degraded") until it has failed for the server's grace period, then red with an alarm line;
// a lost worker or robot is red at once (the server grades each check: `level`).
//
// Speaking follows the speech start and end events the moment they reach the console. The
// heartbeat's flag is three 1 Hz samplings old (the renderer's statistics, the worker's
// heartbeat, the server's relay) and lagged the robot display by 1.5-2 s. Whichever is
// newer wins: an event that arrived after the worker sampled the flag, else the flag
// (which also covers an end that never came as an event).
//
// The server sends the health when it changes, not every second (issue 34): a failing
// check's duration grows here from the message's arrival, and silence is judged from the
// link (any message, the pongs of live.js's 5 s pings included), not from health messages.
// The same for the seconds since the participant video's last chunk (`since_s`).

import { el, seconds } from "./dom.js";

const SILENT_AFTER_MS = 8000; // pongs come every 5 s
const STATES = { ok: "ok", unknown: "unknown", degraded: "degraded", alarm: "bad" };
// The robot refused or never answered the login: the worker waits for the wizard's retry.
const LOGIN_FAILED = /^login /;

// The participant video's chip: the server sends the seconds since its last chunk apart
// from the value (their ticking is no change); they count on here.
function withSince(check, since) {
  return { ...check, value: `${check.value}, last ${seconds(since)} ago` };
}

function stateOf(check) {
  if (check.level && STATES[check.level]) return STATES[check.level];
  return check.ok === null ? "unknown" : check.ok ? "ok" : "bad";
}

export class HealthStrip {
  constructor(container, onRetry = null, onPair = null) {
    this.container = container;
    this.onRetry = onRetry;
    // The capture accepts one phone: offer to pair afresh when another phone is sending.
    this.onPair = onPair;
    this.lastAt = 0; // the last health message
    this.heardAt = 0; // the last message of any kind on the console's socket
    this.mismatchSince = null;
    this.message = null;
    this.expected = null;
    this.speech = null; // {speaking, at}: the last speech event the console received
    setInterval(() => this.checkSilence(), 1000);
  }

  /** A speech event just arrived (start: true, end or stop: false). */
  speechEvent(speaking) {
    this.speech = { speaking, at: Date.now() };
    if (this.message && !this.silent()) this.render();
  }

  /** Whether the chip says the robot speaks now. */
  get speaking() {
    const chip = this.container.querySelector(".chip[data-check='speaking']");
    return Boolean(chip && chip.dataset.speaking === "true");
  }

  /** Any message arrived on the console's socket: the server is there. */
  heard() {
    this.heardAt = Date.now();
  }

  update(message, expectedBehaviour) {
    this.lastAt = Date.now();
    this.heardAt = this.lastAt;
    this.message = message;
    this.expected = expectedBehaviour;
    this.render();
  }

  /** The speaking check: from the heartbeat, unless a speech event is newer than it. */
  speakingCheck(check) {
    const age = Number(this.message.speaking_age_s); // the worker's sample, not the message
    const sampledAt = this.lastAt - (Number.isFinite(age) ? age * 1000 : 0);
    const fromTelemetry = check.value === "speaking";
    const speaking = this.speech && this.speech.at > sampledAt ? this.speech.speaking : fromTelemetry;
    if (check.ok === null && !(this.speech && this.speech.at > sampledAt)) return check;
    return { ...check, ok: true, level: "ok", value: speaking ? "speaking" : "quiet" };
  }

  render() {
    const message = this.message;
    const expectedBehaviour = this.expected;
    const running = message.telemetry && message.telemetry.behaviour;
    const elapsed = (Date.now() - this.lastAt) / 1000; // a failing check has failed longer by this
    const checks = message.checks
      .map((check) => (check.failing_for == null ? check : { ...check, failing_for: check.failing_for + elapsed }))
      .map((check) => (check.since_s == null ? check : withSince(check, check.since_s + elapsed)))
      .map((check) => (check.id === "speaking" ? this.speakingCheck(check) : check));
    const mismatch = Boolean(expectedBehaviour && running && running !== expectedBehaviour);
    if (!mismatch) this.mismatchSince = null;
    else if (!this.mismatchSince) this.mismatchSince = Date.now();
    if (expectedBehaviour && running) {
      // A switch takes a moment to reach the worker: the same grace as the server's checks.
      const failingFor = mismatch ? (Date.now() - this.mismatchSince) / 1000 : null;
      const grace = message.alarm_after_s ?? 0;
      checks.push({
        id: "behaviour",
        label: "Behaviour",
        ok: !mismatch,
        level: !mismatch ? "ok" : failingFor >= grace ? "alarm" : "degraded",
        value: mismatch ? `${running}, should be ${expectedBehaviour}` : running,
        failing_for: failingFor,
      });
    }
    const failing = checks.filter((check) => stateOf(check) === "bad");
    const chips = checks.map((check) => {
      const state = stateOf(check);
      return el(
        "span",
        {
          class: `chip ${state}`,
          dataset: check.id === "speaking"
            ? { check: check.id, state, speaking: String(check.value === "speaking") }
            : { check: check.id, state },
          title: state === "bad" || state === "degraded" ? `failing for ${seconds(check.failing_for || 0)}` : state,
        },
        el("strong", { text: check.label }),
        " ",
        check.value,
        state === "degraded" ? el("span", { class: "since", text: " · degraded" }) : null,
        state === "bad" ? el("span", { class: "since", text: ` · ${seconds(check.failing_for || 0)}` }) : null,
      );
    });
    const alarm = failing.length
      ? el(
          "div",
          { class: "alarm", role: "alert" },
          message.bridge ? "Robot problem: " : "Worker unreachable (no bridge on this server): ",
          failing.map((c) => `${c.label} ${c.value} for ${seconds(c.failing_for || 0)}`).join("; "),
          failing.some((c) => c.id === "worker") ? ". Prompts are logged but not sent." : ".",
        )
      : null;
    this.container.classList.toggle("failing", failing.length > 0);
    // replaceChildren would print a null as the text "null".
    const parts = [el("span", { class: "k", text: `Robot ${message.booth}` }), ...chips];
    // The Robot chip's, or (a booth with both robots) the Furhat's while the display runs.
    const loginFailed = checks.some((check) => (check.id === "robot" || check.id === "furhat")
      && LOGIN_FAILED.test(check.value || ""));
    if (this.onRetry && loginFailed) {
      parts.push(el("button", { type: "button", class: "link", id: "robot-retry", onclick: this.onRetry }, "Try the robot again"));
    }
    const pairing = message.telemetry?.ingest?.pairing;
    if (this.onPair && pairing && pairing.mode === "first_sender" && pairing.other_packets > 0) {
      parts.push(el("button", { type: "button", class: "link", id: "capture-pair", onclick: this.onPair }, "Pair with the next phone"));
    }
    if (alarm) parts.push(alarm);
    this.container.replaceChildren(...parts);
  }

  silent() {
    return Boolean(this.heardAt) && Date.now() - this.heardAt >= SILENT_AFTER_MS;
  }

  checkSilence() {
    if (!this.silent()) {
      // The server sends no message while nothing changes: a failing check's time ticks here.
      if (this.message && this.message.checks.some((check) => check.failing_for != null || check.since_s != null)) this.render();
      return;
    }
    this.container.classList.add("failing");
    this.container.replaceChildren(
      el("div", { class: "alarm", role: "alert", text: `No word from the server for ${seconds((Date.now() - this.heardAt) / 1000)}.` }),
    );
  }
}
