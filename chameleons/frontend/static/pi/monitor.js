// The booths monitor: polls /api/pi/monitor every second and redraws each booth's card
// (participant, step, health chips, phone and robot, last events; red when in alarm).

import { describe } from "../wizard/timeline.js";
import { el, seconds } from "../wizard/dom.js";

const container = document.getElementById("booths");
const study = container.dataset.study;
const NO_NAMES = new Map();
const INTERVAL_MS = 1000;

// The participant video's chip says how long ago its last chunk came (`since_s`), as the
// console's does (wizard/health.js); the page redraws every second, so it counts on.
function chip(check) {
  const since = check.since_s == null ? "" : `, last ${seconds(check.since_s)} ago`;
  return el("span", { class: `chip ${check.level}`, title: check.id },
    el("strong", { text: check.label }), ` ${check.value}${since}`);
}

function card(booth) {
  const s = booth.session;
  const who = s
    ? el("p", { class: "who" },
        el("a", { href: `/pi/sessions/${s.id}`, text: s.participant }),
        s.rehearsal ? el("span", { class: "badge", text: " rehearsal" }) : null,
        ` · ${s.state}`, s.paused ? el("strong", { class: "paused", text: " · PAUSED" }) : null, s.position ? ` · interaction ${s.position} · ${s.step}` : "",
        s.condition ? ` · ${s.condition}` : "")
    : el("p", { class: "who muted", text: "No open session." });
  const phone = s
    ? el("span", { class: `chip ${s.phone_connected ? "ok" : s.state === "running" ? "alarm" : "unknown"}` },
        el("strong", { text: "Phone" }),
        s.phones > 1 ? ` ${s.phones} on one link` : s.phone_connected ? " connected" : " not connected")
    : null;
  const chips = el("div", { class: "chips" }, phone, booth.health.checks.map(chip));
  const problems = el("ul", { class: "problems" }, booth.problems.map((p) => el("li", { text: p })));
  const recent = el("ol", { class: "recent" },
    (s ? s.events : []).map((e) => el("li", { text: describe(e, NO_NAMES) })));
  const state = booth.alarm ? " alarm" : booth.problems.length ? " warn" : "";
  // The booth check for this booth, stored with its open session when there is one.
  const check = el("p", { class: "small" }, el("a", {
    class: "booth-check-link", text: "Booth check",
    href: `/booths/${encodeURIComponent(booth.booth)}/check${s ? `?session_id=${s.id}` : ""}`,
  }));
  return el("article", { class: `booth${state}`, dataset: { booth: booth.booth } },
    el("h2", { text: booth.booth }), check, who, chips, problems, recent);
}

async function refresh() {
  try {
    const response = await fetch(`/api/pi/monitor?study=${study}`, { credentials: "same-origin" });
    if (!response.ok) throw new Error(`the server answered ${response.status}`);
    const data = await response.json();
    const cards = data.booths.map(card);
    container.replaceChildren(...(cards.length ? cards
      : [el("p", { class: "muted", id: "no-booths", text: "No booth has an open session or a worker." })]));
    const alarms = document.getElementById("monitor-alarms");
    alarms.textContent = `${data.alarms} alarm${data.alarms === 1 ? "" : "s"}`;
    alarms.classList.toggle("bad", data.alarms > 0);
    document.getElementById("monitor-updated").textContent = data.generated_at.slice(11, 19);
    container.classList.remove("stale");
  } catch (error) {
    container.classList.add("stale");
    document.getElementById("monitor-updated").textContent = `not updated: ${error.message}`;
  }
}

refresh();
setInterval(refresh, INTERVAL_MS);
