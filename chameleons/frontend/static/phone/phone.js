/* The participant's phone. State comes from the server (page, WebSocket, answers to
 * submissions); answers typed but not yet sent live in localStorage (storage.js), and every
 * submission waits in a local outbox, with its own id, until the server has stored it
 * (outbox.js). This module shows the state's view and keeps the live connection. */

import { app, token } from "./context.js";
import { setConnection, setSave, showError } from "./dom.js";
import { connectOutbox, flush } from "./outbox.js";
import { questionnaireView } from "./questionnaire.js";
import { rankedView, rankingView, updateRanked } from "./ranking.js";
import { forgetAll, load, newClientId, store } from "./storage.js";
import {
  consentView, endedView, languageChooser, listenView, pausedView, sentAwayView, waitingView, welcomeView
} from "./views.js";

var state = JSON.parse(document.getElementById("initial-state").textContent);
var renderedKey = null;

/* ---------- views ---------- */
function viewKey(s) {
  return [s.view, s.position, s.questionnaire ? s.questionnaire.id : ""].join("|");
}

function render(next) {
  // An older view than the one shown (a submission's reply that a busy phone received
  // after the socket's newer view) would take the participant back a step.
  if (isOlder(next, state)) { return; }
  var wasPaused = state && state.view === "paused";
  state = next;
  if (wasPaused && next.view !== "paused") { setTimeout(flush, 0); } // answers held meanwhile
  var nextKey = viewKey(next);
  if (nextKey === renderedKey) {
    if (next.view === "ranked") { updateRanked(next); }
    return;
  }
  renderedKey = nextKey;
  showError("");
  var builders = {
    welcome: welcomeView, waiting: waitingView, listen: listenView, ranking: rankingView,
    ranked: rankedView, questionnaire: questionnaireView, ended: endedView, consent: consentView,
    paused: pausedView
  };
  app.replaceChildren((builders[next.view] || waitingView)(next));
  if (next.languages) { app.prepend(languageChooser(next)); }
  app.dataset.view = next.view;
  var heading = app.querySelector("h1");
  if (heading) { heading.setAttribute("tabindex", "-1"); heading.focus({ preventScroll: true }); }
  window.scrollTo(0, 0);
  if (next.view === "ended") { forgetAll(); setConnection("ended"); setSave(""); }
}

/* Views carry their version, the session's newest event id when they were read; the
 * ended and sent-away views carry none and always count. */
function isOlder(next, shown) {
  return Boolean(shown) && next.version != null && shown.version != null &&
    next.version < shown.version;
}

connectOutbox(function () { return state; }, render);

/* ---------- the live connection: reconnects by itself with backoff ---------- */
var socket = null;
var attempts = 0;
var lastHeard = Date.now();
// This phone's name for the server: the wizard sees two phones on one link as two.
var device = load("device", null) || newClientId();
store("device", device);

/* The wizard disconnected this phone: the link is open on another one. Nothing more is
 * sent from here (answers wait in the outbox), and it does not reconnect by itself. */
function sentAway() {
  state = { view: "sent_away" };
  renderedKey = "sent_away";
  app.replaceChildren(sentAwayView());
  app.dataset.view = "sent_away";
  setConnection("ended");
  setSave("");
}

function connect() {
  if (state.view === "ended" || state.view === "sent_away") { return; }
  setConnection(attempts ? "offline" : "connecting");
  var scheme = location.protocol === "https:" ? "wss://" : "ws://";
  var ws = new WebSocket(scheme + location.host + "/ws/p/" + encodeURIComponent(token) +
    "?device=" + encodeURIComponent(device));
  socket = ws;
  ws.onopen = function () { attempts = 0; lastHeard = Date.now(); setConnection("online"); flush(); };
  ws.onmessage = function (event) {
    lastHeard = Date.now();
    var message = JSON.parse(event.data);
    if (message.type === "state") { render(message.state); }
    if (message.type === "sent_away") { sentAway(); }
  };
  ws.onclose = function (event) {
    if (socket !== ws) { return; }
    socket = null;
    if (event.code === 4410) { render({ view: "ended" }); return; }
    if (event.code === 4409) {
      if (state.view !== "sent_away") { sentAway(); }
      return;
    }
    setConnection("offline");
    var delay = Math.min(8000, 400 * Math.pow(2, attempts)) * (0.75 + Math.random() / 2);
    attempts += 1;
    setTimeout(connect, delay);
  };
}

setInterval(function () {
  if (socket && socket.readyState === WebSocket.OPEN) {
    if (Date.now() - lastHeard > 45000) { socket.close(); return; } // silently dead
    socket.send('{"type":"ping"}');
  }
}, 15000);
window.addEventListener("online", function () {
  flush();
  if (socket) { socket.close(); } else { connect(); }
});
window.addEventListener("offline", function () { setConnection("offline"); });

render(state);
connect();
flush();
