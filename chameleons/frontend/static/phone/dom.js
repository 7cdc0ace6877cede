/* Small DOM helpers (text only: never innerHTML) and the page's status bar: the
 * connection, what was saved, the error line and the screen reader's announcements. */

import { t } from "./context.js";

var connection = document.getElementById("connection");
var saveStatus = document.getElementById("save-status");
var errorBox = document.getElementById("error");
var announcer = document.getElementById("announce");

export function h(tag, attrs) {
  var node = document.createElement(tag);
  Object.keys(attrs || {}).forEach(function (name) {
    var value = attrs[name];
    if (value === null || value === undefined || value === false) { return; }
    if (name === "text") { node.textContent = value; } else if (name.indexOf("on") === 0) {
      node.addEventListener(name.slice(2), value);
    } else { node.setAttribute(name, value === true ? "" : value); }
  });
  for (var i = 2; i < arguments.length; i++) {
    if (arguments[i]) { node.appendChild(arguments[i]); }
  }
  return node;
}

export function panel() {
  var section = h("section", { class: "panel" });
  for (var i = 0; i < arguments.length; i++) { if (arguments[i]) { section.appendChild(arguments[i]); } }
  return section;
}

export function announce(text) { announcer.textContent = ""; announcer.textContent = text; }
export function showError(text) { errorBox.textContent = text; errorBox.hidden = !text; }

/* The server's sentence of a refusal, or ours when it sent none. */
export function messageOf(data) {
  return typeof data.detail === "string" ? data.detail : t("Your answer could not be read. Please check it and try again.");
}

/* "Saved" names what was saved (the consent, the ranking, the answers): on the next
 * page, a bare "Saved ✓" read as if that page, empty as it was, were saved already. It goes
 * as soon as the participant changes something there. */
function savedText(what) {
  if (what === "consent") { return t("Consent saved ✓"); }
  if (what === "ranking") { return t("Ranking saved ✓"); }
  return t("Answers saved ✓");
}
export function setSave(kind, what) {
  var texts = {
    saving: t("Saving…"),
    saved: savedText(what),
    offline: t("Not sent yet – your answers are kept on this phone and sent as soon as the connection is back."),
    held: t("Kept on this phone – sent as soon as the session continues."),
    "": ""
  };
  saveStatus.textContent = texts[kind];
  saveStatus.dataset.state = kind;
}
/* The participant changed the page shown: what it says is not saved yet. */
export function editing() {
  if (saveStatus.dataset.state === "saved") { setSave(""); }
}
export function setConnection(kind) {
  var texts = { connecting: t("Connecting…"), online: t("Connected"), offline: t("Reconnecting…"), ended: "" };
  connection.textContent = texts[kind];
  connection.dataset.state = kind;
}
