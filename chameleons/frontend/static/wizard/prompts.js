// The prompt buttons: sections by stage, items in the order shown, shortcuts, search, marks.

import { el, kbd } from "./dom.js";

const SECTION_HELP = {
  script: "letters",
  items: "1–9 describe · ⇧1–9 ask",
  replies: "letters",
  suggestions: "current suggestion: M , .",
};

export class PromptBoard {
  constructor(container, searchInput, searchCount, onPlay) {
    this.container = container;
    this.searchInput = searchInput;
    this.searchCount = searchCount;
    this.onPlay = onPlay;
    this.buttons = new Map(); // group -> [button elements] on the board
    this.extras = new Map(); // group -> [copies] outside the board (negotiation panel)
    this.byShortcut = new Map(); // "S:Digit1" -> group
    this.data = null;
    searchInput.addEventListener("input", () => this.filter());
  }

  render(data) {
    this.data = data;
    this.buttons.clear();
    this.byShortcut.clear();
    const sections = data.sections.map((section) => this.section(section));
    const warning = this.languageWarning(data);
    const notes = (data.warnings || []).map((text) => el("p", { class: "wz-language-warning wz-natural-warning", role: "note", text }));
    this.container.replaceChildren(...(warning ? [warning] : []), ...notes, ...sections);
    if (this.disabled) this.setDisabled(true);
    this.filter();
  }

  // The session's language: only its prompts are on the board; say which have no recording.
  languageWarning(data) {
    if (!data.missing || !data.missing.length) return null;
    const names = data.missing.slice(0, 12).join(", ") + (data.missing.length > 12 ? ", …" : "");
    return el("p", { class: "wz-language-warning", id: "prompt-language-warning", role: "note" },
      `${data.missing.length} prompt${data.missing.length === 1 ? "" : "s"} of this actor ` +
      `ha${data.missing.length === 1 ? "s" : "ve"} no recording in ${data.language}: ${names}. ` +
      "Do not word them yourself: real sessions in this language are refused until they are recorded.");
  }

  section(section) {
    const body =
      section.id === "items"
        ? this.itemRows(section.buttons)
        : section.id === "suggestions"
          ? this.suggestionRows(section.buttons)
          : el("div", { class: "pb-row" }, section.buttons.map((b) => this.button(b)));
    const title = el("h2", {}, section.title, " ", el("span", { class: "muted small", text: SECTION_HELP[section.id] || "" }));
    if (section.id === "suggestions") {
      return el("details", { class: "pb-section", "data-section": section.id }, el("summary", {}, title), body);
    }
    return el("section", { class: "pb-section", "data-section": section.id }, title, body);
  }

  itemRows(buttons) {
    const rows = new Map();
    for (const b of buttons) {
      if (!rows.has(b.item)) rows.set(b.item, { position: b.position, buttons: [] });
      rows.get(b.item).buttons.push(b);
    }
    return el(
      "div",
      { class: "pb-items" },
      [...rows.entries()].map(([item, row]) =>
        el(
          "div",
          { class: "pb-item", "data-item": item },
          el("span", { class: "pb-num", text: `#${row.position}` }),
          row.buttons.map((b) => this.button(b)),
        ),
      ),
    );
  }

  suggestionRows(buttons) {
    const rows = new Map();
    for (const b of buttons) {
      if (!rows.has(b.item)) rows.set(b.item, []);
      rows.get(b.item).push(b);
    }
    return el(
      "div",
      { class: "pb-items" },
      [...rows.values()].map((row) => el("div", { class: "pb-item" }, row.map((b) => this.button(b)))),
    );
  }

  button(b, shortcutOverride) {
    const shortcut = shortcutOverride === undefined ? b.shortcut : shortcutOverride;
    const title = b.variants.map((text, i) => `${i + 1}. ${text}`).join("\n");
    const node = el(
      "button",
      {
        type: "button",
        class: "pb",
        title,
        dataset: { group: b.group, stage: b.stage, search: `${b.label} ${b.variants.join(" ")}`.toLowerCase() },
        onclick: () => this.onPlay(b.group),
      },
      kbd(shortcut && shortcut.label),
      el("span", { class: "pb-label", text: b.label }),
      b.variants.length > 1 ? el("span", { class: "pb-meta", text: `×${b.variants.length}` }) : null,
      b.has_audio ? null : el("span", { class: "pb-meta", title: "No recording yet: text only", text: "txt" }),
      el("span", { class: "pb-played", "aria-hidden": "true" }),
    );
    const registry = shortcutOverride === undefined ? this.buttons : this.extras;
    if (!registry.has(b.group)) registry.set(b.group, []);
    registry.get(b.group).push(node);
    if (shortcut && shortcutOverride === undefined) {
      this.byShortcut.set(`${shortcut.shift ? "S:" : ""}${shortcut.code}`, b.group);
    }
    return node;
  }

  resetExtras() {
    this.extras.clear();
  }

  /** Prompt buttons off (the session is over: the robot has nothing more to say). */
  setDisabled(disabled) {
    this.disabled = disabled;
    for (const [, node] of this.all()) node.disabled = disabled;
  }

  *all() {
    for (const registry of [this.buttons, this.extras]) {
      for (const [group, nodes] of registry) for (const node of nodes) yield [group, node];
    }
  }

  find(group) {
    for (const section of this.data?.sections || []) {
      const found = section.buttons.find((b) => b.group === group);
      if (found) return found;
    }
    return null;
  }

  groupForKey(code, shift) {
    return this.byShortcut.get(`${shift ? "S:" : ""}${code}`) || null;
  }

  /** ✓ (✓n) on a prompt the participant heard; "not voiced" on one whose every play went
   * unheard, with why in its tooltip and its accessible name. */
  markPlayed(tally) {
    for (const [group, node] of this.all()) {
      const { voiced = 0, silent = 0, reason = null } = tally.get(group) || {};
      const unheard = voiced === 0 && silent > 0;
      node.classList.toggle("played", voiced > 0);
      node.classList.toggle("not-voiced", unheard);
      const mark = node.querySelector(".pb-played");
      mark.textContent = voiced > 1 ? `✓${voiced}` : voiced ? "✓" : unheard ? "✗ not voiced" : "";
      mark.title = unheard ? `Not voiced: ${reason}` : "";
      if (unheard) node.setAttribute("aria-description", `not voiced: ${reason}`);
      else node.removeAttribute("aria-description");
    }
  }

  highlight(groups) {
    const wanted = new Set(groups);
    for (const [group, node] of this.all()) node.classList.toggle("suggested", wanted.has(group));
  }

  markPlaying(group) {
    for (const [name, node] of this.all()) node.classList.toggle("playing", name === group);
  }

  filter() {
    const words = this.searchInput.value.toLowerCase().split(/\s+/).filter(Boolean);
    let shown = 0;
    for (const node of this.container.querySelectorAll("button.pb")) {
      const match = words.every((word) => node.dataset.search.includes(word));
      node.hidden = !match;
      if (match) shown += 1;
    }
    for (const row of this.container.querySelectorAll(".pb-item, .pb-section")) {
      row.hidden = words.length > 0 && !row.querySelector("button.pb:not([hidden])");
    }
    for (const details of this.container.querySelectorAll("details.pb-section")) {
      if (words.length) details.open = true;
    }
    this.searchCount.textContent = words.length ? `${shown} match${shown === 1 ? "" : "es"}` : "";
  }

  firstVisible() {
    const node = this.container.querySelector("button.pb:not([hidden])");
    return node ? node.dataset.group : null;
  }
}
