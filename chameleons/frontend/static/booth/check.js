// The booth check page: runs the check on the server (which puts the robot in copy, stores
// the result) and, while the server measures, tells the technician what to do: turn the
// head left, then nod, then hold still while the robot copies; then shows each step.

const root = document.getElementById("booth-check");
const body = document.querySelector("#check-steps tbody");
const summary = document.getElementById("check-summary");
const checkedOn = document.getElementById("check-robot"); // "Checked on the Furhat"
const prompt = document.getElementById("check-prompt");
const button = document.getElementById("run-check");
const PROMPTS = JSON.parse(root.dataset.prompts || "[]"); // [{id, text, seconds}], the server's plan

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

function show(id, text) {
  prompt.hidden = false;
  prompt.dataset.phase = id;
  prompt.textContent = text;
}

// Shows each prompt for its time, in step with the server's own timing; stops as soon as
// the check has answered (e.g. at once when the booth has no worker).
async function guide(answered) {
  let done = false;
  const over = () => { done = true; };
  answered.then(over, over); // a refusal is shown by run(); here it only ends the prompts
  for (const step of PROMPTS) {
    if (done) return;
    show(step.id, step.text);
    await Promise.race([answered.catch(() => {}), new Promise((r) => setTimeout(r, step.seconds * 1000))]);
  }
  if (!done) show("speech", "Listen: the robot says a test prompt…");
}

async function post() {
  const query = new URLSearchParams();
  if (root.dataset.session) query.set("session_id", root.dataset.session);
  if (root.dataset.condition) query.set("condition", root.dataset.condition);
  const search = query.toString() ? `?${query}` : "";
  const response = await fetch(`/api/booths/${encodeURIComponent(root.dataset.booth)}/check${search}`, {
    method: "POST",
    headers: { "X-CSRF-Token": root.dataset.csrf, "Content-Type": "application/json" },
    body: "{}",
  });
  const result = await response.json();
  if (!response.ok) throw new Error(result.detail || `the server answered ${response.status}`);
  return result;
}

async function run() {
  button.disabled = true;
  summary.textContent = "Checking: follow the prompts.";
  delete summary.dataset.passed;
  checkedOn.textContent = "";
  const answered = post();
  const guided = guide(answered);
  try {
    const result = await answered;
    body.replaceChildren(...result.steps.map(row));
    const warned = result.steps.filter((step) => step.status === "warn").length;
    summary.textContent = !result.passed ? "NOT READY: fix the failing steps and run the check again."
      : warned ? `Booth ready, with ${warned === 1 ? "a warning" : `${warned} warnings`}: read the step${warned === 1 ? "" : "s"} marked WARN.`
      : "Booth ready: every step passed.";
    summary.dataset.passed = String(result.passed);
    checkedOn.textContent = result.checked_on ? `${result.checked_on}.` : "";
  } catch (error) {
    summary.textContent = `The check could not run: ${error.message}`;
  } finally {
    await guided;
    prompt.hidden = true;
    delete prompt.dataset.phase;
    button.disabled = false;
  }
}

button.addEventListener("click", run);
button.disabled = false; // the page comes with it disabled: a click before now did nothing
