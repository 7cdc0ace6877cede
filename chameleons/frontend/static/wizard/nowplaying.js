// The now-playing bar: what the robot says, its progress, and whether the worker got it.
// Derived from the timeline (so a reload shows the same), plus "sending" while a click is
// on its way. Also from the timeline: which plays the participant heard (the prompt
// buttons' marks) and whether the robot speaks now (the Speaking chip, between heartbeats).

const DONE_MARGIN_MS = 1500;
const NOT_SENT = {
  no_worker: "worker unreachable",
  unreachable: "worker unreachable",
  timeout: "worker did not answer",
};

/** What became of each play (``prompt.played`` id -> {group, position, voiced, reason}):
 * ``voiced`` true once the robot started speaking it, false once anything says the
 * participant did not hear it (not sent, not voiced, or ended with a reason such as the
 * robot display closing while it played), null while that is not known yet. */
export function playResults(events) {
  const plays = new Map();
  for (const event of events) {
    const p = event.payload || {};
    if (event.kind === "prompt.played") {
      plays.set(event.id, { group: p.group, position: p.position, voiced: null, reason: null });
      continue;
    }
    const play = plays.get(p.play_event_id);
    if (!play) continue;
    if (event.kind === "prompt.speech_start" && play.voiced === null) play.voiced = true;
    const failed = ["prompt.not_sent", "prompt.not_voiced"].includes(event.kind)
      || (event.kind === "prompt.speech_end" && p.reason);
    if (failed) {
      play.voiced = false;
      play.reason = NOT_SENT[p.reason] || p.detail || p.reason || "not voiced";
    }
  }
  return plays;
}

/** Per prompt group of the interaction at ``position``: how many plays the participant
 * heard, how many they did not (never sent, not voiced, cut short by the display closing)
 * and why. A play nobody voiced gets no tick: the wizard must see it was not heard. */
export function voicing(events, position) {
  const tally = new Map();
  for (const play of playResults(events).values()) {
    if (play.position !== position || play.voiced === null) continue;
    const entry = tally.get(play.group) || { voiced: 0, silent: 0, reason: null };
    if (play.voiced) entry.voiced += 1;
    else {
      entry.silent += 1;
      entry.reason = play.reason;
    }
    tally.set(play.group, entry);
  }
  return tally;
}

export const SPEECH_KINDS = new Set(["prompt.speech_start", "prompt.speech_end", "prompt.not_voiced", "prompt.stopped"]);

/** Whether the robot speaks the session's last play now, by the events alone: it started
 * and nothing has ended, stopped or failed it since. */
export function speakingByEvents(events) {
  let last = null;
  for (const event of events) if (event.kind === "prompt.played") last = event;
  if (!last) return false;
  let speaking = false;
  for (const event of events) {
    if (event.id <= last.id) continue;
    const ofLast = event.payload && event.payload.play_event_id === last.id;
    if (event.kind === "prompt.speech_start" && ofLast) speaking = true;
    if ((event.kind === "prompt.speech_end" || event.kind === "prompt.not_voiced") && ofLast) speaking = false;
    if (event.kind === "prompt.stopped" && event.payload.sent) speaking = false;
  }
  return speaking;
}

export function playState(events) {
  let played = null;
  for (let i = events.length - 1; i >= 0; i -= 1) {
    if (events[i].kind === "prompt.played") {
      played = events[i];
      break;
    }
  }
  if (!played) return { phase: "idle" };
  const later = events.filter((e) => e.id > played.id);
  const related = (kind) => later.find((e) => e.kind === kind && e.payload.play_event_id === played.id);
  const base = { played, text: played.payload.text, group: played.payload.group, duration: played.payload.duration };
  if (later.some((e) => e.kind === "prompt.stopped")) return { ...base, phase: "stopped" };
  // Sent and acknowledged, but no robot voiced it (no display open, robot skipped it...).
  const silent = related("prompt.not_voiced");
  if (silent) return { ...base, phase: "not-sent", notVoiced: true, reason: silent.payload.detail };
  const ended = related("prompt.speech_end");
  // The robot display could not play it (e.g. it needs a click to enable sound, or it was
  // closed while it played): say so.
  if (ended && ended.payload.reason) return { ...base, phase: "not-sent", notPlayed: true, reason: ended.payload.detail || ended.payload.reason };
  if (ended) return { ...base, phase: "finished" };
  const failed = related("prompt.not_sent");
  if (failed) return { ...base, phase: "not-sent", reason: NOT_SENT[failed.payload.reason] || failed.payload.detail };
  const started = related("prompt.speech_start") || related("prompt.acked");
  if (!started) return { ...base, phase: "sending" };
  const startMs = Date.parse(started.server_time);
  if (Date.now() - startMs > base.duration * 1000 + DONE_MARGIN_MS) return { ...base, phase: "finished" };
  return { ...base, phase: "playing", startMs };
}

export class NowPlaying {
  constructor(root, label, bar, onChange) {
    this.root = root;
    this.label = label;
    this.bar = bar;
    this.onChange = onChange;
    this.state = { phase: "idle" };
    this.frame = null;
  }

  sending(text, group) {
    this.show({ phase: "sending", text, group, duration: 0 });
  }

  show(state) {
    this.state = state;
    this.root.className = `wz-now ${state.phase}`;
    this.root.dataset.phase = state.phase;
    const prefix = {
      idle: "",
      sending: "Sending… ",
      playing: "Playing: ",
      "not-sent": `${state.notVoiced ? "NOT VOICED" : state.notPlayed ? "NOT PLAYED" : "NOT SENT"}, ${state.reason}: `,
      stopped: "Stopped: ",
      finished: "Last: ",
    }[state.phase];
    this.label.textContent = state.phase === "idle" ? "Nothing playing." : `${prefix}${state.text}`;
    this.label.className = state.phase === "finished" || state.phase === "stopped" ? "muted" : "";
    cancelAnimationFrame(this.frame);
    if (state.phase === "playing") this.tick();
    else this.bar.style.width = state.phase === "not-sent" ? "100%" : "0%";
    this.onChange(state);
  }

  tick() {
    const { startMs, duration } = this.state;
    const fraction = Math.min(1, (Date.now() - startMs) / Math.max(1, duration * 1000));
    this.bar.style.width = `${(fraction * 100).toFixed(1)}%`;
    if (Date.now() - startMs > duration * 1000 + DONE_MARGIN_MS) {
      this.show({ ...this.state, phase: "finished" });
      return;
    }
    this.frame = requestAnimationFrame(() => this.tick());
  }
}
