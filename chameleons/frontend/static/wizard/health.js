// The health strip: one chip per check from the worker's telemetry. A failing check is amber
// ("degraded") until it has failed for the server's grace period, then red with an alarm line;
// a lost worker or robot is red at once (the server grades each check: `level`).

import { el, seconds } from "./dom.js";

const SILENT_AFTER_MS = 3500;
const STATES = { ok: "ok", unknown: "unknown", degraded: "degraded", alarm: "bad" };
// The robot refused or never answered the login: the worker waits for the wizard's retry.
const LOGIN_FAILED = /^login /;

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
    this.lastAt = 0;
    this.mismatchSince = null;
    setInterval(() => this.checkSilence(), 1000);
  }

  update(message, expectedBehaviour) {
    this.lastAt = Date.now();
    const running = message.telemetry && message.telemetry.behaviour;
    const checks = [...message.checks];
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
          dataset: { check: check.id, state },
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
    const robot = checks.find((check) => check.id === "robot");
    if (this.onRetry && robot && LOGIN_FAILED.test(robot.value || "")) {
      parts.push(el("button", { type: "button", class: "link", id: "robot-retry", onclick: this.onRetry }, "Try the robot again"));
    }
    const pairing = message.telemetry?.ingest?.pairing;
    if (this.onPair && pairing && pairing.mode === "first_sender" && pairing.other_packets > 0) {
      parts.push(el("button", { type: "button", class: "link", id: "capture-pair", onclick: this.onPair }, "Pair with the next phone"));
    }
    if (alarm) parts.push(alarm);
    this.container.replaceChildren(...parts);
  }

  checkSilence() {
    if (!this.lastAt || Date.now() - this.lastAt < SILENT_AFTER_MS) return;
    this.container.classList.add("failing");
    this.container.replaceChildren(
      el("div", { class: "alarm", role: "alert", text: `No health data from the server for ${seconds((Date.now() - this.lastAt) / 1000)}.` }),
    );
  }
}
