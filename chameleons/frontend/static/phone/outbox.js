/* Submissions: outbox first, then the server; shown as saved only once stored. Every
 * submission waits in the local outbox, with its own id, until the server has stored it. */

import { api, postHeaders } from "./context.js";
import { messageOf, setSave, showError } from "./dom.js";
import { forget, load, newClientId, store } from "./storage.js";

var flushing = false;
var retryTimer = null;
var retryDelay = 1000;
// The page's state and how it shows a new one (set by the page, see connectOutbox).
var page = { state: function () { return {}; }, render: function () {} };

/* The outbox reads the view shown (paused, sent away) and shows the server's answers. */
export function connectOutbox(currentState, render) {
  page = { state: currentState, render: render };
}

export function submit(kind, body, draftName) {
  var box = load("outbox", []);
  var target = kind + ":" + body.position + ":" + (body.questionnaire || "");
  var entry = box.filter(function (e) { return e.target === target; })[0];
  if (entry) {
    entry.body = Object.assign({}, body, { client_id: entry.body.client_id });
  } else {
    entry = { target: target, kind: kind, draft: draftName, body: Object.assign({ client_id: newClientId() }, body) };
    box.push(entry);
  }
  store("outbox", box);
  showError("");
  setSave("saving");
  flush();
}

function dropFromOutbox(clientId) {
  store("outbox", load("outbox", []).filter(function (e) { return e.body.client_id !== clientId; }));
}

function scheduleRetry() {
  setSave("offline");
  if (retryTimer) { return; }
  retryTimer = setTimeout(function () { retryTimer = null; flush(); }, retryDelay);
  retryDelay = Math.min(retryDelay * 2, 8000);
}

export function flush() {
  var state = page.state();
  if (flushing || state.view === "sent_away") { return; }
  var box = load("outbox", []);
  if (!box.length) { return; }
  if (state.view === "paused") { setSave("held"); return; } // sent when the session continues
  flushing = true;
  var entry = box[0];
  fetch(api + "/" + entry.kind, {
    method: "POST", headers: postHeaders(), body: JSON.stringify(entry.body)
  }).then(function (response) {
    if (response.status >= 500) { throw new Error("server " + response.status); }
    return response.json().catch(function () { return {}; }).then(function (data) {
      if (response.status === 409) { return refused(entry, data); }
      dropFromOutbox(entry.body.client_id);
      if (response.ok) {
        if (entry.draft) { forget(entry.draft); }
        retryDelay = 1000;
        setSave("saved", entry.kind);
        page.render(data.state);
      } else if (response.status === 410) {
        page.render({ view: "ended" });
      } else {
        setSave("");
        showError(messageOf(data));
      }
    });
  }).then(function () {
    flushing = false;
    flush();
  }, function () {
    flushing = false;
    scheduleRetry();
  });
}

/* A 409: paused meanwhile (the answer stays in the outbox until the session continues),
 * or really refused (dropped, with the server's sentence). */
function refused(entry, data) {
  return fetch(api + "/state").then(function (response) {
    return response.ok ? response.json() : null;
  }).catch(function () { return null; }).then(function (fresh) {
    if (fresh && fresh.view === "paused") { page.render(fresh); setSave("held"); return; }
    dropFromOutbox(entry.body.client_id);
    setSave("");
    if (fresh) { page.render(fresh); } else { refresh(); }
    showError(messageOf(data));
  });
}

function refresh() {
  fetch(api + "/state").then(function (response) {
    if (response.status === 410) { page.render({ view: "ended" }); return null; }
    return response.ok ? response.json() : null;
  }).then(function (fresh) { if (fresh) { page.render(fresh); } }, function () { /* the socket retries */ });
}
