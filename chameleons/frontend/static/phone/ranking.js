/* The ranking: the participant's own (drag or arrow buttons, kept as a draft until sent)
 * and, once sent, the current ranking, which changes when the pair changes it together. */

import { t } from "./context.js";
import { announce, editing, h, panel } from "./dom.js";
import { submit } from "./outbox.js";
import { load, store } from "./storage.js";

var shownRanking = null;

function nameOf(s, id) {
  var found = s.items.filter(function (item) { return item.id === id; })[0];
  return found ? found.name : id;
}

export function rankingView(s) {
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

export function rankedView(s) {
  shownRanking = null;
  var list = h("ol", { class: "rank-list readonly", id: "current-ranking", "aria-label": t("Your current ranking") });
  var section = panel(h("h1", { text: t("Your ranking") }),
    h("p", { class: "lead", text: t("Listen to {robot}.", { robot: s.robot_name }) }),
    h("p", { class: "muted", text: t("If you change your ranking together, this list changes too.") }),
    list);
  fillRanked(s, list, s.ranking, []);
  shownRanking = s.ranking.slice();
  return section;
}

function fillRanked(s, list, ranking, moved) {
  list.replaceChildren.apply(list, ranking.map(function (id, index) {
    return h("li", { class: "rank-item" + (moved.indexOf(id) >= 0 ? " moved" : ""), "data-id": id },
      h("span", { class: "rank", text: String(index + 1) }),
      h("span", { class: "name", text: nameOf(s, id) }));
  }));
}

/* The ranked view is shown already: the items that moved are marked, the one that rose
 * announced. */
export function updateRanked(s) {
  var ranking = s.ranking;
  var list = document.getElementById("current-ranking");
  if (!list || !shownRanking || shownRanking.join("|") === ranking.join("|")) { return; }
  var before = shownRanking;
  var moved = ranking.filter(function (id, index) { return before[index] !== id; });
  fillRanked(s, list, ranking, moved);
  shownRanking = ranking.slice();
  var leader = moved.filter(function (id) { return ranking.indexOf(id) < before.indexOf(id); })[0];
  if (leader) { announce(t("Updated: {item} is now number {rank}.", { item: nameOf(s, leader), rank: ranking.indexOf(leader) + 1 })); }
}
