// The console's modal dialogs: a confirmation, and the pause and end forms (a reason and a
// note). Each runs its action only when the wizard closes it with its own button.

const $ = (id) => document.getElementById(id);

/** Ask ``text``; ``then()`` runs when the wizard confirms. */
export function confirmDialog(text, then) {
  const dialog = $("confirm-dialog");
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
