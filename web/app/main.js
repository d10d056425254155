// The map page (/app): load a seed file, choose the owner field and the grid, run the job
// asynchronously with its progress, then see the owners' sea, the seeds, the lines and the
// tripoints on one map with a legend (each owner's label, colour and areas), a scale bar, a
// click read-out of any cell's owner and distance, and every result to download.
//
// Every request goes through the same JSON API as any client's, with the person's token
// (client.js). Text from uploads and from the server only ever reaches the page as text.

import "ol/ol.css";
import "./app.css";
import { el, table, sessionBar, headers, Problem, getJson, problemView, humanBytes, download, saveBlob } from "../client.js";
import { ACCEPT, seedInput, describeSeeds, postJson } from "./upload.js";
import { jobFields, readForm, niceNumber, seaChoice } from "./form.js";
import { MapView, projectionFor } from "./map.js";
import { EditMode } from "./edit.js";

const panel = document.getElementById("panel");
const cellBox = document.getElementById("cell");
const view = new MapView("map");
// The map for scripts on this page's element (the browser tests find a feature's pixel with it).
document.getElementById("map").rvoronoiView = view;
const state = { process: null, file: null, seeds: null, inventory: null, job: null, report: null, pollTimer: 0 };

function setState(s) {
  document.body.dataset.state = s;
}

// ---- Problems in plain words ----------------------------------------------------------------

const ADVICE = {
  400: "The server could not use this request.",
  401: "This server asks for an access token.",
  403: "This token may not do that.",
  409: "The job was cancelled or changed meanwhile.",
  413: "The file is larger than this server accepts in one request.",
  429: "That is over your allowance on this server (jobs at once, or grid cells per hour): the message says when to try again.",
  503: "The server is busy: try again in a moment.",
};

const TOO_LARGE = "That is more than this server takes at once: for a grid, a larger cell size or a smaller extent makes fewer cells.";

function problemBox(e) {
  const p = e instanceof Problem ? e : new Problem(0, { title: "Something went wrong", detail: String((e && e.message) || e) });
  const box = problemView(p, () => location.reload());
  // By the problem's type where it tells more than the status (a job that failed on a limit
  // answers 422 with the type too-large).
  const type = String((p.body && p.body.type) || "");
  const advice = type.endsWith("/too-large") ? TOO_LARGE : ADVICE[p.status];
  if (advice) box.insertBefore(el("p", { class: "advice", text: advice }), box.children[1] || null);
  return box;
}

function showProblem(where, e) {
  where.replaceChildren(problemBox(e));
}

// ---- The seed file ----------------------------------------------------------------------------

const sections = {
  seeds: el("section", { "aria-labelledby": "h-seeds" }),
  job: el("section", { "aria-labelledby": "h-job", hidden: "" }),
  progress: el("section", { "aria-labelledby": "h-progress", hidden: "" }),
  result: el("section", { "aria-labelledby": "h-result", hidden: "" }),
  edit: el("section", { "aria-labelledby": "h-edit", hidden: "" }),
};

function seedPicker() {
  const input = el("input", { id: "seed-file", type: "file", accept: ACCEPT });
  input.addEventListener("change", () => input.files[0] && loadFile(input.files[0]));
  const zone = el("div", { class: "drop", id: "drop" },
    el("label", { for: "seed-file", text: "Seed file: GeoJSON, GeoPackage, zipped Shapefile or FlatGeobuf" }),
    input,
    el("p", { class: "muted", text: "…or drop it here." }));
  zone.addEventListener("dragover", (ev) => { ev.preventDefault(); zone.classList.add("over"); });
  zone.addEventListener("dragleave", () => zone.classList.remove("over"));
  zone.addEventListener("drop", (ev) => {
    ev.preventDefault();
    zone.classList.remove("over");
    if (ev.dataTransfer.files[0]) loadFile(ev.dataTransfer.files[0]);
  });
  return zone;
}

// The seed file's description with what the form needs of it.
function inventoryOf(d) {
  const first = (d.layers && d.layers[0]) || { fields: [] };
  const common = new Set(d.commonFields || []);
  const fields = first.fields.filter((f) => common.has(f.name));
  const featureCount = (d.layers || []).reduce((n, l) => n + l.features, 0);
  const numeric = (f) => ["integer", "integer64", "real"].includes(f.type);
  // A guess at the owner field: a text field of a few values, by its name, else one that
  // groups features (fewer values than features).
  const candidates = fields.filter((f) => f.distinctExact && f.distinct >= 2 && f.distinct <= 500 && !numeric(f));
  const named = candidates.find((f) => /owner|state|country|iso|sovereign|nation|admin|party/i.test(f.name));
  const plausible = candidates.filter((f) => f.distinct < featureCount);
  return {
    ...d,
    featureCount,
    fieldsFor: (wantNumeric) => fields.filter((f) => !wantNumeric || numeric(f)),
    ownerGuess: (named || plausible[0] || {}).name || "",
  };
}

function seedSummary(file, inv) {
  const layers = table(["Layer", "Features", "Geometry"],
    (inv.layers || []).map((l) => [l.name, String(l.features), l.geometryTypes.join(", ")]),
    "CRS: " + (inv.crs.name || "none") + (inv.crs.code ? " (" + inv.crs.code + ")" : ""));
  layers.classList.add("layers");
  const parts = [
    el("p", { class: "file" }, el("strong", { text: file.name }), " · " + humanBytes(file.size) + " · " + inv.featureCount + " features"),
    layers,
  ];
  for (const w of inv.warnings || []) parts.push(el("p", { class: "warning", text: w }));
  return parts;
}

async function loadFile(file) {
  const status = el("p", { class: "muted", text: "Reading " + file.name + "…" });
  sections.seeds.replaceChildren(el("h2", { id: "h-seeds", text: "1 · Seeds" }), seedPicker(), status);
  sections.job.hidden = true;
  sections.progress.hidden = true;
  sections.result.hidden = true;
  setState("describing");
  try {
    state.file = file;
    state.seeds = await seedInput(file);
    state.inventory = inventoryOf(await describeSeeds(state.seeds, ""));
    status.replaceWith(...seedSummary(file, state.inventory));
    const inv = state.inventory;
    view.frame(projectionFor(inv.crs, inv.bbox), inv.bbox);
    view.showSeeds(inv.features, () => null);
    for (const name of ["owners", "boundaries", "tripoints", "limits"]) view.setLayer(name, null);
    buildForm();
    setState("described");
  } catch (e) {
    status.replaceWith(problemBox(e));
    setState("failed");
  }
}

// ---- The job --------------------------------------------------------------------------------------

function buildForm() {
  const inv = state.inventory;
  const form = el("form", { id: "job-form", novalidate: "" }, ...jobFields(state.process, inv),
    el("button", { type: "submit", class: "run", text: "Compute" }));
  sections.job.replaceChildren(el("h2", { id: "h-job", text: "2 · Grid and options" }), form);
  sections.job.hidden = false;
  if (inv.bbox) {
    const [x0, y0, x1, y1] = inv.bbox;
    const span = Math.max(x1 - x0, y1 - y0);
    // About 600 cells across the data (a single point gives no span: no proposal).
    if (span > 0) form.querySelector("#in-resolution").value = String(niceNumber(span / 600));
    inv.bbox.forEach((v, i) => { form.querySelector("#in-extent-" + i).placeholder = String(+v.toPrecision(8)); });
  }
  form.addEventListener("submit", (ev) => {
    ev.preventDefault();
    runJob(form);
  });
}

async function runJob(form) {
  clearTimeout(state.pollTimer);
  const { inputs, outputs } = readForm(form, state.process);
  const sea = seaChoice(form);
  state.request = { inputs, outputs };
  if (state.edit) {
    state.edit.stop();
    state.edit = null;
  }
  const bar = el("progress", { id: "job-progress", max: "100", value: "0", "aria-label": "Job progress" });
  const message = el("p", { id: "job-message", class: "muted", role: "status", text: "Sending the job…" });
  const cancel = el("button", { type: "button", text: "Cancel" });
  sections.progress.replaceChildren(el("h2", { id: "h-progress", text: "3 · Computing" }), bar, message, cancel);
  sections.progress.hidden = false;
  sections.result.hidden = true;
  setState("running");
  try {
    // The seeds in the grid's CRS when another one is asked for, so that they lie under the rasters.
    const crs = inputs.crs || "";
    if (crs !== (state.inventory.requestedCrs || "")) {
      state.inventory = { ...inventoryOf(await describeSeeds(state.seeds, crs)), requestedCrs: crs };
    }
    if (sea.bySea) {
      if (!sea.file) throw new Problem(0, { title: "By sea needs a barrier layer", detail: "Choose the file of the land (polygons) or barrier lines that paths go around." });
      inputs.barriers = await seedInput(sea.file);
    }
    const status = await postJson("/processes/voronoi/execution", { inputs: { ...inputs, seeds: state.seeds }, outputs },
      { Prefer: "respond-async" });
    state.job = status.jobID;
    cancel.addEventListener("click", async () => {
      cancel.disabled = true;
      await fetch("/jobs/" + state.job, { method: "DELETE", headers: headers("application/json") });
    });
    poll(bar, message, cancel, inputs);
  } catch (e) {
    showProblem(sections.progress, e);
    setState("failed");
  }
}

function poll(bar, message, cancel, inputs) {
  const id = state.job;
  const step = async () => {
    try {
      const s = await getJson("/jobs/" + id);
      bar.value = Math.max(0, Math.min(100, s.progress || 0));
      message.textContent = s.status + (s.message ? " · " + s.message : "");
      if (s.status === "successful") {
        cancel.remove();
        await showResults(id, inputs);
        return;
      }
      if (s.status === "failed" || s.status === "dismissed") {
        cancel.remove();
        // The job's error as the server's problem+json (its results answer with it).
        try {
          await getJson("/jobs/" + id + "/results");
        } catch (e) {
          sections.progress.append(problemBox(e));
        }
        setState("failed");
        return;
      }
      state.pollTimer = setTimeout(step, 400);
    } catch (e) {
      sections.progress.append(problemBox(e));
      setState("failed");
    }
  };
  step();
}

// ---- Results ------------------------------------------------------------------------------------

async function fetchJson(href) {
  return getJson(new URL(href, location.href).pathname);
}

const EXTENSIONS = { "application/geo+json": "geojson", "application/json": "json", "image/png": "png", "text/csv": "csv", "application/geopackage+sqlite3": "gpkg", "application/xml": "xml" };

function fileName(id, type) {
  const t = (type || "").split(";")[0].trim();
  return id + "." + (t === "image/tiff" ? "tif" : EXTENSIONS[t] || "bin");
}

function legend(report) {
  const owners = (report.seeds && report.seeds.owners) || [];
  const regions = (report.deliverables && report.deliverables.regions) || {};
  const areas = new Map((regions.areas || []).map((a) => [a.owner, a]));
  // Square metres read better as square kilometres; other units are shown as the report has them.
  const km2 = regions.area_units === "m^2";
  const unit = km2 ? " (km²)" : regions.area_units ? " (" + regions.area_units.replace("^2", "²") + ")" : "";
  const shown = owners.slice(0, 200);
  // (No areas without regions: a run that asked for none.)
  const withAreas = areas.size > 0;
  const rows = shown.map((o) => {
    const a = areas.get(o.code) || {};
    const fmt = (v) => (v === undefined ? "" : (km2 ? v / 1e6 : Number(v)).toLocaleString("en", { maximumFractionDigits: 1 }));
    return el("tr", {},
      el("td", {}, el("span", { class: "swatch", style: null, "data-colour": o.colour, role: "img", "aria-label": "colour " + o.colour })),
      el("td", { class: "owner", text: o.label }),
      withAreas ? el("td", { class: "num", text: fmt(a.sea_area) }) : null,
      withAreas ? el("td", { class: "num", text: fmt(a.land_area) }) : null);
  });
  const t = el("table", { class: "legend", id: "legend" },
    el("caption", { text: "Owners" }),
    el("thead", {}, el("tr", {}, el("th", { scope: "col", text: "" }), el("th", { scope: "col", text: "Owner" }),
      withAreas ? el("th", { scope: "col", text: "Sea" + unit }) : null,
      withAreas ? el("th", { scope: "col", text: "Land" + unit }) : null)),
    el("tbody", {}, ...rows));
  // Colours through the CSSOM, which the page's policy allows (no style attributes in markup).
  for (const s of t.querySelectorAll(".swatch")) s.style.background = s.dataset.colour;
  const parts = [t];
  if (owners.length > shown.length) parts.push(el("p", { class: "muted", text: "…and " + (owners.length - shown.length) + " more owners (see the report)." }));
  return parts;
}

function layerToggles() {
  const names = [["owners", "Owners' sea"], ["regions", "Regions"], ["seeds", "Seeds"], ["edit", "Seeds being edited"],
    ["boundaries", "Boundaries"], ["tripoints", "Tripoints"], ["limits", "Limits"]];
  const box = el("fieldset", { class: "toggles" }, el("legend", { text: "Layers" }));
  for (const [name, text] of names) {
    const layer = view.layers[name];
    if (!layer) continue;
    const input = el("input", { type: "checkbox", id: "layer-" + name });
    input.checked = layer.getVisible();
    input.addEventListener("change", () => layer.setVisible(input.checked));
    box.append(el("span", { class: "check" }, input, el("label", { for: "layer-" + name, text })));
  }
  return box;
}

async function showResults(id, inputs) {
  const results = await getJson("/jobs/" + id + "/results");
  // The report comes by value (the daemon's default for it) or, when asked so, by reference.
  const report = results.report.value !== undefined ? results.report.value : await fetchJson(results.report.href);
  state.report = report;
  const owners = (report.seeds && report.seeds.owners) || [];
  const colours = [];
  const byLabel = new Map();
  for (const o of owners) {
    colours[o.code] = o.colour;
    byLabel.set(o.label, o.colour);
  }
  const inv = state.inventory;
  const ownerField = inputs.ownerField;
  const g = report.grid || {};
  view.frame(projectionFor(inv.crs, inv.bbox), g.xmin !== undefined ? [g.xmin, g.ymin, g.xmax, g.ymax] : inv.bbox);
  view.showSeeds(inv.features, (f) => byLabel.get(ownerField ? String(f.get(ownerField)) : String(f.getId())));
  for (const name of ["boundaries", "tripoints", "limits"])
    view.showVector(name, results[name] ? await fetchJson(results[name].href) : null);
  const rasterUrl = (name) => new URL(results[name].href, location.href).pathname;
  await view.showOwners(rasterUrl("ownership"), rasterUrl("distance"), colours);

  const downloads = el("ul", { class: "downloads", id: "downloads" });
  for (const [name, r] of Object.entries(results)) {
    const file = fileName(name, r.type || r.mediaType);
    const save = r.href
      ? () => download(new URL(r.href, location.href).pathname, file)
      : async () => saveBlob(new Blob([JSON.stringify(r.value, null, 2)], { type: "application/json" }), file);
    downloads.append(el("li", {}, el("button", { type: "button", class: "link", text: file, onclick: () => save().catch((e) => downloads.append(problemBox(e))) })));
  }
  if (results.ownership) {
    const sidecar = new URL(results.ownership.href, location.href).pathname + ".aux.xml";
    downloads.append(el("li", {}, el("button", { type: "button", class: "link", text: "ownership.tif.aux.xml", onclick: () => download(sidecar, "ownership.tif.aux.xml").catch((e) => downloads.append(problemBox(e))) }),
      " (the raster attribute table: keep it beside ownership.tif)"));
  }
  const toggles = el("div", { id: "toggles" }, layerToggles());
  const editButton = el("button", { type: "button", id: "edit-start", text: "What if… (edit the seeds)",
    onclick: () => startEdit(byLabel, toggles, editButton) });
  sections.edit.hidden = true;
  sections.result.replaceChildren(
    el("h2", { id: "h-result", text: "4 · Result" }),
    el("p", {}, "Job ", el("a", { href: "/jobs/" + id + "?f=html", text: id }), " · " + (report.grid ? report.grid.width + " × " + report.grid.height + " cells" : "")),
    toggles, ...legend(report),
    el("h3", { text: "Downloads" }), downloads, editButton);
  sections.result.hidden = false;
  sections.result.scrollIntoView({ block: "start" });
  cellBox.textContent = "Click the map for a cell's owner and distance.";
  setState("done");
}

// ---- What if: a live session of the job ---------------------------------------------------------

async function startEdit(byLabel, toggles, button) {
  const { inputs, outputs } = state.request;
  if (inputs.barriers) {
    sections.edit.replaceChildren(el("h2", { id: "h-edit", text: "5 · What if" }),
      el("p", { text: "Editing does not compute by sea yet: change the seeds and compute again." }));
    sections.edit.hidden = false;
    return;
  }
  if (inputs.crs) {
    sections.edit.replaceChildren(el("h2", { id: "h-edit", text: "5 · What if" }),
      el("p", { text: "Editing needs the seeds in the grid's CRS; this job reprojects them (its CRS option)." }));
    sections.edit.hidden = false;
    return;
  }
  button.disabled = true;
  // The session keeps the job's lines and regions; a saved job writes the job's own outputs.
  const keep = {};
  for (const name of ["boundaries", "tripoints", "limits", "regions"]) if (outputs[name]) keep[name] = {};
  const saveOutputs = { ...outputs };
  delete saveOutputs.changes;
  const edit = new EditMode(view, sections.edit, { inputs: { ...inputs, seeds: state.seeds }, outputs: keep, saveOutputs },
    (label) => byLabel.get(label), problemBox);
  state.edit = edit;
  await edit.start();
  if (document.body.dataset.state === "edit-failed") {
    // The session was refused (its problem is shown): the map and its read-out as they were.
    state.edit = null;
    button.disabled = false;
    return;
  }
  // The owners' raster is the job's, not the session's: the regions stand for it while editing.
  toggles.replaceChildren(layerToggles());
  cellBox.textContent = "Editing: drag a basepoint or a vertex; click a feature to weight, reach or remove it.";
  sections.edit.scrollIntoView({ block: "start" });
}

// ---- The cell read-out ------------------------------------------------------------------------

view.map.on("singleclick", async (ev) => {
  if (!state.report || state.edit) return;  // while editing, a click picks a feature (edit.js)
  try {
    const c = await view.cellAt(ev.coordinate);
    if (!c) {
      cellBox.textContent = "Outside the grid.";
      delete cellBox.dataset.row;
      return;
    }
    const owner = ((state.report.seeds && state.report.seeds.owners) || []).find((o) => o.code === c.code);
    const units = state.report.distance_units || "";
    const where = "cell row " + c.row + ", column " + c.col + " (" + c.x.toPrecision(9) + ", " + c.y.toPrecision(9) + ")";
    const none = state.report.sea ? "No owner (land, or no seed reaches it by sea)" : "No owner (beyond the maximum distance)";
    cellBox.textContent = c.code === 0
      ? none + " · " + where
      : "Owner " + (owner ? owner.label : "code " + c.code) + " · distance " + c.distance.toLocaleString("en", { maximumFractionDigits: 3 }) + " " + units + " · " + where;
    // The values and the map coordinate clicked, for scripts (and the tests) to check.
    Object.assign(cellBox.dataset, { row: c.row, col: c.col, code: c.code, distance: c.distance, x: ev.coordinate[0], y: ev.coordinate[1] });
  } catch (e) {
    cellBox.replaceChildren(problemBox(e));
  }
});

// ---- Start ------------------------------------------------------------------------------------

async function start() {
  sessionBar(() => location.reload());
  try {
    state.process = await getJson("/processes/voronoi");
    sections.seeds.append(el("h2", { id: "h-seeds", text: "1 · Seeds" }), seedPicker());
    panel.replaceChildren(el("h1", { text: "Delimitation" }), ...Object.values(sections));
    setState("ready");
  } catch (e) {
    panel.replaceChildren(problemBox(e));
    if (e instanceof Problem && e.status === 401) setState("token");
    else setState("failed");
  }
}

start();
