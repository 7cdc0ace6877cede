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
