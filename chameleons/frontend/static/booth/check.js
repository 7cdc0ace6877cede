// The booth check page: runs the check on the server (which stores it) and shows each step.

const root = document.getElementById("booth-check");
const body = document.querySelector("#check-steps tbody");
const summary = document.getElementById("check-summary");
const button = document.getElementById("run-check");
const HEAD_SECONDS = 12; // the turn, then the robot's copy of it after the copy delay

function row(step) {
  const tr = document.createElement("tr");
  tr.dataset.step = step.id;
  tr.dataset.status = step.status;
  for (const text of [step.label, step.status.toUpperCase(), step.value]) {
    const td = document.createElement("td");
    td.textContent = text;
    tr.append(td);
  }
  return tr;
}

async function run() {
  button.disabled = true;
  summary.textContent = `Turn your head to the left and back, then nod (${HEAD_SECONDS} s)…`;
  await new Promise((resolve) => setTimeout(resolve, HEAD_SECONDS * 1000 * Number(root.dataset.wait ?? 1)));
  const session = root.dataset.session ? `?session_id=${encodeURIComponent(root.dataset.session)}` : "";
  try {
    const response = await fetch(`/api/booths/${encodeURIComponent(root.dataset.booth)}/check${session}`, {
      method: "POST",
      headers: { "X-CSRF-Token": root.dataset.csrf, "Content-Type": "application/json" },
      body: "{}",
    });
    const result = await response.json();
    if (!response.ok) throw new Error(result.detail || `the server answered ${response.status}`);
    body.replaceChildren(...result.steps.map(row));
    summary.textContent = result.passed ? "Booth ready: every step passed." : "NOT READY: fix the failing steps and run the check again.";
    summary.dataset.passed = String(result.passed);
  } catch (error) {
    summary.textContent = `The check could not run: ${error.message}`;
  } finally {
    button.disabled = false;
  }
}

button.addEventListener("click", run);
