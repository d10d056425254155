// The HTML face of every OGC API resource of the daemon (service/src/daemon/server_web.hpp).
//
// The daemon sends the same empty page for any resource asked for in HTML; this script fetches
// that resource as JSON and draws it. Everything a server or an upload says (owner labels, file
// names, messages) goes into text nodes (textContent), never into markup, so no upload can add
// script to the page; links are followed only within this origin. With authentication on, the
// person types the access token once; it is kept in this tab's sessionStorage and sent as
// "Authorization: Bearer" on every request the page makes, downloads included (they are fetched,
// then saved from memory), and never put in a URL. The header says who it signs in as (/me).

import { el, sessionBar, table, facts, headers, Problem, getJson, problemView as problemBox, humanBytes, download } from "./client.js";

const content = document.getElementById("content");
const problemView = (p) => problemBox(p, render);

// A link to a resource of this server: its HTML page for JSON resources, else the file.
function sameOrigin(href) {
  try {
    const u = new URL(href, location.href);
    return u.origin === location.origin ? u : null;
  } catch {
    return null;
  }
}

function pageLink(href, text) {
  const u = sameOrigin(href);
  if (!u) return el("span", { text: text || href });
  u.searchParams.set("f", "html");
  return el("a", { href: u.pathname + u.search, text: text || u.pathname });
}

function show(...nodes) {
  content.replaceChildren(...nodes);
  content.setAttribute("aria-busy", "false");
}

// ---- Resources --------------------------------------------------------------------------

// Files (a job's outputs) are fetched with the token and saved; resources open as pages.
function linksTable(links) {
  const cell = (l) => {
    const u = sameOrigin(l.href);
    if (u && (l.rel === "enclosure" || l.rel === "describedby")) {
      const name = u.pathname.split("/").pop();
      return el("button", { type: "button", class: "link", text: l.title || name,
        onclick: () => download(u.href, name).catch((e) => show(problemView(e))) });
    }
    // What answers a POST only (a session's edits, undo, redo, jobs) is no page to open.
    if ((l.title || "").startsWith("POST")) return el("code", { text: u ? u.pathname : l.href });
    return pageLink(l.href, l.title || l.href);
  };
  return table(["Link", "Relation", "Type"], (links || []).map((l) => [cell(l),
    (l.title || "").startsWith("POST") ? l.rel + " · " + l.title : l.rel || "", l.type || ""]));
}

function landing(doc) {
  return [el("h1", { text: doc.title || "rvoronoi" }), el("p", { class: "lead", text: doc.description || "" }),
    el("h2", { text: "Resources" }), linksTable(doc.links)];
}

function conformance(doc) {
  return [el("h1", { text: "Conformance" }), el("p", { class: "lead", text: "The conformance classes this server implements." }),
    el("ul", {}, ...(doc.conformsTo || []).map((c) => el("li", {}, el("code", { text: c }))))];
}

function processList(doc) {
  return [el("h1", { text: "Processes" }),
    table(["Process", "Title", "Version", "Description"], (doc.processes || []).map((p) => [
      pageLink("/processes/" + encodeURIComponent(p.id), p.id), p.title || "", p.version || "", p.description || ""]))];
}

function schemaText(s) {
  if (!s) return "";
  const parts = [];
  if (s.type) parts.push(s.type === "array" && s.items ? "array of " + (s.items.type || "values") : s.type);
  if (s.enum) parts.push("one of " + s.enum.join(", "));
  if (s.minimum !== undefined) parts.push((s.exclusiveMinimum ? "> " : "≥ ") + s.minimum);
  if (s.maximum !== undefined) parts.push("≤ " + s.maximum);
  if (s.format) parts.push(s.format);
  if (s.contentMediaType) parts.push(s.contentMediaType);
  if (s.oneOf) parts.push(s.oneOf.map(schemaText).filter(Boolean).join(" | "));
  return parts.join(", ");
}

function processDescription(doc) {
  const inputs = Object.entries(doc.inputs || {}).map(([id, i]) => [
    el("code", { text: id }), i.title || "", schemaText(i.schema),
    i.schema && i.schema.default !== undefined ? JSON.stringify(i.schema.default) : "",
    (i.minOccurs || 0) > 0 ? "required" : "optional", i.description || ""]);
  const outputs = Object.entries(doc.outputs || {}).map(([id, o]) => [el("code", { text: id }), o.title || "", schemaText(o.schema), o.description || ""]);
  return [el("h1", { text: doc.title || doc.id }), el("p", { class: "lead", text: doc.description || "" }),
    el("p", { class: "muted", text: "Version " + (doc.version || "?") + " · job control: " + (doc.jobControlOptions || []).join(", ") }),
    el("h2", { text: "Inputs" }), table(["Input", "Title", "Type", "Default", "Use", "Description"], inputs),
    el("h2", { text: "Outputs" }), table(["Output", "Title", "Type", "Description"], outputs),
    el("h2", { text: "Links" }), linksTable(doc.links)];
}

function statusBadge(s) {
  return el("span", { class: "status " + s, text: s });
}

// A principal's name, linking to the list of its jobs (an admin's view of one principal).
function principalLink(name) {
  return name ? pageLink("/jobs?principal=" + encodeURIComponent(name), name) : "";
}

function jobList(doc) {
  const rows = (doc.jobs || []).map((j) => [pageLink("/jobs/" + encodeURIComponent(j.jobID), j.jobID), statusBadge(j.status),
    j.progress !== undefined ? j.progress + " %" : "", principalLink(j.principal), j.created || "", j.message || ""]);
  const next = (doc.links || []).find((l) => l.rel === "next");
  const only = new URLSearchParams(location.search).get("principal");
  return [el("h1", { text: only ? "Jobs of " + only : "Jobs" }),
    only ? el("p", {}, pageLink("/jobs", "Every job you may see")) : null,
    rows.length ? table(["Job", "Status", "Progress", "Principal", "Created", "Message"], rows) : el("p", { text: "No jobs yet." }),
    next ? el("p", {}, pageLink(next.href, "Next page")) : null];
}

let pollTimer = null;

function jobStatus(doc) {
  const bar = el("progress", { max: "100", value: String(doc.progress || 0), "aria-label": "progress" });
  const nodes = [el("h1", { text: "Job " + doc.jobID }),
    el("p", {}, statusBadge(doc.status), " ", bar, " ", el("span", { text: (doc.progress || 0) + " %" })),
    el("p", { class: "lead", text: doc.message || "" }),
    facts([["Process", doc.processID || ""], ["Principal", principalLink(doc.principal)], ["Created", doc.created || ""], ["Started", doc.started || ""],
      ["Finished", doc.finished || ""], ["Updated", doc.updated || ""]]),
    el("h2", { text: "Links" }), linksTable(doc.links)];
  if (doc.status === "accepted" || doc.status === "running") {
    pollTimer = setTimeout(render, 1000);  // progress that updates
  }
  return nodes;
}

function reportSummary(report) {
  const owners = (report.seeds && report.seeds.owners) || [];
  const nodes = [el("h2", { text: "Report" }),
    facts([["Grid", report.grid ? report.grid.width + " × " + report.grid.height + " cells of " + report.grid.resolution : ""],
      ["Metric", report.metric || ""], ["Distance units", report.distance_units || ""], ["Method", report.method || ""]])];
  // Each owner's areas when the job made regions (in the job's distance units squared).
  const regions = report.deliverables && report.deliverables.regions;
  const areas = {};
  for (const a of (regions && regions.areas) || []) areas[a.owner] = a;
  const fmt = (v) => (typeof v === "number" ? v.toLocaleString("en", { maximumSignificantDigits: 6 }) : "");
  if (owners.length && regions) {
    nodes.push(table(["Code", "Owner", "Sea area (" + regions.area_units + ")", "Land area (" + regions.area_units + ")"],
      owners.map((o) => [String(o.code), o.label, fmt((areas[o.code] || {}).sea_area), fmt((areas[o.code] || {}).land_area)]), "Owners"));
  } else if (owners.length) {
    nodes.push(table(["Code", "Owner"], owners.map((o) => [String(o.code), o.label]), "Owners"));
  }
  return nodes;
}

async function results(doc, path) {
  const rows = [];
  const extra = [];
  for (const [name, out] of Object.entries(doc)) {
    if (out.href) {
      const u = sameOrigin(out.href);
      let size = "";
      if (u) {
        const h = await fetch(u, { method: "HEAD", headers: headers("*/*") }).catch(() => null);
        if (h && h.ok) size = humanBytes(Number(h.headers.get("Content-Length")));
      }
      const button = el("button", { type: "button", text: "Download " + name,
        onclick: () => download(u.href, name).catch((e) => show(problemView(e))) });
      rows.push([el("code", { text: name }), out.type || "", size, button]);
      if (u && (out.type || "").startsWith("image/png")) {
        const r = await fetch(u, { headers: headers("image/png") });
        if (r.ok) extra.push(el("h2", { text: "Preview" }), el("img", { class: "preview", src: URL.createObjectURL(await r.blob()), alt: "Quicklook of the ownership raster (" + name + ")" }));
      }
      if (u && name === "report") {
        const r = await fetch(u, { headers: headers("application/json") });
        if (r.ok) extra.push(...reportSummary(await r.json()));
      }
    } else if (out.value !== undefined) {
      rows.push([el("code", { text: name }), out.mediaType || "", "", "by value"]);
      if (name === "report" && typeof out.value === "object") extra.push(...reportSummary(out.value));
    }
  }
  const job = path.split("/")[2] || "";
  return [el("h1", { text: "Results of job " + job }), pageLink("/jobs/" + encodeURIComponent(job), "Job status"),
    table(["Output", "Type", "Size", ""], rows), ...extra];
}

function apiDocument(text) {
  return [el("h1", { text: "API definition (OpenAPI 3.0)" }), el("p", {}, "As YAML; tools read it from ", el("code", { text: "/api" }), "."),
    el("pre", { text: typeof text === "string" ? text : JSON.stringify(text, null, 2) })];
}

// GET /me: who the token signs in as.
function me(doc) {
  const how = { none: "none: this server asks for no token", token: "a token of this server", jwt: "a token of the identity provider (JWT)" };
  const title = doc.authentication === "none" ? "Open server" : "Signed in as " + doc.name;
  const rows = [["Name", doc.name || ""], ["Role", doc.role || ""], ["Authentication", how[doc.authentication] || doc.authentication || ""]];
  if (doc.expires) rows.push(["Expires", new Date(doc.expires).toLocaleString() + " (" + doc.expires + ")"]);
  return [el("h1", { text: title }), facts(rows), el("h2", { text: "Links" }), linksTable(doc.links)];
}

function health(doc) {
  return [el("h1", { text: "Health" }), el("pre", { text: JSON.stringify(doc, null, 2) })];
}

// ---- Live what-if sessions (/sessions) -----------------------------------------------------

const fmtNumber = (v) => (typeof v === "number" ? v.toLocaleString("en", { maximumSignificantDigits: 7 }) : "");

function sessionList(doc) {
  const rows = (doc.sessions || []).map((x) => [pageLink("/sessions/" + encodeURIComponent(x.sessionID), x.sessionID),
    statusBadge(x.status), principalLink(x.principal), x.memoryBytes !== undefined ? humanBytes(x.memoryBytes) : "",
    x.lastUsed || "", x.expires || ""]);
  return [el("h1", { text: "Sessions" }),
    el("p", { class: "lead", text: "Live what-if sessions on the daemon " + (doc.daemon || "") +
      ": a job kept in memory whose seeds are edited step by step (POST /sessions with an execution request creates one)." }),
    rows.length ? table(["Session", "Status", "Principal", "Memory", "Last used", "Expires"], rows) : el("p", { text: "No sessions." })];
}

function sessionStatus(doc) {
  const nodes = [el("h1", { text: "Session " + doc.sessionID }),
    el("p", {}, statusBadge(doc.status), " ", el("span", { text: doc.message || "" })),
    facts([["Daemon", doc.daemon || ""], ["Principal", principalLink(doc.principal)], ["Created", doc.created || ""],
      ["Last used", doc.lastUsed || ""], ["Expires", doc.expires || ""],
      ["Grid", doc.grid ? doc.grid.width + " × " + doc.grid.height + " cells of " + doc.grid.res + " (" + doc.grid.crs + ")" : ""],
      ["Metric", doc.metric || ""], ["Steps", doc.steps !== undefined ? doc.steps + " (undo " + doc.undo + ", redo " + doc.redo + ")" : ""],
      ["Memory", doc.memory_bytes !== undefined ? humanBytes(doc.memory_bytes) + " (" + fmtNumber(doc.bytes_per_cell) + " bytes a cell)" : ""]])];
  if (doc.areas) {
    const regions = doc.areas.some((a) => a.area !== undefined);
    nodes.push(el("h2", { text: "Areas (" + (doc.area_units || "") + ")" }),
      table(regions ? ["Owner", "Cells' area", "Region", "Sea", "Land"] : ["Owner", "Cells' area"],
        doc.areas.map((a) => (regions ? [a.label, fmtNumber(a.cells_area), fmtNumber(a.area), fmtNumber(a.sea_area), fmtNumber(a.land_area)]
          : [a.label, fmtNumber(a.cells_area)]))));
  }
  nodes.push(el("h2", { text: "Links" }), linksTable(doc.links));
  if (doc.status === "creating") pollTimer = setTimeout(render, 1000);
  return nodes;
}

function sessionDeliverables(doc) {
  return [el("h1", { text: "Deliverables kept" }),
    table(["Deliverable", "Type"], (doc.deliverables || []).map((d) => [pageLink(d.href, d.id), d.type])),
    el("h2", { text: "Links" }), linksTable(doc.links)];
}

// A GeoJSON collection (a session's features, a deliverable) as a table of its features.
function featureTable(doc, path) {
  const features = doc.features || [];
  const keys = [...new Set(features.flatMap((f) => Object.keys(f.properties || {})))].slice(0, 8);
  const vertices = (g) => (g ? JSON.stringify(g.coordinates || []).split("],[").length : 0);
  const rows = features.slice(0, 2000).map((f) => [f.id !== undefined ? String(f.id) : "", (f.geometry || {}).type || "",
    String(vertices(f.geometry)), ...keys.map((k) => { const v = (f.properties || {})[k]; return v === null || v === undefined ? "" : typeof v === "object" ? JSON.stringify(v) : String(v); })]);
  const session = path.split("/")[2] || "";
  return [el("h1", { text: path.split("/").pop() + " of session " + session }),
    pageLink("/sessions/" + encodeURIComponent(session), "Session status"),
    el("p", { class: "muted", text: features.length + " features" + (features.length > 2000 ? " (the first 2000 shown)" : "") }),
    table(["Id", "Geometry", "Vertices", ...keys], rows)];
}

const VIEWS = [
  [/^\/$/, landing],
  [/^\/conformance$/, conformance],
  [/^\/processes$/, processList],
  [/^\/processes\/[^/]+$/, processDescription],
  [/^\/jobs$/, jobList],
  [/^\/jobs\/[^/]+$/, jobStatus],
  [/^\/jobs\/[^/]+\/results$/, results],
  [/^\/health$/, health],
  [/^\/me$/, me],
  [/^\/sessions$/, sessionList],
  [/^\/sessions\/[^/]+$/, sessionStatus],
  [/^\/sessions\/[^/]+\/deliverables$/, sessionDeliverables],
  [/^\/sessions\/[^/]+\/(features|deliverables\/(boundaries|tripoints|limits|regions))$/, featureTable],
];

async function render() {
  clearTimeout(pollTimer);
  sessionBar(render);
  const path = location.pathname.replace(/\/+$/, "") || "/";
  try {
    if (path === "/api") {
      const r = await fetch("/api", { headers: headers("application/vnd.oai.openapi, */*") });
      show(...apiDocument(await r.text()));
      return;
    }
    const view = VIEWS.find(([re]) => re.test(path));
    const doc = await getJson(location.pathname + location.search);
    const nodes = view ? await view[1](doc, path) : [el("h1", { text: path }), el("pre", { text: JSON.stringify(doc, null, 2) })];
    document.title = "rvoronoi · " + ((nodes[0] && nodes[0].textContent) || path);
    show(...nodes.filter(Boolean));
  } catch (e) {
    if (e instanceof Problem) {
      document.title = "rvoronoi · " + (e.body.title || "error");
      show(problemView(e));
    } else {
      show(problemView(new Problem(0, { title: "The page could not be drawn", detail: String(e && e.message ? e.message : e) })));
    }
  }
}

render();
