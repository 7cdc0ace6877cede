/* The pages with little to do on them: the language chooser, consent, welcome, waiting,
 * paused, listen, the end and the link open on another phone. */

import { api, postHeaders, t } from "./context.js";
import { h, messageOf, panel, setSave, showError } from "./dom.js";
import { submit } from "./outbox.js";
import { newClientId } from "./storage.js";

/* The study's languages, offered before consent; the page reloads in the one chosen
 * (its texts and this script's strings come from the server in that language). */
export function languageChooser(s) {
  var nav = h("nav", { class: "languages", "aria-label": t("Choose your language") });
  s.languages.forEach(function (language) {
    var current = language.code === s.language;
    nav.appendChild(h("button", {
      type: "button", class: "language", lang: language.code, "aria-pressed": current ? "true" : "false",
      "data-language": language.code, text: language.name,
      onclick: current ? null : function () { chooseLanguage(language.code); }
    }));
  });
  return nav;
}

function chooseLanguage(code) {
  fetch(api + "/language", {
    method: "POST", headers: postHeaders(),
    body: JSON.stringify({ client_id: newClientId(), language: code })
  }).then(function (response) {
    if (response.ok) { location.reload(); return null; }
    return response.json().then(function (data) { showError(messageOf(data)); });
  }).catch(function () { setSave("offline"); });
}

export function consentView(s) {
  var c = s.consent;
  var section = panel(h("h1", { text: c.title }));
  c.paragraphs.forEach(function (text) { section.appendChild(h("p", { text: text })); });
  var agree = h("button", { type: "button", class: "big primary", id: "consent-agree", text: c.agree });
  var decline = h("button", { type: "button", class: "big", id: "consent-decline", text: c.decline });
  var items = consentVideoItems(c.video);
  if (items.node) { section.appendChild(items.node); }
  agree.addEventListener("click", function () {
    submit("consent", { position: 0, agree: true, video: items.video(), audio: items.audio() });
  });
  decline.addEventListener("click", function () { submit("consent", { position: 0, agree: false }); });
  section.appendChild(h("div", { class: "consent-actions" }, agree, decline));
  return section;
}

/* The study's own video items (procedure.video): each optional, unticked; the microphone
 * item only counts with the video one (it is disabled until that is ticked). */
function consentVideoItems(video) {
  if (!video) { return { node: null, video: function () { return false; }, audio: function () { return false; } }; }
  var filmed = h("input", { type: "checkbox", id: "consent-video" });
  var box = h("fieldset", { class: "consent-video" },
    h("label", { class: "check" }, filmed, h("span", { text: video.label })));
  var voice = null;
  if (video.audio_label) {
    voice = h("input", { type: "checkbox", id: "consent-audio", disabled: "disabled" });
    box.appendChild(h("label", { class: "check" }, voice, h("span", { text: video.audio_label })));
    filmed.addEventListener("change", function () {
      voice.disabled = !filmed.checked;
      if (!filmed.checked) { voice.checked = false; }
    });
  }
  return {
    node: box,
    video: function () { return filmed.checked; },
    audio: function () { return Boolean(voice && filmed.checked && voice.checked); }
  };
}

export function welcomeView() {
  return panel(h("h1", { text: t("Welcome!") }),
    h("p", { class: "lead", text: t("Thank you for taking part. The session begins shortly.") }),
    h("p", { text: t("Please keep this page open; it shows you what to do next.") }));
}

/* Before the first interaction there is no "next" conversation yet. */
export function waitingView(s) {
  var lead = s.first ? t("The first conversation begins shortly.")
    : t("The next conversation begins shortly.");
  return panel(h("h1", { text: s.after ? t("Thank you!") : t("Please wait") }),
    h("p", { class: "lead", text: lead }),
    h("p", { text: t("Please keep this page open.") }));
}

/* The wizard paused the session: a calm page; nothing to do, nothing is lost. */
export function pausedView() {
  return panel(h("h1", { text: t("A short pause") }),
    h("p", { class: "lead", text: t("We will continue in a moment. Please stay here and keep this page open.") }),
    h("p", { text: t("Everything you have answered so far is saved.") }));
}

export function listenView(s) {
  return panel(h("div", { class: "listen-icon", "aria-hidden": "true" }),
    h("h1", { text: t("Listen to {robot}", { robot: s.robot_name }) }),
    h("p", { class: "lead", text: t("When it is time to rank the items, they will appear here.") }));
}

export function endedView(s) {
  if (s.declined) {
    return panel(h("h1", { text: t("Thank you!") }),
      h("p", { class: "lead", text: t("You have chosen not to take part, and nothing about you has been kept.") }),
      h("p", { text: t("Thank you for your time; please give the phone back to the experimenter.") }));
  }
  var section = panel(h("h1", { text: t("Thank you!") }),
    h("p", { class: "lead", text: t("This session has ended. Thank you for taking part!") }));
  if (s.debriefing) {
    section.appendChild(h("h2", { text: s.debriefing.title }));
    s.debriefing.paragraphs.forEach(function (text) { section.appendChild(h("p", { text: text })); });
  }
  section.appendChild(h("p", { text: t("You can give the phone back now.") }));
  return section;
}

/* The wizard disconnected this phone (the link is open on another one). The server's
 * sentence is English; the page shows its own, in the phone's language. */
export function sentAwayView() {
  return panel(h("h1", { text: t("This link is open on another phone") }),
    h("p", { class: "lead", text: t("Please continue on that phone, or ask the experimenter if this is the phone you should use.") }),
    h("p", { text: t("Your answers so far are saved.") }));
}
