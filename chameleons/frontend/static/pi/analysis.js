// The effect sizes and models arrive after the first render (they take about a second
// for a large study); then the LaTeX copy button.
(function () {
  "use strict";
  const holder = document.getElementById("extended");
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
      const status = document.getElementById("extended-status");
      if (status) status.textContent = "The effect sizes and models could not be loaded (" + error.message + "): reload the page.";
      holder.dataset.loaded = "error";
    });
})();

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

// The synchrony of the faces (issue 32): a fragment of its own, so it shows even when the
// effect sizes or models cannot be computed (and they when it cannot).
(function () {
  "use strict";
  const holder = document.getElementById("synchrony-section");
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
      const status = document.getElementById("synchrony-status");
      if (status) status.textContent = "The synchrony of the faces could not be loaded (" + error.message + "): reload the page.";
      holder.dataset.loaded = "error";
    });
})();
