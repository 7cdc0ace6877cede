// The wizard console: state from the server (HTTP on load, then the live WebSocket),
// rendered by the panels; every action goes to the server and comes back as events.

import { createApi } from "./api.js";
import { confirmDialog, reasonDialog } from "./dialogs.js";
import { HealthStrip } from "./health.js";
import { bindKeys } from "./keys.js";
import { connectLive } from "./live.js";
import { NowPlaying, SPEECH_KINDS, playState, speakingByEvents, voicing } from "./nowplaying.js";
import {
  interactionAt,
  itemNames,
  primaryAction,
  renderBar,
  renderCondition,
  renderNegotiation,
  renderParticipant,
  renderPause,
  renderPhones,
  renderPrimary,
  tickUndo,
} from "./panels.js";
import { PromptBoard } from "./prompts.js";
import { bindFilter, Timeline } from "./timeline.js";

const $ = (id) => document.getElementById(id);
const root = $("console");
const sessionId = Number(root.dataset.sessionId);
const link = { server: true, live: false };
const api = createApi(sessionId, root.dataset.csrf, (ok) => {
  link.server = ok;
  showLink();
});

let state = null;
let gone = false; // the session was deleted (its participant withdrawn): nothing works here
let promptsPosition = null;
let sendingGroup = null;
let flashTimer = null;
let liveStates = 0; // console states the WebSocket has delivered

const board = new PromptBoard($("prompt-sections"), $("prompt-search"), $("search-count"), play);
const timeline = new Timeline($("timeline"), $("timeline-count"));
const now = new NowPlaying($("now-playing"), $("now-label"), $("now-bar"), (s) =>
  board.markPlaying(["playing", "sending"].includes(s.phase) ? s.group : null),
);
const health = new HealthStrip(
  $("health"),
  () => perform("try the robot again", api.robotRetry),
  () => perform("pair with the next phone", api.pairCapture),
);

function showLink() {
  if (gone) return;
  const banner = $("conn-banner");
  const problems = [];
  if (!link.server) problems.push("The server is unreachable: actions are not saved. Retrying…");
  else if (!link.live) problems.push("Live updates interrupted: reconnecting… (the page may be out of date)");
  banner.hidden = problems.length === 0;
  banner.textContent = problems.join(" ");
  root.classList.toggle("offline", problems.length > 0);
}

function flash(message, kind = "error") {
  const node = $("flash");
  node.textContent = message;
  node.className = `wz-flash ${kind}`;
  node.hidden = false;
  clearTimeout(flashTimer);
  flashTimer = setTimeout(() => (node.hidden = true), kind === "error" ? 9000 : 4000);
}

/** Say, for good, that this tab's session no longer exists, and stop acting on it: ids are
 * never reused, so the tab cannot quietly turn into another participant's session. */
function showGone() {
  if (gone) return;
  gone = true;
  feed.close();
  const banner = $("conn-banner");
  banner.replaceChildren(
    "This session no longer exists: its participant was withdrawn (or the session deleted). " +
      "Nothing done on this page is saved. ",
  );
  const back = document.createElement("a");
  back.href = "/wizard";
  back.textContent = "Back to the sessions";
  banner.append(back);
  banner.hidden = false;
  banner.dataset.gone = "true";
  root.classList.add("gone");
  for (const control of root.querySelectorAll("button, input, select, textarea")) control.disabled = true;
}

/** A 404 from an action may be about the thing acted on; the console itself says whether
 * the session is gone. */
async function checkGone() {
  try {
    await api.console();
  } catch (error) {
    if (error.status === 404) showGone();
  }
}

async function perform(what, run) {
  if (gone) return;
  try {
    await run();
    if (!link.live) await refresh();
  } catch (error) {
    if (error.status === 404) await checkGone();
    if (!gone) flash(`${what}: ${error.message}`);
  }
}

/** Put the robot in the interaction's condition and face again, by hand (logged either
 * way). Starting an interaction or switching its condition needs no call from here: the
 * server's booth flow sets the robot up then, once (two set-ups logged the same line twice). */
async function applyRobot() {
  try {
    const result = await api.robotApply();
    if (result.kind !== "robot.applied") {
      const failed = [result.behaviour, result.face_result].filter((r) => !r.sent);
      flash(`Robot not set to ${result.condition}: ${failed.map((r) => r.detail).join("; ")}`, "warn");
    }
  } catch (error) {
    flash(`Robot not set: ${error.message}`, "warn");
  }
}

/** The server could not set the robot up (it does when an interaction starts or its
 * condition changes): say so where the wizard looks, as the set-up by hand does. */
function warnRobotNotSet(events) {
  const failed = events.filter((e) => e.kind === "robot.not_applied" && e.source !== "wizard").pop();
  if (!failed) return;
  const p = failed.payload;
  const details = [p.behaviour, p.face_result].filter((r) => r && !r.sent).map((r) => r.detail);
  flash(`Robot not set to ${p.condition}: ${details.join("; ")}`, "warn");
}

function expectedBehaviour() {
  if (!state || state.session.state !== "running") return null;
  const interaction = interactionAt(state);
  return ["discussion", "ranking", "negotiation"].includes(interaction.state) ? interaction.condition : null;
}

async function refresh() {
  const before = liveStates;
  try {
    const next = await api.console();
    // A state the WebSocket delivered meanwhile is as new as this answer or newer, and the
    // socket sends every change after it: this answer, read earlier, would undo changes.
    if (liveStates === before) apply(next);
  } catch (error) {
    if (error.status === 404) showGone();
    else flash(`Could not load the session: ${error.message}`);
  }
}

/** A live update carries only the events new since the last one (events_delta): they join
 * the events this page holds. Anything else is the whole timeline: it replaces them. */
function withHeldEvents(next) {
  if (!next.events_delta) return next;
  const held = state ? state.events : [];
  const known = new Set(held.map((e) => e.id));
  const events = held.concat(next.events.filter((e) => !known.has(e.id)));
  events.sort((a, b) => a.id - b.id); // already in order but for a rare late commit
  return { ...next, events };
}

async function apply(next) {
  if (gone) return;
  if (!next.events_delta) timeline.reset(); // texts may have changed (a withdrawal)
  state = withHeldEvents(next);
  // The Speaking chip follows speech events as they arrive (not the 1 Hz heartbeat).
  if (next.events_delta && next.events.some((e) => SPEECH_KINDS.has(e.kind))) {
    health.speechEvent(speakingByEvents(state.events));
  }
  if (next.events_delta) warnRobotNotSet(next.events);
  if (state.prompt_position !== promptsPosition) {
    promptsPosition = state.prompt_position;
    try {
      board.render(await api.prompts(promptsPosition));
    } catch (error) {
      $("prompt-sections").textContent = `The prompts cannot be shown: ${error.message}`;
    }
    // The session may have gone while the prompts loaded: rendering now would enable again
    // the controls showGone disabled.
    if (gone) return;
  }
  renderBar(state);
  renderPhones(state, disconnectPhone);
  renderPrimary(state, api, perform);
  renderPause(state);
  renderCondition(state, requestSwitch, () => perform("set up the robot", applyRobot));
  renderNegotiation(state, board, act);
  renderParticipant(state);
  markStep(state);
  const over = ["complete", "ended"].includes(state.session.state);
  const paused = Boolean(state.session.paused);
  $("end-open").disabled = over;
  $("pause-open").disabled = over || paused || !["running", "final_questionnaire"].includes(state.session.state);
  board.setDisabled(over || paused);
  $("say-button").disabled = over || paused;
  board.highlight(state.suggestion_prompts);
  board.markPlayed(voicing(state.events, state.prompt_position));
  timeline.sync(state.events, itemNames(state));
  if (!sendingGroup) now.show(playState(state.events));
}

/** The step and phone as attributes of the console: the layout follows them (console.css
 * puts the replies and the live ranking first during the negotiation). */
function markStep(current) {
  const session = current.session;
  const interaction = session.interactions.find((i) => i.position === current.prompt_position);
  const node = $("console");
  node.dataset.step = session.state === "running" && interaction ? interaction.state : session.state;
  node.dataset.phone = session.phone.connected ? "connected" : "absent";
}

async function play(group) {
  if (gone) return;
  if (board.disabled) {
    flash(promptsOff(), "warn");
    return;
  }
  const button = board.find(group);
  sendingGroup = group;
  now.sending(button ? button.text : group, group);
  try {
    await api.play(group); // "not sent" shows on the now-playing bar and the timeline
  } catch (error) {
    if (error.status === 404) await checkGone();
    if (!gone) flash(`Play failed: ${error.message}`);
  } finally {
    sendingGroup = null;
  }
  if (!link.live) await refresh();
  else if (state) now.show(playState(state.events));
}

function act(what) {
  if (!state) return;
  const allowed = state.session.allowed;
  const decide = allowed.find((a) => a.action === "decide");
  const undo = allowed.find((a) => a.action === "undo");
  if ((what === "accept" || what === "decline") && decide) {
    perform(`${what} suggestion ${decide.index}`, () => api.decide(decide.position, decide.index, what === "accept"));
  } else if (what === "undo" && undo && Date.parse(undo.until) > Date.now()) {
    perform(`undo suggestion ${undo.index}`, () => api.undo(undo.position, undo.index));
  } else if (what === "undo" && undo) {
    flash(`Too late to undo suggestion ${undo.index}: its undo window has passed.`, "warn");
  } else {
    flash(`Cannot ${what} now. ${allowedNow(state, undo)}`, "warn");
  }
}

/** The server's "Allowed now: …" without an undo whose window has passed since. */
function allowedNow(state, undo) {
  const sentence = state.session.allowed_sentence;
  if (!undo || Date.parse(undo.until) > Date.now()) return sentence;
  const clause = `undo the decision on suggestion ${undo.index} of interaction ${undo.position}`;
  return sentence.replace(`; or ${clause}`, "").replace(`${clause}; or `, "");
}

/** Disconnecting a phone cannot be undone from here (that phone stops and says the link is
 * open on another): the wizard confirms which one. */
function disconnectPhone(phone) {
  confirmDialog(
    `Disconnect phone ${phone.number} (${phone.label})? It stops and says the link is open on ` +
      "another phone; the participant continues on the other one.",
    () => perform(`disconnect phone ${phone.number}`, () => api.disconnectPhone(phone.id)),
    { title: `Disconnect phone ${phone.number}?`, ok: `Disconnect phone ${phone.number}` },
  );
}

function requestSwitch(interaction, condition) {
  if (condition === interaction.condition) return;
  const position = interaction.position;
  const switchTo = (confirmed) =>
    perform("switch condition", async () => {
      try {
        await api.condition(position, condition, confirmed);
      } catch (error) {
        // A condition this session already ran: the server asks for a confirmation.
        if (error.confirm !== "confirm_deviation" || confirmed) throw error;
        confirmDialog(error.message, () => switchTo(true));
      }
    });
  if (condition === interaction.planned_condition) {
    switchTo(false);
    return;
  }
  confirmDialog(
    `Interaction ${position} is planned as "${interaction.planned_condition}". ` +
      `Switch it to "${condition}"? This is logged as a deviation from the plan.`,
    () => switchTo(false),
  );
}

function promptsOff() {
  return state && state.session.paused
    ? "The session is paused: prompts are off until you resume it."
    : "The session is over: prompts are off.";
}

function openPauseDialog() {
  if (!state || state.session.paused) return;
  reasonDialog("pause", (reason, note) => perform("pause the session", () => api.pause(reason, note)));
}

function openEndDialog() {
  if (!state || ["complete", "ended"].includes(state.session.state)) return;
  reasonDialog("end", (reason, note) => perform("end the session", () => api.end(reason, note)));
}

/** After Enter in a text field the keys belong to the console again (a note typed after
 * Shift+N must never land in the Say field and be spoken). The text stays in the field
 * until it is saved, so nothing typed is lost when saving fails. */
function backToConsole(input) {
  input.blur();
  if (document.activeElement && document.activeElement !== document.body) document.activeElement.blur();
}

/** Escape in a text field stops the robot too, when it is (or may be) speaking. */
function speakingNow() {
  return ["playing", "sending"].includes(now.state.phase) || health.speaking;
}

async function addNote(event) {
  event.preventDefault();
  const input = $("note-text");
  const text = input.value.trim();
  if (!text) {
    flash("Write the note first: it is empty.", "warn");
    return;
  }
  backToConsole(input);
  try {
    await api.note(text);
    input.value = ""; // kept on failure, so nothing typed is lost
    flash("Note added to the timeline.", "ok");
    if (!link.live) await refresh();
  } catch (error) {
    flash(`Note not saved: ${error.message}`);
  }
}

async function sayTyped(event) {
  event.preventDefault();
  const input = $("say-text");
  const text = input.value.trim();
  if (!text) {
    flash("Type what the robot should say first.", "warn");
    return;
  }
  if (board.disabled) {
    flash(promptsOff(), "warn");
    return;
  }
  backToConsole(input);
  sendingGroup = "typed";
  now.sending(text, "typed");
  try {
    const result = await api.say(text);
    input.value = ""; // kept when it failed, so nothing typed is lost
    if (!result.sent) flash(`Not sent to the robot: ${result.detail || result.reason}`, "warn");
  } catch (error) {
    flash(`Not said: ${error.message}`);
  } finally {
    sendingGroup = null;
  }
  if (!link.live) await refresh();
  else if (state) now.show(playState(state.events));
}

bindKeys({
  note: () => $("note-text").focus(),
  say: () => $("say-text").focus(),
  stop: () => perform("stop", () => api.stop()),
  stopIfSpeaking: () => {
    if (speakingNow()) perform("stop", () => api.stop());
  },
  search: () => $("prompt-search").focus(),
  help: () => $("help-dialog").showModal(),
  accept: () => act("accept"),
  decline: () => act("decline"),
  undo: () => act("undo"),
  primary: () => {
    const action = state && primaryAction(state, api);
    if (action && action.run) perform(action.label, action.run);
  },
  suggestion: (index) => {
    const group = state && state.suggestion_prompts[index];
    if (group) play(group);
  },
  play: (code, shift) => {
    const group = board.groupForKey(code, shift);
    if (group) play(group);
    return Boolean(group);
  },
  playFirstMatch: () => {
    const group = board.firstVisible();
    if (group) play(group);
  },
});

$("stop-button").addEventListener("click", () => perform("stop", () => api.stop()));
$("end-open").addEventListener("click", openEndDialog);
$("pause-open").addEventListener("click", openPauseDialog);
$("note-form").addEventListener("submit", addNote);
$("say-form").addEventListener("submit", sayTyped);
bindFilter($("timeline-filter"), $("timeline"), (filter) => (timeline.filter = filter));
$("help-open").addEventListener("click", () => $("help-dialog").showModal());
setInterval(() => state && tickUndo(state), 1000);

const feed = connectLive(sessionId, {
  onStatus(open) {
    link.live = open;
    if (open) link.server = true;
    showLink();
  },
  onSignedOut() {
    location.assign(`/login?next=${encodeURIComponent(location.pathname)}`);
  },
  onMessage(message) {
    health.heard();
    if (message.type === "gone") showGone();
    else if (message.type === "console") {
      liveStates += 1;
      apply(message);
    }
    else if (message.type === "health") health.update(message, expectedBehaviour());
  },
});
refresh();
