// The session timeline: every event, newest first, with per-prompt latencies.

import { clock, el, seconds } from "./dom.js";

function rankingText(ranking, names) {
  return (ranking || []).map((id, i) => `${i + 1}. ${names.get(id) || id}`).join("  ");
}

function count(list, noun) {
  const n = Array.isArray(list) ? list.length : 0;
  return `${n} ${noun}${n === 1 ? "" : "s"}`;
}

/** A kind without a sentence yet: its short values, never whole paths or nested data. */
function summary(payload) {
  const parts = Object.entries(payload)
    .filter(([, v]) => ["string", "number", "boolean"].includes(typeof v))
    .map(([k, v]) => `${k} ${typeof v === "string" && v.includes("/") ? v.split("/").pop() : v}`);
  return parts.length ? ` (${parts.join(", ")})` : "";
}

/** Where a questionnaire belongs: before the interactions (position -1), after one, or at
 * the end (0). */
function questionnaireWhen(position) {
  if (position === -1) return "before the interactions";
  return position > 0 ? `after interaction ${position}` : "final";
}

export function describe(event, names) {
  const p = event.payload || {};
  const item = (id) => names.get(id) || id;
  switch (event.kind) {
    case "session.created": return `Session created for ${p.participant} (${p.booth})`;
    case "session.started": return "Session started";
    case "interaction.advanced": return `Interaction ${p.position}: ${p.from} → ${p.to}`;
    case "ranking.submitted": return `Phone: ranking submitted — ${rankingText(p.ranking, names)}`;
    case "questionnaire.submitted": return `Phone: questionnaire ${p.questionnaire || ""} answered (${questionnaireWhen(p.position)})`;
    case "consent.given": return `Phone: consent given (${p.version || "consent"})`;
    case "consent.declined": return `PARTICIPANT DECLINED CONSENT (${p.version || "consent"}): the session ended`;
    case "suggestion.proposed": return `Suggestion ${p.index} proposed: ${item(p.item)} from ${p.from_rank} to ${p.to_rank} (${p.kind})`;
    case "suggestion.decided": return `Suggestion ${p.index} ${p.accepted ? "ACCEPTED" : "DECLINED"}: ${item(p.item)}`;
    case "suggestion.undone": return `Suggestion ${p.index}: decision undone (was ${p.was_accepted ? "accepted" : "declined"})`;
    case "condition.switched": return `Condition of interaction ${p.position}: ${p.from} → ${p.to} (planned ${p.planned})${p.confirmed ? `, confirmed although interaction ${p.repeats_position} already ran ${p.to}` : ""}`;
    case "plan.deviation": return `DEVIATION from plan: interaction ${p.position} runs ${p.to}, planned ${p.planned}`;
    case "prompt.played": return p.typed ? `▶ (typed) ${p.text}` : `▶ ${p.text}`;
    case "wizard.typed_speech": return `TYPED SPEECH (deviation): "${p.text}"`;
    case "prompt.acked": return `Worker acknowledged ${p.prompt_id} after ${p.click_to_ack_ms} ms`;
    case "prompt.not_sent": return `Not sent: ${p.detail || p.reason}`;
    case "prompt.speech_start": return `Speech started ${p.click_to_speech_ms} ms after the click`;
    case "prompt.speech_end":
      if (p.reason) return `NOT PLAYED: ${p.detail || p.reason} (${p.prompt_id})`;
      return p.outcome && p.outcome !== "played" ? `Speech ${p.outcome} (${p.prompt_id})` : `Speech ended (${p.prompt_id})`;
    case "prompt.stopped": return p.sent ? "Stopped the prompt" : `Stop not sent: ${p.detail || p.reason}`;
    case "robot.applied": return p.behaviour && p.behaviour.unchanged && p.face_result && p.face_result.unchanged
      ? `Robot runs ${p.condition}, face ${p.face} (set already)` : `Robot set to ${p.condition}, face ${p.face}${p.behaviour_words ? `: ${p.behaviour_words}` : ""}`;
    case "robot.not_applied": return `Robot NOT set to ${p.condition}/${p.face}: ${[p.behaviour, p.face_result].filter((r) => !r.sent).map((r) => r.detail).join("; ")}`;
    case "wizard.note": return `Note: ${p.text}`;
    case "recording.started": return `Recording interaction ${p.position} (${Object.keys(p.files || {}).join(" and ") || "streams"})`;
    case "recording.stopped": return `Recording of interaction ${p.position} saved (${count(p.recordings, "file")})`;
    case "recording.indexed": return `Recording of interaction ${p.position}: ${count(p.recordings, "more file")} saved`;
    case "capture.pairing_reset": return p.sent ? `Face capture pairs with the next phone${p.previous_sender ? ` (was ${p.previous_sender})` : ""}` : `Pairing not reset: ${p.detail || p.reason}`;
    case "recording.failed": return `RECORDING FAILED (interaction ${p.position}): ${p.reason}`;
    case "recording.not_started": return `RECORDING NOT STARTED (interaction ${p.position}): ${p.detail || p.reason}`;
    case "recording.not_stopped": return `RECORDING NOT STOPPED (interaction ${p.position}): ${p.detail || p.reason}; ${count(p.recordings, "file")} recovered`;
    case "robot.copy_draw": return p.bout != null
      ? `Copy bout ${p.bout + 1}: ${p.bout_s} s after a rest of ${Number(p.rest_s).toFixed(1)} s, ${Number(p.delay_s).toFixed(2)} s late`
      : `Copy delay drawn: ${Number(p.delay_s).toFixed(2)} s`;
    case "robot.connected": return `Robot connected (${p.booth || "booth"})`;
    case "robot.disconnected": return `ROBOT DISCONNECTED (${p.booth || "booth"})`;
    case "robot.auth_refused": return `ROBOT REFUSED THE LOGIN (${p.booth || "booth"}): ${p.reason || "wrong or missing key"}`;
    case "robot.auth_timeout": return `ROBOT DID NOT ANSWER THE LOGIN (${p.booth || "booth"})`;
    case "robot.retry_requested": return `Asked the worker to try the robot again (${p.booth || "booth"})`;
    case "worker.connected": return `Worker of ${p.booth || "the booth"} connected`;
    case "worker.lost": return `WORKER LOST (${p.booth || "booth"})${p.last_seen_s != null ? `: silent for ${p.last_seen_s} s` : ""}`;
    case "worker.restarted": return `Worker of ${p.booth || "the booth"} restarted (restart ${p.restarts ?? "?"})`;
    case "prompt.not_voiced": return `NOT VOICED: ${p.detail || p.reason || p.prompt_id}`;
    case "prompt.not_played": return `NOT PLAYED: ${p.detail || p.reason || p.prompt_id}`;
    case "behaviour.natural_source": return `Natural movement replays ${p.source === "clip" ? `clip ${p.clip}` : p.source === "yoked" ? `participant ${p.from_participant}, interaction ${p.from_position} (${p.from_condition})` : `a synthetic face (seed ${p.seed})`}`;
    case "session.rehearsal_marked": return "Marked as a rehearsal";
    case "session.rehearsal_unmarked": return "No longer marked as a rehearsal";
    case "phone.connected": return p.phones > 1 ? `PHONE CONNECTED: ${p.phones} phones on this link now (${p.label})` : "Phone connected";
    case "phone.language": return `Participant chose language ${p.to} (was ${p.from})`;
    case "phone.disconnected": return p.phones > 0 ? `Phone disconnected (${p.label}); ${p.phones} still on the link` : "Phone disconnected";
    case "phone.sent_away": return `Wizard disconnected phone ${p.number} (${p.label}): the link was open on another phone`;
    case "session.final_questionnaire": return "Final questionnaire started";
    case "session.completed": return "Session complete";
    case "session.ended_early": return `SESSION ENDED EARLY: ${p.reason_text || p.reason}${p.note ? ` (${p.note})` : ""}${p.position ? `, during interaction ${p.position} (${p.step})` : ""}`;
    case "session.paused": return `SESSION PAUSED: ${p.reason_text || p.reason}${p.note ? ` (${p.note})` : ""}${p.position ? `, during interaction ${p.position} (${p.step})` : ""}`;
    case "session.resumed": return `Session resumed after ${seconds(p.paused_s || 0)} (paused: ${p.reason_text || p.reason})`;
    case "participant.excluded": return `PI excluded the participant from the analysis: ${p.reason}`;
    case "participant.included": return "PI included the participant in the analysis again";
    case "plan_row.handed_on": return `PI gave plan row ${p.row_number} to a replacement participant`;
    default: return `${event.kind}${summary(p)}`;
  }
}

const DEVIATIONS = new Set(["plan.deviation", "condition.switched", "session.ended_early",
  "participant.excluded", "plan_row.handed_on", "prompt.not_voiced", "wizard.typed_speech"]);

/** The filter an event belongs to: prompts, phone, robot, deviations or notes. */
export function category(kind, source) {
  if (kind === "wizard.note") return "notes";
  if (DEVIATIONS.has(kind) || kind.endsWith(".deviation")) return "deviations";
  if (kind.startsWith("prompt.") || kind.startsWith("wizard.prompt")) return "prompts";
  if (source === "participant" || kind.startsWith("phone.")) return "phone";
  if (kind.startsWith("robot.") || kind.startsWith("worker.") || kind.startsWith("recording.")
      || source === "worker" || source === "robot") return "robot";
  return "session";
}

/** Show only ``filter``'s rows ("all": every row) of a list whose rows carry data-category. */
export function applyFilter(list, filter) {
  for (const row of list.children) {
    row.hidden = filter !== "all" && row.dataset.category !== filter;
  }
}

/** Buttons with data-filter in ``group`` switch the filter of ``list`` (aria-pressed shows it). */
export function bindFilter(group, list, onChange = () => {}) {
  group.addEventListener("click", (event) => {
    const button = event.target.closest("button[data-filter]");
    if (!button) return;
    for (const other of group.querySelectorAll("button[data-filter]")) {
      other.setAttribute("aria-pressed", String(other === button));
    }
    applyFilter(list, button.dataset.filter);
    onChange(button.dataset.filter);
  });
}

export class Timeline {
  constructor(list, counter) {
    this.list = list;
    this.counter = counter;
    this.filter = "all";
    this.lastId = 0;
    this.rows = new Map(); // event id -> row
    this.count = 0;
  }

  sync(events, names) {
    if (events.length && events[0].id < this.lastId && !this.rows.has(events[0].id)) this.reset();
    for (const event of events) {
      if (this.rows.has(event.id)) continue; // (a late commit can come below lastId)
      this.add(event, names);
    }
  }

  reset() {
    this.list.replaceChildren();
    this.rows.clear();
    this.lastId = 0;
    this.count = 0;
  }

  add(event, names) {
    this.lastId = Math.max(this.lastId, event.id);
    this.count += 1;
    // Wall-clock time as a person reads it; the worker's own clock (seconds since it
    // started) stays in the export and in the time's tooltip for an audit.
    const audit = event.worker_time != null ? `worker clock ${event.worker_time.toFixed(3)} s` : null;
    const row = el(
      "li",
      { class: `tl tl-${event.source} tl-${event.kind.replace(/\./g, "-")}`, dataset: { kind: event.kind, id: String(event.id), category: category(event.kind, event.source) } },
      el("time", { datetime: event.server_time, text: clock(event.server_time), title: audit }),
      el("span", { class: "tl-source", text: event.source }),
      el("span", { class: "tl-text", text: describe(event, names) }),
      el("span", { class: "tl-latency" }),
    );
    this.rows.set(event.id, row);
    row.hidden = this.filter !== "all" && row.dataset.category !== this.filter;
    this.place(row, event.id);
    this.counter.textContent = `(${this.count})`;
    this.attachLatency(event);
  }

  /** Newest (highest id) first: a new event goes on top; one committed late (an id below
   * rows already shown) goes where its id belongs, not on top. */
  place(row, id) {
    let next = this.list.firstElementChild;
    while (next && Number(next.dataset.id) > id) next = next.nextElementSibling;
    this.list.insertBefore(row, next);
  }

  attachLatency(event) {
    const p = event.payload || {};
    const played = p.play_event_id ? this.rows.get(p.play_event_id) : null;
    if (!played) return;
    const slot = played.querySelector(".tl-latency");
    if (event.kind === "prompt.acked") slot.dataset.ack = `ack ${p.click_to_ack_ms} ms`;
    if (event.kind === "prompt.speech_start") slot.dataset.speech = `speech ${p.click_to_speech_ms} ms`;
    if (event.kind === "prompt.not_sent") slot.dataset.ack = "not sent";
    if (event.kind === "prompt.not_voiced") slot.dataset.speech = "NOT VOICED";
    slot.textContent = [slot.dataset.ack, slot.dataset.speech].filter(Boolean).join(" · ");
    if (event.kind === "prompt.not_sent" || event.kind === "prompt.not_voiced") played.classList.add("tl-failed");
  }
}
