// Keyboard shortcuts. Letters and digits are matched by KeyboardEvent.code, so Shift+1 is
// "Digit1 with Shift" whatever character the layout types.

const TYPING = new Set(["INPUT", "TEXTAREA", "SELECT"]);
const FIXED = {
  KeyA: "accept",
  KeyD: "decline",
  KeyU: "undo",
  Slash: "search",
};
const SUGGESTION_CODES = ["KeyM", "Comma", "Period"];

export function bindKeys(handlers) {
  document.addEventListener("keydown", (event) => {
    if (document.querySelector("dialog[open]")) return;
    const target = event.target;
    if (TYPING.has(target.tagName)) {
      // Escape leaves any field and stops the robot from there too; Space types a space.
      if (event.key === "Escape") handlers.stopIfSpeaking();
      if (target.id === "prompt-search") searchKeys(event, handlers);
      else if (event.key === "Escape") target.blur();
      return;
    }
    if (event.altKey || event.metaKey) return;
    if (event.ctrlKey) {
      if (event.key === "Enter") {
        event.preventDefault();
        handlers.primary();
      }
      return;
    }
    if (event.code === "Space" || event.key === "Escape") {
      event.preventDefault();
      handlers.stop();
      return;
    }
    if (event.key === "?") {
      event.preventDefault();
      handlers.help();
      return;
    }
    if (event.repeat) return;
    const fixed = !event.shiftKey && FIXED[event.code];
    if (fixed) {
      event.preventDefault();
      handlers[fixed]();
      return;
    }
    if (event.shiftKey && event.code === "KeyN") {
      event.preventDefault();
      handlers.note();
      return;
    }
    if (event.shiftKey && event.code === "KeyT") {
      event.preventDefault();
      handlers.say();
      return;
    }
    const suggestion = SUGGESTION_CODES.indexOf(event.code);
    if (suggestion >= 0 && !event.shiftKey) {
      event.preventDefault();
      handlers.suggestion(suggestion);
      return;
    }
    if (handlers.play(event.code, event.shiftKey)) event.preventDefault();
  });
}

function searchKeys(event, handlers) {
  if (event.key === "Enter") {
    event.preventDefault();
    handlers.playFirstMatch();
  } else if (event.key === "Escape") {
    event.preventDefault();
    event.target.value = "";
    event.target.dispatchEvent(new Event("input"));
    event.target.blur();
  }
}
