/* The participant's phone. State comes from the server (page, WebSocket, answers to
 * submissions); answers typed but not yet sent live in localStorage, and every submission
 * waits in a local outbox, with its own id, until the server has stored it. */
(function () {
  "use strict";

  var app = document.getElementById("app");
  var token = app.dataset.token;
  var api = "/api/phone/" + encodeURIComponent(token);
  var connection = document.getElementById("connection");
  var saveStatus = document.getElementById("save-status");
  var errorBox = document.getElementById("error");
  var announcer = document.getElementById("announce");
  var state = JSON.parse(document.getElementById("initial-state").textContent);
  var renderedKey = null;
  var shownRanking = null;
  // The participant's language: the server sends this script's strings translated
  // (message id -> text); a string without a translation shows in English.
  var messages = JSON.parse(document.getElementById("messages").textContent || "{}");
  function t(message, params) {
    var text = Object.prototype.hasOwnProperty.call(messages, message) ? messages[message] : message;
    return text.replace(/\{(\w+)\}/g, function (whole, name) {
      return params && Object.prototype.hasOwnProperty.call(params, name) ? String(params[name]) : whole;
    });
  }

  // The page's language (the session's) asks the server for its refusals in it too.
  function postHeaders() {
    return { "Content-Type": "application/json", "Accept-Language": document.documentElement.lang || "en" };
  }

  /* ---------- local storage: drafts and the outbox (tolerates private mode) ---------- */
  function key(name) { return "mc:" + token + ":" + name; }
  function load(name, fallback) {
    try {
      var text = localStorage.getItem(key(name));
      return text === null ? fallback : JSON.parse(text);
    } catch (e) { return fallback; }
  }
  function store(name, value) {
    try { localStorage.setItem(key(name), JSON.stringify(value)); } catch (e) { /* full */ }
  }
  function forget(name) {
    try { localStorage.removeItem(key(name)); } catch (e) { /* unavailable */ }
  }
  function forgetAll() {
    try {
      Object.keys(localStorage).forEach(function (k) {
        if (k.indexOf("mc:" + token + ":") === 0) { localStorage.removeItem(k); }
      });
    } catch (e) { /* unavailable */ }
  }
  function newClientId() {
    var bytes = new Uint8Array(16);
    crypto.getRandomValues(bytes); // works without https, unlike crypto.randomUUID
    return Array.prototype.map.call(bytes, function (b) {
      return ("0" + b.toString(16)).slice(-2);
    }).join("");
  }

  /* ---------- small DOM helpers (text only: never innerHTML) ---------- */
  function h(tag, attrs) {
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
  function announce(text) { announcer.textContent = ""; announcer.textContent = text; }
  function showError(text) { errorBox.textContent = text; errorBox.hidden = !text; }
  /* "Saved" names what was saved (the consent, the ranking, the answers): on the next
   * page, a bare "Saved ✓" read as if that page, empty as it was, were saved already. It goes
   * as soon as the participant changes something there. */
  function savedText(what) {
    if (what === "consent") { return t("Consent saved ✓"); }
    if (what === "ranking") { return t("Ranking saved ✓"); }
    return t("Answers saved ✓");
  }
  function setSave(kind, what) {
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
  function editing() {
    if (saveStatus.dataset.state === "saved") { setSave(""); }
  }
  function setConnection(kind) {
    var texts = { connecting: t("Connecting…"), online: t("Connected"), offline: t("Reconnecting…"), ended: "" };
    connection.textContent = texts[kind];
    connection.dataset.state = kind;
  }

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
      if (next.view === "ranked") { updateRanked(next.ranking); }
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

  function panel() {
    var section = h("section", { class: "panel" });
    for (var i = 0; i < arguments.length; i++) { if (arguments[i]) { section.appendChild(arguments[i]); } }
    return section;
  }

  /* The study's languages, offered before consent; the page reloads in the one chosen
   * (its texts and this script's strings come from the server in that language). */
  function languageChooser(s) {
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

  function consentView(s) {
    var c = s.consent;
    var section = panel(h("h1", { text: c.title }));
    c.paragraphs.forEach(function (text) { section.appendChild(h("p", { text: text })); });
    var agree = h("button", { type: "button", class: "big primary", id: "consent-agree", text: c.agree });
    var decline = h("button", { type: "button", class: "big", id: "consent-decline", text: c.decline });
    agree.addEventListener("click", function () { submit("consent", { position: 0, agree: true }); });
    decline.addEventListener("click", function () { submit("consent", { position: 0, agree: false }); });
    section.appendChild(h("div", { class: "consent-actions" }, agree, decline));
    return section;
  }

  function welcomeView() {
    return panel(h("h1", { text: t("Welcome!") }),
      h("p", { class: "lead", text: t("Thank you for taking part. The session begins shortly.") }),
      h("p", { text: t("Please keep this page open; it shows you what to do next.") }));
  }

  /* Before the first interaction there is no "next" conversation yet. */
  function waitingView(s) {
    var lead = s.first ? t("The first conversation begins shortly.")
      : t("The next conversation begins shortly.");
    return panel(h("h1", { text: s.after ? t("Thank you!") : t("Please wait") }),
      h("p", { class: "lead", text: lead }),
      h("p", { text: t("Please keep this page open.") }));
  }

  /* The wizard paused the session: a calm page; nothing to do, nothing is lost. */
  function pausedView() {
    return panel(h("h1", { text: t("A short pause") }),
      h("p", { class: "lead", text: t("We will continue in a moment. Please stay here and keep this page open.") }),
      h("p", { text: t("Everything you have answered so far is saved.") }));
  }

  function listenView(s) {
    return panel(h("div", { class: "listen-icon", "aria-hidden": "true" }),
      h("h1", { text: t("Listen to {robot}", { robot: s.robot_name }) }),
      h("p", { class: "lead", text: t("When it is time to rank the items, they will appear here.") }));
  }

  function nameOf(s, id) {
    var found = s.items.filter(function (item) { return item.id === id; })[0];
    return found ? found.name : id;
  }

  function rankingView(s) {
    var draftName = "draft:rank:" + s.position;
    var presented = s.items.map(function (item) { return item.id; });
    var draft = load(draftName, null);
    var order = isPermutation(draft, presented) ? draft : presented;
    var list = h("ol", { class: "rank-list", id: "ranking-list", "aria-label": t("Your ranking") });
    order.forEach(function (id) { list.appendChild(rankItem(s, id, list, draftName)); });
    renumber(list);
    if (window.Sortable) {
      window.Sortable.create(list, {
        animation: 150, handle: ".handle", ghostClass: "dragging",
        onEnd: function () { renumber(list); store(draftName, currentOrder(list)); editing(); }
      });
    }
    var button = h("button", {
      type: "button", class: "big primary", id: "submit-ranking", text: t("Submit my ranking"),
      onclick: function () {
        submit("ranking", { position: s.position, ranking: currentOrder(list) }, draftName);
      }
    });
    return panel(h("h1", { text: t("Rank the items") }),
      h("p", { class: "muted", text: t("{task}: {introduction}", { task: s.task_name, introduction: s.introduction }) }),
      h("p", { text: t("Number 1 is the most important. Drag an item by its handle, or use the arrow buttons.") }),
      list, button);
  }

  function isPermutation(candidate, items) {
    return Array.isArray(candidate) && candidate.length === items.length &&
      candidate.slice().sort().join("\u0000") === items.slice().sort().join("\u0000");
  }

  function rankItem(s, id, list, draftName) {
    var name = nameOf(s, id);
    function moveBy(step) {
      return function () {
        var item = list.querySelector('[data-id="' + CSS.escape(id) + '"]');
        var target = step < 0 ? item.previousElementSibling : item.nextElementSibling;
        if (!target) { return; }
        list.insertBefore(item, step < 0 ? target : target.nextElementSibling);
        renumber(list);
        store(draftName, currentOrder(list));
        editing();
        var rank = currentOrder(list).indexOf(id) + 1;
        announce(t("{item} is now number {rank}.", { item: name, rank: rank }));
        item.querySelector(step < 0 ? ".up" : ".down").focus();
      };
    }
    return h("li", { class: "rank-item", "data-id": id },
      h("span", { class: "handle", "aria-hidden": "true", text: "⠿" }),
      h("span", { class: "rank" }),
      h("span", { class: "name", text: name }),
      h("button", { type: "button", class: "move up", "aria-label": t("Move {item} up", { item: name }), text: "▲", onclick: moveBy(-1) }),
      h("button", { type: "button", class: "move down", "aria-label": t("Move {item} down", { item: name }), text: "▼", onclick: moveBy(1) }));
  }

  function renumber(list) {
    Array.prototype.forEach.call(list.children, function (item, index) {
      item.querySelector(".rank").textContent = String(index + 1);
      var up = item.querySelector(".up");
      var down = item.querySelector(".down");
      if (up) { up.disabled = index === 0; }
      if (down) { down.disabled = index === list.children.length - 1; }
    });
  }

  function currentOrder(list) {
    return Array.prototype.map.call(list.children, function (item) { return item.dataset.id; });
  }

  function rankedView(s) {
    shownRanking = null;
    var list = h("ol", { class: "rank-list readonly", id: "current-ranking", "aria-label": t("Your current ranking") });
    var section = panel(h("h1", { text: t("Your ranking") }),
      h("p", { class: "lead", text: t("Listen to {robot}.", { robot: s.robot_name }) }),
      h("p", { class: "muted", text: t("If you change your ranking together, this list changes too.") }),
      list);
    fillRanked(list, s.ranking, []);
    shownRanking = s.ranking.slice();
    return section;
  }

  function fillRanked(list, ranking, moved) {
    list.replaceChildren.apply(list, ranking.map(function (id, index) {
      return h("li", { class: "rank-item" + (moved.indexOf(id) >= 0 ? " moved" : ""), "data-id": id },
        h("span", { class: "rank", text: String(index + 1) }),
        h("span", { class: "name", text: nameOf(state, id) }));
    }));
  }

  function updateRanked(ranking) {
    var list = document.getElementById("current-ranking");
    if (!list || !shownRanking || shownRanking.join("|") === ranking.join("|")) { return; }
    var before = shownRanking;
    var moved = ranking.filter(function (id, index) { return before[index] !== id; });
    fillRanked(list, ranking, moved);
    shownRanking = ranking.slice();
    var leader = moved.filter(function (id) { return ranking.indexOf(id) < before.indexOf(id); })[0];
    if (leader) { announce(t("Updated: {item} is now number {rank}.", { item: nameOf(state, leader), rank: ranking.indexOf(leader) + 1 })); }
  }

  function questionnaireView(s) {
    var q = s.questionnaire;
    var draftName = "draft:q:" + s.position + ":" + q.id;
    var draft = load(draftName, {});
    var form = h("form", { class: "questionnaire", novalidate: true, id: "questionnaire" });
    var counter = h("p", { class: "answered", "aria-live": "polite" });
    q.items.forEach(function (item, index) {
      form.appendChild(questionField(q, item, index + 1, draft[item.id], function (value) {
        var current = load(draftName, {});
        current[item.id] = value;
        store(draftName, current);
        editing();
        countAnswered(form, q, counter);
      }));
    });
    form.appendChild(h("button", { type: "submit", class: "big primary", text: s.page < s.pages ? t("Save and continue") : t("Save") }));
    form.addEventListener("submit", function (event) {
      event.preventDefault();
      var answers = collect(form, q);
      var missing = q.items.map(function (item, i) {
        return item.required !== false && answers[item.id] === undefined ? i + 1 : 0;
      }).filter(Boolean);
      if (missing.length) {
        showError(t("Please answer question {number}.", { number: missing[0] }));
        var field = form.querySelector('[data-number="' + missing[0] + '"]');
        field.classList.add("invalid");
        field.scrollIntoView({ block: "center" });
        return;
      }
      submit("questionnaire", { position: s.position, questionnaire: q.id, answers: answers }, draftName);
    });
    countAnswered(form, q, counter);
    var title = s.before ? q.title : s.final ? t("Final questions") : t("Questions about {robot}", { robot: s.robot_name });
    return panel(
      h("p", { class: "progress-label", text: t("Part {page} of {pages}", { page: s.page, pages: s.pages }) }),
      h("progress", { value: s.page - 1, max: s.pages, "aria-label": t("Progress") }),
      h("h1", { text: title }), counter, form);
  }

  function questionField(q, item, number, saved, onChange) {
    var field = h("fieldset", { class: "question " + item.type, "data-number": number, "data-item": item.id });
    var optional = item.required === false ? h("span", { class: "optional", text: " " + t("(optional)") }) : null;
    if (item.type === "text") {
      var area = h("textarea", { name: item.id, rows: "4", id: "answer-" + item.id });
      area.value = typeof saved === "string" ? saved : "";
      area.addEventListener("input", function () { onChange(area.value); field.classList.remove("invalid"); });
      field.appendChild(h("legend", { text: number + ". " + item.text }, optional));
      field.appendChild(area);
      return field;
    }
    if (item.options && item.options.length) {
      field.appendChild(h("legend", { text: number + ". " + item.text }, optional));
      var list = h("div", { class: "choices" });
      item.options.forEach(function (option) {
        var choice = h("input", { type: "radio", name: item.id, value: String(option.id), checked: saved === option.id });
        choice.addEventListener("change", function () { onChange(option.id); field.classList.remove("invalid"); });
        list.appendChild(h("label", { class: "choice" }, choice, h("span", { text: option.label })));
      });
      field.appendChild(list);
      return field;
    }
    var legend = item.type === "differential"
      ? number + ". " + item.left + " – " + item.right
      : number + ". " + item.text;
    field.appendChild(h("legend", { text: legend }, optional));
    var scale = h("div", { class: "scale" });
    for (var value = 1; value <= q.points; value++) {
      var input = h("input", { type: "radio", name: item.id, value: String(value), checked: saved === value });
      input.addEventListener("change", function (event) {
        onChange(Number(event.target.value));
        field.classList.remove("invalid");
      });
      scale.appendChild(h("label", { class: "point" }, input, h("span", { text: String(value) })));
    }
    field.appendChild(scale);
    var low = item.type === "differential" ? item.left : q.low;
    var high = item.type === "differential" ? item.right : q.high;
    if (low || high) {
      field.appendChild(h("div", { class: "anchors", "aria-hidden": "true" },
        h("span", { text: low }), h("span", { text: high })));
    }
    return field;
  }

  function collect(form, q) {
    var answers = {};
    q.items.forEach(function (item) {
      if (item.type === "text") {
        var text = form.querySelector('textarea[name="' + CSS.escape(item.id) + '"]').value.trim();
        if (text) { answers[item.id] = text; }
      } else {
        var checked = form.querySelector('input[name="' + CSS.escape(item.id) + '"]:checked');
        if (checked && item.options && item.options.length) {
          // the option's own id: text for a choice, the robot's number for a robot item
          var picked = item.options.filter(function (o) { return String(o.id) === checked.value; })[0];
          if (picked) { answers[item.id] = picked.id; }
        } else if (checked) { answers[item.id] = Number(checked.value); }
      }
    });
    return answers;
  }

  function countAnswered(form, q, counter) {
    var done = Object.keys(collect(form, q)).length;
    counter.textContent = t("{done} of {total} answered", { done: done, total: q.items.length });
  }

  function endedView(s) {
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

  /* ---------- submissions: outbox first, then the server; shown as saved only once stored ---------- */
  var flushing = false;
  var retryTimer = null;
  var retryDelay = 1000;

  function submit(kind, body, draftName) {
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

  function messageOf(data) {
    return typeof data.detail === "string" ? data.detail : t("Your answer could not be read. Please check it and try again.");
  }

  function flush() {
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
          render(data.state);
        } else if (response.status === 410) {
          render({ view: "ended" });
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
      if (fresh && fresh.view === "paused") { render(fresh); setSave("held"); return; }
      dropFromOutbox(entry.body.client_id);
      setSave("");
      if (fresh) { render(fresh); } else { refresh(); }
      showError(messageOf(data));
    });
  }

  function refresh() {
    fetch(api + "/state").then(function (response) {
      if (response.status === 410) { render({ view: "ended" }); return null; }
      return response.ok ? response.json() : null;
    }).then(function (fresh) { if (fresh) { render(fresh); } }, function () { /* the socket retries */ });
  }

  /* ---------- the live connection: reconnects by itself with backoff ---------- */
  var socket = null;
  var attempts = 0;
  var lastHeard = Date.now();
  // This phone's name for the server: the wizard sees two phones on one link as two.
  var device = load("device", null) || newClientId();
  store("device", device);

  /* The wizard disconnected this phone: the link is open on another one. Nothing more is
   * sent from here (answers wait in the outbox), and it does not reconnect by itself.
   * The server's sentence is English; the page shows its own, in the phone's language. */
  function sentAway() {
    state = { view: "sent_away" };
    renderedKey = "sent_away";
    app.replaceChildren(panel(h("h1", { text: t("This link is open on another phone") }),
      h("p", { class: "lead", text: t("Please continue on that phone, or ask the experimenter if this is the phone you should use.") }),
      h("p", { text: t("Your answers so far are saved.") })));
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
}());
