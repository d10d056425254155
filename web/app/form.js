// The job form, made from the process description (GET /processes/voronoi), which the daemon
// makes from its option table: every input gets a field of its schema's kind with its title as
// the label and its description as the help text. The description's x-rvoronoi-* members say
// what the schema cannot (the same ones the QGIS provider is made from): uploads
// (x-rvoronoi-upload: the page takes the seeds itself), fields of the seed layers
// (x-rvoronoi-field-of: the seed file's fields fill their choices).

import { el } from "../client.js";
import { ACCEPT } from "./upload.js";

// Inputs the page supplies itself (the edit of an earlier job; uploads, by their schema).
const NOT_IN_FORM = new Set(["baseJob"]);
const isUpload = (input) => Boolean(schemaOf(input)["x-rvoronoi-upload"]);
const isField = (input) => Boolean(schemaOf(input)["x-rvoronoi-field-of"]);
// An extent: an array of four numbers, or an OGC bbox object.
const isExtent = (input) => (schemaOf(input).oneOf || []).some((v) => v.type === "array" && v.minItems === 4 && v.maxItems === 4);
const isList = (input) => schemaOf(input).type === "array";
const inForm = (name, input) => !NOT_IN_FORM.has(name) && !isUpload(input);
// First, in this order, open; the rest under "More options".
const MAIN = ["ownerField", "resolution", "extent", "metric", "distanceUnits", "maxDistance", "limitDistances"];
// The outputs offered; ownership, distance, report and regions are always made (the map, the
// click read-out and the legend's areas need them), the limit lines when distances are given.
export const OPTIONAL_OUTPUTS = [
  ["boundaries", "Boundary (equidistance) lines", true],
  ["tripoints", "Tripoints", true],
  ["preview", "Quicklook PNG", false],
  ["nearestFeature", "Nearest-feature raster", false],
  ["turningPoints", "Turning points (treaty table)", false],
  ["margin", "Margin raster", false],
];
export const ALWAYS_OUTPUTS = ["ownership", "distance", "report", "regions"];

// 1, 2 or 5 times a power of ten, near `x`.
export function niceNumber(x) {
  const p = Math.pow(10, Math.floor(Math.log10(x)));
  const m = x / p;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}

function schemaOf(input) {
  return input.schema || {};
}

function fieldId(name) {
  return "in-" + name;
}

function help(name, input) {
  return input.description ? el("p", { class: "help", id: fieldId(name) + "-help", text: input.description }) : null;
}

// A field for one input; `fields` are the seed file's fields (for the *Field inputs).
function control(name, input, inventory) {
  const s = schemaOf(input);
  const id = fieldId(name);
  const label = input.title || name;
  const described = input.description ? id + "-help" : null;
  if (isField(input)) {
    const numeric = name !== "ownerField";
    const select = el("select", { id, name, "aria-describedby": described });
    select.append(el("option", { value: "", text: name === "ownerField" ? "(none: each feature is its own owner)" : "(none)" }));
    for (const f of inventory ? inventory.fieldsFor(numeric) : []) {
      const values = f.distinctExact ? f.distinct + " value" + (f.distinct === 1 ? "" : "s") : "over " + f.distinct + " values";
      select.append(el("option", { value: f.name, text: f.name + " (" + f.type + ", " + values + ")" }));
    }
    if (name === "ownerField" && inventory && inventory.ownerGuess) select.value = inventory.ownerGuess;
    return el("div", { class: "field" }, el("label", { for: id, text: label }), select, help(name, input));
  }
  if (isExtent(input)) {
    const boxes = ["xmin", "ymin", "xmax", "ymax"].map((c, i) =>
      el("input", { id: id + "-" + i, name: name + "-" + c, type: "number", step: "any", "aria-label": label + ": " + c, placeholder: c }));
    return el("fieldset", { class: "field extent", id, "aria-describedby": described },
      el("legend", { text: label + " (empty: from the seeds)" }), ...boxes, help(name, input));
  }
  if (isList(input)) {
    return el("div", { class: "field" }, el("label", { for: id, text: label }),
      el("input", { id, name, type: "text", placeholder: "12nmi, 24nmi", "aria-describedby": described }), help(name, input));
  }
  if (s.type === "boolean") {
    const box = el("input", { id, name, type: "checkbox", "aria-describedby": described });
    box.checked = s.default === true;
    return el("div", { class: "field check" }, box, el("label", { for: id, text: label }), help(name, input));
  }
  if (s.enum) {
    const select = el("select", { id, name, "aria-describedby": described });
    if (s.default === undefined) select.append(el("option", { value: "", text: "(default)" }));
    for (const v of s.enum) if (!String(v).includes("_")) select.append(el("option", { value: v, text: v }));
    if (s.default !== undefined) select.value = s.default;
    return el("div", { class: "field" }, el("label", { for: id, text: label }), select, help(name, input));
  }
  const attrs = { id, name, "aria-describedby": described };
  if (s.type === "number" || s.type === "integer") {
    Object.assign(attrs, { type: "number", step: "any" });
    if (s.minimum !== undefined && !s.exclusiveMinimum) attrs.min = s.minimum;
    if (s.default !== undefined) attrs.placeholder = String(s.default);
  } else {
    attrs.type = "text";
  }
  if (input.minOccurs > 0) attrs.required = "";
  return el("div", { class: "field" }, el("label", { for: id, text: label }), el("input", attrs), help(name, input));
}

// The distance by sea (the process's "barriers" upload): a switch and the barrier layer it asks
// for. Paths go around the barriers, so they matter when the seeds are not them: with the coast
// itself as the seeds nothing changes (a path a seed blocks passes nearer to that seed). Every
// deliverable is offered by sea too.

function bySea(process) {
  const input = (process.inputs || {}).barriers;
  if (!input) return null;
  const box = el("input", { id: "by-sea", name: "by-sea", type: "checkbox", "aria-controls": "sea-layer" });
  const file = el("input", { id: "barrier-file", type: "file", accept: ACCEPT, "aria-describedby": "sea-help" });
  const layer = el("div", { class: "field", id: "sea-layer", hidden: "" },
    el("label", { for: "barrier-file", text: "Barrier layer: land polygons, lines no path crosses" }), file,
    el("p", { class: "help", id: "sea-help", text: "For example the land while the seeds are ports or farms. With only " +
      "the coasts loaded as seeds it would change nothing. On a longitude/latitude grid paths and edges are " +
      "geodesics. Boundary lines, tripoints, limits and regions follow the distance by sea and end on the coasts " +
      "they meet; turning points name each side's last bend." }));
  box.addEventListener("change", () => {
    layer.hidden = !box.checked;
  });
  return el("fieldset", { class: "field sea" }, el("legend", { text: input.title || "Distance by sea" }),
    el("div", { class: "check" }, box, el("label", { for: "by-sea", text: "By sea: around land and barriers" })), layer);
}

// Whether the form asks for the distance by sea, and its barrier file (or null).
export function seaChoice(form) {
  const box = form.querySelector("#by-sea");
  if (!box || !box.checked) return { bySea: false, file: null };
  const file = form.querySelector("#barrier-file");
  return { bySea: true, file: file && file.files[0] ? file.files[0] : null };
}

// The form's fields for the process description `process` and the seed file `inventory`.
export function jobFields(process, inventory) {
  const inputs = process.inputs || {};
  const names = Object.keys(inputs).filter((n) => inForm(n, inputs[n]));
  const main = MAIN.filter((n) => names.includes(n));
  const more = names.filter((n) => !MAIN.includes(n));
  const outputs = el("fieldset", { class: "field outputs" }, el("legend", { text: "Also make" }),
    ...OPTIONAL_OUTPUTS.map(([id, text, on]) => {
      const box = el("input", { id: "out-" + id, name: "out-" + id, type: "checkbox" });
      box.checked = on;
      return el("div", { class: "check" }, box, el("label", { for: "out-" + id, text }));
    }));
  return [
    ...main.map((n) => control(n, inputs[n], inventory)),
    bySea(process),
    outputs,
    el("details", { class: "more" }, el("summary", { text: "More options" }), ...more.map((n) => control(n, inputs[n], inventory))),
  ];
}

// The execute request's inputs and outputs from the form (only what the person set).
export function readForm(form, process) {
  const inputs = {};
  for (const [name, input] of Object.entries(process.inputs || {})) {
    if (!inForm(name, input)) continue;
    const s = schemaOf(input);
    if (isExtent(input)) {
      const v = [0, 1, 2, 3].map((i) => form.querySelector("#" + fieldId(name) + "-" + i).value.trim());
      if (v.some((x) => x !== "")) inputs[name] = v.map(Number);
      continue;
    }
    const field = form.querySelector("#" + fieldId(name));
    if (!field) continue;
    if (field.type === "checkbox") {
      if (field.checked !== (s.default === true)) inputs[name] = field.checked;
    } else if (isList(input)) {
      const list = field.value.split(",").map((x) => x.trim()).filter(Boolean);
      if (list.length) inputs[name] = list;
    } else if (s.default !== undefined && field.value === String(s.default)) {
      continue;
    } else if (field.value.trim() !== "") {
      inputs[name] = s.type === "number" || s.type === "integer" ? Number(field.value) : field.value.trim();
    }
  }
  const outputs = {};
  for (const id of ALWAYS_OUTPUTS) outputs[id] = {};
  for (const [id] of OPTIONAL_OUTPUTS) if (form.querySelector("#out-" + id).checked) outputs[id] = {};
  // Limit lines exactly when there are distances for them (the daemon refuses either alone).
  if (inputs.limitDistances) outputs.limits = {};
  // By sea: the vias too.
  if (seaChoice(form).bySea) outputs.via = {};
  return { inputs, outputs };
}
