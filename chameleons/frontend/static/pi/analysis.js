// Parts of the analysis page that arrive after the first render, each a fragment of its own
// so one shows even when another cannot be computed: the effect sizes and models (about a
// second for a large study) and the synchrony of the faces (issue 32).
function loadFragment(holderId, statusId, what) {
  "use strict";
  const holder = document.getElementById(holderId);
  if (!holder) return;
  fetch(holder.dataset.src, { credentials: "same-origin", headers: { Accept: "text/html" } })
    .then(function (response) {
      if (!response.ok) throw new Error("HTTP " + response.status);
      return response.text();
    })
    .then(function (html) {
      holder.innerHTML = html;
      holder.dataset.loaded = "true";
    })
    .catch(function (error) {
      const status = document.getElementById(statusId);
      if (status) status.textContent = what + " could not be loaded (" + error.message + "): reload the page.";
      holder.dataset.loaded = "error";
    });
}
loadFragment("extended", "extended-status", "The effect sizes and models");
loadFragment("synchrony-section", "synchrony-status", "The synchrony of the faces");

// Copy the LaTeX table to the clipboard (falls back to selecting it for Ctrl-C).
(function () {
  "use strict";
  const button = document.getElementById("copy-latex");
  const latex = document.getElementById("latex");
  if (!button || !latex) return;
  button.addEventListener("click", async function () {
    try {
      await navigator.clipboard.writeText(latex.textContent);
      button.textContent = "Copied";
    } catch (_error) {
      const range = document.createRange();
      range.selectNodeContents(latex);
      const selection = window.getSelection();
      selection.removeAllRanges();
      selection.addRange(range);
      button.textContent = "Selected: press Ctrl-C";
    }
  });
})();
