// drive-rig's view: three tabs (Live, Runs, Studies) over the server's read-only API.

import { getJSON } from "./charts.js";
import { startLive } from "./live.js";
import { loadRuns } from "./runs.js";
import { loadStudies } from "./studies.js";

function show(tab) {
  for (const section of document.querySelectorAll("section.tab")) section.hidden = section.id !== tab;
  for (const b of document.querySelectorAll("nav button")) b.classList.toggle("active", b.dataset.tab === tab);
  if (location.hash !== `#${tab}`) history.replaceState(null, "", `#${tab}`);
  window.dispatchEvent(new Event("resize"));
}

async function main() {
  const info = await getJSON("/api/info");
  for (const b of document.querySelectorAll("nav button")) b.addEventListener("click", () => show(b.dataset.tab));
  const first = location.hash.slice(1) || (info.live ? "live" : "runs");
  show(["live", "runs", "studies"].includes(first) ? first : "runs");
  startLive(info);
  const runs = await loadRuns();
  await loadStudies(runs);
  document.body.dataset.ready = "1";
}

main().catch((err) => {
  document.body.dataset.ready = "error";
  document.querySelector("main").prepend(Object.assign(document.createElement("p"),
    { className: "error", textContent: `the view could not start: ${err.message || err}` }));
});
