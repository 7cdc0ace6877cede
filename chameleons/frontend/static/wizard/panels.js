// The session bar, primary action, condition switch, negotiation panel and participant view.

import { clock, el, kbd } from "./dom.js";

const $ = (id) => document.getElementById(id);
export const SUGGESTION_KEYS = [
  { code: "KeyM", label: "M" },
  { code: "Comma", label: "," },
  { code: "Period", label: "." },
];
const STEP_ACTIONS = {
  discussion: (p) => `Start interaction ${p} (discussion)`,
  ranking: () => "Hand over: ranking on the phone",
  negotiation: () => "Start the negotiation",
  questionnaire: () => "Send to the questionnaire",
};
const WAITING = {
  consent: "Waiting for the participant's consent on the phone…",
  before: "Waiting for the participant's answers about themselves…",
  ranking: "Waiting for the participant's ranking…",
  questionnaire: "Waiting for the participant's questionnaire…",
  final_questionnaire: "Waiting for the final questionnaire…",
};

export function interactionAt(state) {
  return state.session.interactions.find((i) => i.position === state.prompt_position);
}

export function itemNames(state) {
  const names = new Map();
  for (const interaction of state.session.interactions) {
    for (const item of interaction.items) names.set(item.id, item.name);
  }
  return names;
}

export function renderBar(state) {
  const session = state.session;
  const interaction = interactionAt(state);
  $("bar-participant").textContent = session.participant.code;
  $("bar-rehearsal").hidden = !session.is_rehearsal;
  $("bar-language").textContent = session.language; // the phone may change it before consent
  $("bar-position").textContent = `${interaction.position} of ${session.interaction_count}`;
  $("bar-step").textContent = session.state === "running" ? interaction.state : session.state.replace("_", " ");
  $("bar-planned").textContent = interaction.planned_condition;
  $("bar-actor").textContent = interaction.actor;
  $("bar-robot").textContent = interaction.robot_name;
  $("bar-face").textContent = interaction.face;
  $("bar-scenario").textContent = `${interaction.task_name} · ${interaction.item_set}`;
  const qr = $("phone-qr");
  if (qr.getAttribute("src") !== session.phone.qr_svg) qr.src = session.phone.qr_svg;
  qr.hidden = false;
  qr.title = session.phone.url;
  $("phone-code").textContent = session.phone.short_code;
  const phone = $("phone-state");
  if (["complete", "ended"].includes(session.state)) {
    // The phone link stops working when the session is over (the page says thank you).
    phone.textContent = session.phone.connected ? "phone still on the last page" : "phone left";
    phone.className = "pill";
  } else if (session.phone.connections > 1) {
    phone.textContent = `${session.phone.connections} phones on this link`;
    phone.className = "pill warn";
  } else {
    phone.textContent = session.phone.connected ? "phone connected" : "phone not connected";
    phone.className = `pill ${session.phone.connected ? "ok" : "bad"}`;
  }
}

/** Two or more phones on the link: each with when it came and a Disconnect button (the
 * later ones are probably the extra; the wizard chooses). */
export function renderPhones(state, disconnect) {
  const session = state.session;
  const list = $("phone-devices");
  const phones = session.phone.devices || [];
  const over = ["complete", "ended"].includes(session.state);
  list.hidden = phones.length < 2 || over;
  if (list.hidden) {
    list.replaceChildren();
    return;
  }
  list.replaceChildren(
    ...phones.map((phone) =>
      el(
        "li",
        { dataset: { device: phone.id } },
        `Phone ${phone.number} · ${phone.label}`,
        phone.connected_at ? ` · since ${clock(phone.connected_at).slice(0, 8)}` : "",
        phone.extra ? el("span", { class: "muted", text: " (later)" }) : null,
        phone.id && el("button", {
          type: "button",
          class: phone.extra ? "danger" : "",
          text: "Disconnect",
          title: `Disconnect phone ${phone.number}: it says the link is open on another phone`,
          onclick: () => disconnect(phone),
        }),
      ),
    ),
  );
}

/** The primary (next-step) action: returns a function to run it, or null when none. */
export function primaryAction(state, api) {
  const action = state.session.allowed[0] || { action: "none" };
  if (action.action === "start") return { label: "Start the session", run: () => api.start() };
  if (action.action === "resume") return { label: "Resume the session", run: () => api.resume() };
  if (action.action === "advance") {
    const label = STEP_ACTIONS[action.to](action.position);
    return { label, run: () => api.advance(action.position, action.to) };
  }
  if (action.action === "decide") return { label: `Decide suggestion ${action.index}: A accept / D decline`, run: null };
  if (action.action === "wait") return { label: WAITING[action.for] || "Waiting…", run: null };
  if (action.why === "ended") return { label: "Session ended early", run: null };
  return { label: "Session complete", run: null };
}

/** While paused: since when and why, under the primary action (which resumes). */
export function renderPause(state) {
  const paused = state.session.paused;
  const banner = $("pause-banner");
  banner.hidden = !paused;
  if (!paused) return;
  const note = paused.note ? ` (${paused.note})` : "";
  banner.textContent = `Paused since ${clock(paused.since).slice(0, 8)}: ${paused.reason_text}${note}. ` +
    "The phone shows a short pause; prompts are off.";
}

export function renderPrimary(state, api, perform) {
  const action = primaryAction(state, api);
  const node = $("primary-action");
  node.replaceChildren(...[action.label, " ", action.run ? kbd("Ctrl+↵") : null].filter(Boolean));
  node.disabled = !action.run;
  node.onclick = action.run ? () => perform(action.label, action.run) : null;
  $("primary-hint").textContent = state.session.allowed_sentence;
}

/** What the robot does in a condition, e.g. "copies head, 4 s late" (from the study). */
function conditionDetails(state, condition) {
  return (state.session.condition_details || []).find((c) => c.id === condition) || { id: condition, label: condition, summary: "" };
}

export function renderCondition(state, requestSwitch, applyRobot) {
  const interaction = interactionAt(state);
  const closed = interaction.state === "done" || !["pending", "running"].includes(state.session.state);
  const buttons = state.session.conditions.map((condition) => {
    const details = conditionDetails(state, condition);
    return el(
      "button",
      {
        type: "button",
        class: condition === interaction.condition ? "active" : "",
        "aria-pressed": String(condition === interaction.condition),
        disabled: closed,
        title: `${details.label}: ${details.summary}`,
        dataset: { condition },
        onclick: () => requestSwitch(interaction, condition),
      },
      condition,
      condition === interaction.planned_condition ? el("span", { class: "planned", text: " planned" }) : null,
    );
  });
  $("condition-switch").replaceChildren(...buttons);
  const running = conditionDetails(state, interaction.condition);
  const natural = interaction.natural;
  // replaceChildren() would write a null as the text "null": leave the absent parts out.
  $("condition-note").replaceChildren(...[
    interaction.deviates_from_plan
      ? `Deviation: running ${interaction.condition}, planned ${interaction.planned_condition} (logged). `
      : `Interaction ${interaction.position} runs as planned. `,
    el("span", { id: "condition-behaviour", text: `Robot: ${running.summary}. ` }),
    natural ? el("span", { id: "natural-source", text: `Natural replays ${natural.recording}. ` }) : null,
    el("button", { type: "button", class: "link", id: "robot-apply", disabled: closed, onclick: applyRobot }, "Send condition and face to the robot"),
  ].filter((part) => part !== null));
}

export function renderNegotiation(state, board, act) {
  const interaction = interactionAt(state);
  const body = $("negotiation-body");
  const names = itemNames(state);
  const decided = interaction.suggestions.filter((s) => s.accepted !== null);
  const pending = interaction.suggestions.find((s) => s.accepted === null);
  const undo = state.session.allowed.find((a) => a.action === "undo");
  const parts = [];
  board.resetExtras();
  if (interaction.state !== "negotiation" && !decided.length) {
    body.className = "muted";
    body.replaceChildren("Not in negotiation yet.");
    return;
  }
  body.className = "";
  if (pending && interaction.state === "negotiation") {
    const groups = state.suggestion_prompts;
    parts.push(
      el(
        "div",
        { class: "suggestion-now" },
        el("div", { class: "k", text: `Suggestion ${pending.index} of ${state.session.suggestions_per_interaction} · ${pending.kind}` }),
        el("div", { class: "suggestion-move" }, "Move ", el("strong", { text: names.get(pending.item) || pending.item }),
          ` ${pending.to_rank < pending.from_rank ? "up" : "down"} from ${pending.from_rank} to ${pending.to_rank}`),
        el(
          "div",
          { class: "pb-row", id: "suggestion-prompts" },
          groups.length
            ? groups.slice(0, 3).map((group, i) => {
                const b = board.find(group);
                return b ? board.button(b, SUGGESTION_KEYS[i]) : null;
              })
            : el("span", { class: "error", id: "suggestion-missing", text: state.suggestion_missing || "No prompt phrases this suggestion." }),
        ),
        el(
          "div",
          { class: "decide" },
          el("button", { type: "button", class: "accept", onclick: () => act("accept") }, kbd("A"), " Accepted"),
          el("button", { type: "button", class: "decline", onclick: () => act("decline") }, kbd("D"), " Declined"),
        ),
      ),
    );
  }
  if (undo && undoLeft(undo) > 0) {
    parts.push(
      el(
        "button",
        { type: "button", class: "undo", id: "undo-button", onclick: () => act("undo") },
        kbd("U"),
        ` Undo suggestion ${undo.index} `,
        el("span", { class: "left", text: `(${undoLeft(undo)} s)` }),
      ),
    );
  }
  parts.push(
    el(
      "ol",
      { class: "decided" },
      interaction.suggestions.map((s) =>
        el(
          "li",
          { class: s.accepted === null ? "open" : s.accepted ? "yes" : "no", dataset: { index: String(s.index) } },
          `${s.index}. ${names.get(s.item) || s.item} ${s.from_rank}→${s.to_rank} (${s.kind}) `,
          el("strong", { text: s.accepted === null ? "pending" : s.accepted ? "accepted" : "declined" }),
        ),
      ),
    ),
  );
  body.replaceChildren(...parts);
}

function undoLeft(undo) {
  return Math.max(0, Math.ceil((Date.parse(undo.until) - Date.now()) / 1000));
}

/** Count the undo window down once a second; the button goes when the window closes. */
export function tickUndo(state) {
  const button = document.getElementById("undo-button");
  const undo = state.session.allowed.find((a) => a.action === "undo");
  if (!button || !undo) return;
  const left = undoLeft(undo);
  if (left <= 0) button.remove();
  else button.querySelector(".left").textContent = `(${left} s)`;
}

export function renderParticipant(state) {
  const interaction = interactionAt(state);
  const names = itemNames(state);
  const initial = interaction.initial_ranking;
  const current = interaction.current_ranking || initial;
  const ranking = current
    ? el(
        "ol",
        { class: "ranking", id: "live-ranking" },
        current.map((id) => {
          const was = initial.indexOf(id) + 1;
          const now = current.indexOf(id) + 1;
          return el(
            "li",
            { class: was !== now ? "moved" : "", dataset: { item: id } },
            names.get(id) || id,
            was !== now ? el("span", { class: "muted small", text: ` (was ${was})` }) : null,
          );
        }),
      )
    : el("p", { class: "muted", id: "live-ranking-empty", text: "No ranking submitted yet." });
  const progress = (p, label) =>
    el(
      "div",
      { class: "qprogress" },
      `${label}: ${p.answered.length} of ${p.required.length} done`,
      el("progress", { max: String(p.required.length || 1), value: String(p.answered.length) }),
    );
  document.getElementById("participant-view").replaceChildren(
    el("div", { class: "k", text: initial ? "Ranking (live)" : "Ranking" }),
    ranking,
    progress(interaction.questionnaires, `Questionnaires after interaction ${interaction.position}`),
    progress(state.session.final_questionnaire, "Final questionnaire"),
  );
}
