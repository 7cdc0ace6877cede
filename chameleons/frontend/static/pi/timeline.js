// The PI's session timeline in the console's sentences (describe() of the wizard console),
// filterable like the console's; the raw kind and payload stay in each row's <details>.

import { bindFilter, category, describe } from "../wizard/timeline.js";

const list = document.getElementById("timeline");
if (list) {
  const names = new Map(Object.entries(JSON.parse(list.dataset.names || "{}")));
  for (const row of list.querySelectorAll("li[data-kind]")) {
    const event = { kind: row.dataset.kind, source: row.dataset.source,
                    payload: JSON.parse(row.dataset.payload || "{}") };
    row.dataset.category = category(event.kind, event.source);
    row.querySelector(".tl-text").textContent = describe(event, names);
  }
  const filter = document.getElementById("timeline-filter");
  if (filter) bindFilter(filter, list);
}
