// The console's modal dialogs: a confirmation, and the pause and end forms (a reason and a
// note). Each runs its action only when the wizard closes it with its own button.

const $ = (id) => document.getElementById(id);

const SWITCH = { title: "Switch condition?", ok: "Switch and log deviation" };

/** Ask ``text``; ``then()`` runs when the wizard confirms. ``title`` and ``ok`` (the
 * confirming button's words) default to the condition switch's. */
export function confirmDialog(text, then, { title = SWITCH.title, ok = SWITCH.ok } = {}) {
  const dialog = $("confirm-dialog");
  $("confirm-title").textContent = title;
  $("confirm-ok").textContent = ok;
  $("confirm-text").textContent = text;
  dialog.returnValue = "";
  dialog.onclose = () => {
    if (dialog.returnValue === "ok") then();
  };
  dialog.showModal();
  $("confirm-ok").focus();
}

/** The ``name`` form ("pause" or "end": #pause-dialog with #pause-reason and #pause-note,
 * closed with value "pause"): ``submit(reason, note)`` gets what the wizard chose. */
export function reasonDialog(name, submit) {
  const dialog = $(`${name}-dialog`);
  const note = $(`${name}-note`);
  note.value = "";
  dialog.returnValue = "";
  dialog.onclose = () => {
    if (dialog.returnValue === name) submit($(`${name}-reason`).value, note.value.trim());
  };
  dialog.showModal();
  $(`${name}-reason`).focus();
}
