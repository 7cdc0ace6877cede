/* A questionnaire page: its items (scales, differentials, choices, free text), answers kept
 * as a draft while typed, the required ones checked before sending. */

import { t } from "./context.js";
import { editing, h, panel, showError } from "./dom.js";
import { submit } from "./outbox.js";
import { load, store } from "./storage.js";

export function questionnaireView(s) {
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
