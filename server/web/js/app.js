// The dashboard's shell: a hash router (#/studies, #/studies/ID, #/submit, #/diagnoses,
// #/diagnoses/ID, #/reports, #/reports/DATE, #/server), the navigation and the token dialog.
// Each page is a module with render(main, params, query) returning a cleanup function (which
// stops its polling); the router destroys the previous page's charts.
import { token } from "./api.js";
import { destroyCharts } from "./charts.js";
import { h, replace, errorBox } from "./dom.js";
import * as studies from "./pages/studies.js";
import * as study from "./pages/study.js";
import * as submit from "./pages/submit.js";
import * as diagnoses from "./pages/diagnoses.js";
import * as diagnosis from "./pages/diagnosis.js";
import * as reports from "./pages/reports.js";
import * as server from "./pages/server.js";

const routes = [
  [/^\/studies$/, studies, "studies"],
  [/^\/studies\/([^/]+)$/, study, "studies"],
  [/^\/submit$/, submit, "submit"],
  [/^\/diagnoses$/, diagnoses, "diagnoses"],
  [/^\/diagnoses\/([^/]+)$/, diagnosis, "diagnoses"],
  [/^\/reports$/, reports, "reports"],
  [/^\/reports\/([^/]+)$/, reports, "reports"],
  [/^\/server$/, server, "server"],
];

let cleanup = null;
let generation = 0;

function parseHash() {
  const raw = location.hash.replace(/^#/, "") || "/studies";
  const q = raw.indexOf("?");
  const path = q < 0 ? raw : raw.slice(0, q);
  const query = new URLSearchParams(q < 0 ? "" : raw.slice(q + 1));
  return { path, query };
}

async function route() {
  const { path, query } = parseHash();
  if (cleanup) {
    try {
      cleanup();
    } catch (_) {
      /* a page's cleanup never blocks navigation */
    }
    cleanup = null;
  }
  destroyCharts();
  const main = document.getElementById("main");
  const my = ++generation;
  document.body.dataset.page = "";
  for (const [re, page, section] of routes) {
    const m = path.match(re);
    if (!m) continue;
    for (const a of document.querySelectorAll("#nav a")) a.classList.toggle("active", a.dataset.section === section);
    replace(main);
    try {
      const params = m.slice(1).map(decodeURIComponent);
      const stop = await page.render(main, params, query, () => my === generation);
      if (my === generation) cleanup = stop || null;
      else if (stop) stop();
    } catch (err) {
      if (my === generation) main.appendChild(errorBox(err));
    }
    return;
  }
  replace(main, h("h1", null, "Not found"), h("p", null, "No page at ", h("code", null, path), ". ", h("a", { href: "#/studies" }, "Studies")));
}

function setupToken() {
  const dialog = document.getElementById("token-dialog");
  const input = document.getElementById("token-input");
  const state = document.getElementById("token-state");
  const show = () => {
    // Whether a token is set, never the token.
    state.textContent = token.isSet() ? "token set" : "no token";
  };
  document.getElementById("token-button").addEventListener("click", () => {
    input.value = "";
    dialog.showModal();
    input.focus();
  });
  document.getElementById("token-save").addEventListener("click", () => {
    token.set(input.value.trim());
    input.value = "";
    dialog.close();
  });
  document.getElementById("token-clear").addEventListener("click", () => {
    token.set("");
    input.value = "";
    dialog.close();
  });
  document.getElementById("token-cancel").addEventListener("click", () => {
    input.value = "";
    dialog.close();
  });
  input.addEventListener("keydown", (e) => {
    if (e.key === "Enter") document.getElementById("token-save").click();
  });
  window.addEventListener("stickslip-token", show);
  show();
}

/** Asks for the token (a write was refused with 401 or 403). */
export function askForToken() {
  document.getElementById("token-button").click();
}
window.stickslip = window.stickslip || {};
window.stickslip.askForToken = askForToken;

setupToken();
window.addEventListener("hashchange", route);
route();
