// The map page's "what if" mode (issue 54): after a result, a live session of the daemon holds the
// same job; the person drags a basepoint or a vertex of a coast or island (OpenLayers' Modify),
// or picks a feature to weight it, give it a reach or remove it, or types a vertex's new
// coordinates; each change is one step of the session (POST /sessions/{id}/edits). The step's
// answer redraws what it changed at once: the features it touched, the boundaries, tripoints and
// limits it added, changed and removed (by the lines' ids, GET /sessions/{id}/lines keying the
// lines first drawn), and each owner's area and its change since the start; then the regions are
// read again (they change with every owner's cells) and the areas become the regions'. Undo,
// redo and "Save as job" are the session's.
//
// The page keeps no rule of its own: what an edit changes, and every number shown, is the
// daemon's answer. Requests go one at a time, in the order the person made them.

import Modify from "ol/interaction/Modify.js";
import VectorLayer from "ol/layer/Vector.js";
import VectorSource from "ol/source/Vector.js";
import GeoJSON from "ol/format/GeoJSON.js";
import { Style, Fill, Stroke, Circle as CircleStyle } from "ol/style.js";
import { el, getJson, headers } from "../client.js";
import { postJson } from "./upload.js";
import { LAND } from "./map.js";

const EDITABLE = new Style({
  image: new CircleStyle({ radius: 6, fill: new Fill({ color: "#f4d03f" }), stroke: new Stroke({ color: "#1b2631", width: 1.5 }) }),
  stroke: new Stroke({ color: "#b9770e", width: 2 }),
  fill: new Fill({ color: LAND }),
});
const PICKED = new Style({
  image: new CircleStyle({ radius: 8, fill: new Fill({ color: "#e74c3c" }), stroke: new Stroke({ color: "#fff", width: 2 }) }),
  stroke: new Stroke({ color: "#e74c3c", width: 3 }),
  fill: new Fill({ color: LAND }),
});

// The path of the first vertex where two GeoJSON geometries of one type differ, for a
// "move-vertex" edit: [] for a point, [part] for a multipoint, [part, vertex] for a line or
// multiline, [part, ring, vertex] for a polygon or multipolygon; null when they differ otherwise
// (a vertex added or removed: the edit is a "replace").
export function movedVertex(before, after) {
  if (!before || !after || before.type !== after.type) return null;
  const same = (a, b) => a[0] === b[0] && a[1] === b[1];
  const parts = (g) => (g.type.startsWith("Multi") ? g.coordinates : [g.coordinates]);
  const a = parts(before), b = parts(after);
  if (a.length !== b.length) return null;
  const moved = [];
  const kind = before.type.replace("Multi", "");
  for (let p = 0; p < a.length; ++p) {
    if (kind === "Point") {
      if (!same(a[p], b[p])) moved.push({ path: before.type === "Point" ? [] : [p], to: b[p] });
    } else if (kind === "LineString") {
      if (a[p].length !== b[p].length) return null;
      for (let v = 0; v < a[p].length; ++v) if (!same(a[p][v], b[p][v])) moved.push({ path: [p, v], to: b[p][v] });
    } else if (kind === "Polygon") {
      if (a[p].length !== b[p].length) return null;
      for (let r = 0; r < a[p].length; ++r) {
        if (a[p][r].length !== b[p][r].length) return null;
        // The closing vertex is the first one again: moving one moves both.
        for (let v = 0; v < a[p][r].length - 1; ++v) if (!same(a[p][r][v], b[p][r][v])) moved.push({ path: [p, r, v], to: b[p][r][v] });
      }
    } else {
      return null;
    }
  }
  return moved.length === 1 ? moved[0] : null;
}

function km2(v, units) {
  return units === "m^2" ? v / 1e6 : v;
}

function signed(x) {
  const s = Math.abs(x).toLocaleString("en", { maximumFractionDigits: 1, minimumFractionDigits: 1 });
  return (x > 0 ? "+" : x < 0 ? "−" : "±") + s;
}

export class EditMode {
  // `view`: the MapView; `section`: the panel's section to draw in; `request`: the session's
  // creation body ({inputs, outputs}); `colourOf(label)`: an owner's colour; `problemBox(e)`.
  constructor(view, section, request, colourOf, problemBox) {
    this.view = view;
    this.section = section;
    this.request = request;
    this.colourOf = colourOf;
    this.problemBox = problemBox;
    this.queue = Promise.resolve();
    this.format = new GeoJSON({ dataProjection: view.projection, featureProjection: view.projection });
    this.geometry = new Map();  // feature id -> its GeoJSON geometry as the session has it
    this.picked = null;
  }

  setBusy(busy) {
    document.body.dataset.state = busy ? "edit-busy" : "editing";
    for (const b of this.section.querySelectorAll("button, input")) b.disabled = busy;
  }

  // Runs `work` after every request before it; a failure is shown, the session is re-read.
  enqueue(work) {
    this.queue = this.queue.then(async () => {
      this.setBusy(true);
      try {
        await work();
      } catch (e) {
        this.message.replaceChildren(this.problemBox(e));
        await this.refresh().catch(() => {});
      } finally {
        this.setBusy(false);
      }
    });
    return this.queue;
  }

  async start() {
    this.section.replaceChildren(el("h2", { id: "h-edit", text: "5 · What if" }), el("p", { class: "muted", role: "status", text: "Creating a live session of this job…" }));
    this.section.hidden = false;
    document.body.dataset.state = "edit-busy";
    let status;
    try {
      status = await postJson("/sessions", { inputs: this.request.inputs, outputs: this.request.outputs });
    } catch (e) {
      this.section.append(this.problemBox(e));
      document.body.dataset.state = "edit-failed";
      return;
    }
    this.id = status.sessionID;
    this.units = status.area_units || "";
    // Each owner's area at the start, the regions' and the cells' (a step answers with the
    // cells'; the regions' follow when they are read).
    this.start_areas = new Map((status.areas || []).map((a) => [a.label, a]));
    this.drawPanel(status);
    this.editLayer = new VectorLayer({ source: new VectorSource(), style: (f) => (f === this.picked ? PICKED : EDITABLE) });
    this.view.setLayer("edit", this.editLayer, 6);
    for (const name of ["seeds", "owners"]) if (this.view.layers[name]) this.view.layers[name].setVisible(false);
    this.modify = new Modify({ source: this.editLayer.getSource(), pixelTolerance: 12 });
    this.modify.on("modifyend", (ev) => ev.features.forEach((f) => this.dragged(f)));
    this.view.map.addInteraction(this.modify);
    this.clicker = this.view.map.on("singleclick", (ev) => {
      const f = this.view.map.forEachFeatureAtPixel(ev.pixel, (x) => x, { layerFilter: (l) => l === this.editLayer, hitTolerance: 6 });
      if (f) this.pick(f);
    });
    await this.enqueue(async () => {
      await this.refresh();
      this.areas(status.areas || []);
    });
  }

  drawPanel(status) {
    this.stepLine = el("p", { id: "edit-step", role: "status", "data-session": this.id, "data-step": "0",
      text: "Session " + this.id + " · step 0. Drag a basepoint or a vertex; click a feature to weight, reach or remove it." });
    const undo = el("button", { type: "button", id: "edit-undo", text: "Undo", onclick: () => this.step("undo") });
    const redo = el("button", { type: "button", id: "edit-redo", text: "Redo", onclick: () => this.step("redo") });
    const save = el("button", { type: "button", id: "edit-save", text: "Save as job", onclick: () => this.save() });
    this.table = el("div", { id: "edit-areas" });
    this.featureBox = el("div", { id: "edit-feature" }, el("p", { class: "muted", text: "No feature picked." }));
    // The keyboard way to move a vertex: its feature, its path and where to.
    const field = (id, label, attrs = {}) => el("div", { class: "field" }, el("label", { for: id, text: label }), el("input", { id, ...attrs }));
    this.moveForm = el("form", { id: "edit-move", class: "move" },
      el("h3", { text: "Move a vertex" }),
      field("move-feature", "Feature id"), field("move-path", "Vertex path (empty for a point; part, vertex; part, ring, vertex)"),
      field("move-x", "x", { inputmode: "decimal" }), field("move-y", "y", { inputmode: "decimal" }),
      el("button", { type: "submit", text: "Move" }));
    this.moveForm.addEventListener("submit", (ev) => {
      ev.preventDefault();
      const v = (id) => this.moveForm.querySelector("#" + id).value.trim();
      const path = v("move-path") === "" ? [] : v("move-path").split(",").map((x) => Number(x.trim()));
      this.edit([{ op: "move-vertex", feature: v("move-feature"), path, to: [Number(v("move-x")), Number(v("move-y"))] }]);
    });
    this.message = el("div", { id: "edit-message", "aria-live": "polite" });
    this.section.replaceChildren(el("h2", { id: "h-edit", text: "5 · What if" }), this.stepLine,
      el("div", { class: "buttons" }, undo, redo, save), this.message, this.table, this.featureBox, this.moveForm);
  }

  // The session's features and deliverables as they are now, the lines keyed by their ids.
  async refresh() {
    const fc = await getJson("/sessions/" + this.id + "/features");
    const source = this.editLayer.getSource();
    source.clear();
    this.geometry.clear();
    for (const f of fc.features) this.geometry.set(String(f.id), f.geometry);
    const features = this.format.readFeatures({ type: "FeatureCollection", features: fc.features });
    source.addFeatures(features);
    if (this.picked) {
      const again = source.getFeatureById(this.picked.getId());
      this.picked = null;
      if (again) this.pick(again);
      else this.featureBox.replaceChildren(el("p", { class: "muted", text: "No feature picked." }));
    }
    const kept = this.kept();
    const ids = await getJson("/sessions/" + this.id + "/lines");
    for (const name of ["boundaries", "tripoints", "limits"]) {
      const fc = kept.includes(name) ? await getJson("/sessions/" + this.id + "/deliverables/" + name) : null;
      if (fc) fc.features.forEach((f, i) => { f.id = ids[name][i]; });
      this.view.showVector(name, fc);
    }
    await this.redrawRegions();
  }

  kept() {
    return (this.request.outputs && Object.keys(this.request.outputs)) || [];
  }

  // The regions read again, and the areas they give.
  async redrawRegions() {
    if (!this.kept().includes("regions")) return;
    this.view.showRegions(await getJson("/sessions/" + this.id + "/deliverables/regions"), this.colourOf);
    const status = await getJson("/sessions/" + this.id);
    this.areas(status.areas || []);
  }

  // The lines and features a step added, changed and removed, redrawn from its answer.
  patch(answer) {
    const replace = (source, changes, read) => {
      if (!source || !changes) return;
      for (const id of changes.removed || []) {
        const f = source.getFeatureById(id);
        if (f) source.removeFeature(f);
      }
      for (const entry of [...(changes.changed || []), ...(changes.added || [])]) {
        const old = source.getFeatureById(entry.id);
        if (old) source.removeFeature(old);
        source.addFeature(read(entry));
      }
    };
    const line = (entry) => {
      const { geometry, id, ...properties } = entry;
      return this.format.readFeature({ type: "Feature", id, properties, geometry });
    };
    const lines = answer.lines || {};
    for (const name of ["boundaries", "limits"]) {
      const layer = this.view.layers[name];
      replace(layer && layer.getSource(), lines[name], line);
    }
    const tri = this.view.layers.tripoints;
    replace(tri && tri.getSource(), answer.tripoints, line);
    const features = answer.features || {};
    const source = this.editLayer.getSource();
    replace(source, features, (f) => this.format.readFeature(f));
    for (const id of features.removed || []) this.geometry.delete(String(id));
    for (const f of [...(features.changed || []), ...(features.added || [])]) this.geometry.set(String(f.id), f.geometry);
    if (this.picked && !source.getFeatureById(this.picked.getId())) {
      this.picked = null;
      this.featureBox.replaceChildren(el("p", { class: "muted", text: "No feature picked." }));
    } else if (this.picked) {
      this.pick(source.getFeatureById(this.picked.getId()));
    }
  }

  // One step (edits, undo or redo), then what it changed drawn again.
  edit(edits) {
    return this.enqueue(async () => {
      const answer = await postJson("/sessions/" + this.id + "/edits", { edits });
      await this.answered(answer);
    });
  }

  step(which) {
    return this.enqueue(async () => {
      const answer = await postJson("/sessions/" + this.id + "/" + which, {});
      await this.answered(answer);
    });
  }

  async answered(answer) {
    this.patch(answer);
    this.areas(answer.areas || []);
    const moved = (answer.moved || []).filter((m) => m.area > 0).map((m) =>
      (m.from || "nobody") + " → " + (m.to || "nobody") + " " + km2(m.area, this.units).toLocaleString("en", { maximumFractionDigits: 3 }) + (this.units === "m^2" ? " km²" : " " + this.units));
    const lines = answer.lines || {};
    const count = (x) => (x ? (x.added || []).length + (x.changed || []).length + (x.removed || []).length : 0);
    const changedLines = count(lines.boundaries) + count(lines.limits);
    this.message.replaceChildren(el("p", { text: (answer.cells ? answer.cells.owner_changed.toLocaleString("en") + " cells changed owner" : "") +
      (moved.length ? "; " + moved.join(", ") : "") + "; " + changedLines + (changedLines === 1 ? " line" : " lines") + " changed · " +
      ((answer.timings && answer.timings.server_s) || 0).toFixed(3) + " s on the server" }));
    await this.redrawRegions();
    this.stepLine.dataset.step = String(answer.step);
    this.stepLine.textContent = "Session " + this.id + " · step " + answer.step + (answer.undone ? " (undone)" : answer.redone ? " (redone)" : "") + ".";
  }

  // The area table: each owner's area now and its change since the session began, the regions'
  // when `list` has them, else the cells'.
  areas(list) {
    const unit = this.units === "m^2" ? "km²" : this.units.replace("^2", "²");
    const rows = list.map((a) => {
      const kind = a.area !== undefined ? "area" : "cells_area";
      const now = a[kind];
      const first = this.start_areas.get(a.label);
      const start = first && first[kind] !== undefined ? first[kind] : 0;
      const change = km2(now - start, this.units);
      return el("tr", { "data-owner": a.label, "data-area": String(now), "data-change": String(now - start) },
        el("td", { class: "owner", text: a.label }),
        el("td", { class: "num", text: km2(now, this.units).toLocaleString("en", { maximumFractionDigits: 1 }) }),
        el("td", { class: "num change", text: a.label + " " + signed(change) + " " + unit }));
    });
    this.table.replaceChildren(el("table", { class: "legend" }, el("caption", { text: "Areas and their change since the start" }),
      el("thead", {}, el("tr", {}, el("th", { scope: "col", text: "Owner" }), el("th", { scope: "col", text: "Area (" + unit + ")" }),
        el("th", { scope: "col", text: "Change" }))), el("tbody", {}, ...rows)));
  }

  // A feature dragged on the map: the vertex it moved, or its whole new geometry.
  dragged(feature) {
    const id = String(feature.getId());
    const after = this.format.writeGeometryObject(feature.getGeometry());
    const moved = movedVertex(this.geometry.get(id), after);
    if (moved) this.edit([{ op: "move-vertex", feature: id, path: moved.path, to: moved.to }]);
    else this.edit([{ op: "replace", feature: id, geometry: after }]);
  }

  // A feature picked by a click: its owner, weight and reach, to change or remove it.
  pick(feature) {
    const previous = this.picked;
    this.picked = feature;
    if (previous) previous.changed();
    feature.changed();
    const id = String(feature.getId());
    const p = feature.getProperties();
    const weight = el("input", { id: "pick-weight", type: "number", step: "any", min: "0", value: p.weight !== undefined ? String(p.weight) : "1" });
    const reach = el("input", { id: "pick-reach", type: "number", step: "any", min: "0", value: p.reach !== undefined && p.reach !== null ? String(p.reach) : "" });
    const apply = el("button", { type: "button", id: "pick-apply", text: "Apply", onclick: () => {
      const properties = { weight: Number(weight.value) };
      if (reach.value.trim() !== "") properties.reach = Number(reach.value);
      this.edit([{ op: "set", feature: id, properties }]);
    } });
    const remove = el("button", { type: "button", id: "pick-remove", text: "Remove this feature", onclick: () => this.edit([{ op: "remove", feature: id }]) });
    this.featureBox.replaceChildren(el("h3", { text: "Feature " + id + " · " + (p.kind || "") + " of " + (p.owner || "") }),
      el("div", { class: "field" }, el("label", { for: "pick-weight", text: "Weight" }), weight),
      el("div", { class: "field" }, el("label", { for: "pick-reach", text: "Reach (distance units; empty: none)" }), reach),
      el("div", { class: "buttons" }, apply, remove));
    // The keyboard move starts from the feature's first vertex.
    const g = this.geometry.get(id);
    if (g) {
      let path = [], at = g.coordinates;
      if (g.type === "MultiPoint") { path = [0]; at = at[0]; }
      else if (g.type === "LineString") { path = [0, 0]; at = at[0]; }
      else if (g.type === "MultiLineString") { path = [0, 0]; at = at[0][0]; }
      else if (g.type === "Polygon") { path = [0, 0, 0]; at = at[0][0]; }
      else if (g.type === "MultiPolygon") { path = [0, 0, 0]; at = at[0][0][0]; }
      const set = (fid, v) => { this.moveForm.querySelector("#" + fid).value = v; };
      set("move-feature", id);
      set("move-path", path.join(", "));
      set("move-x", String(at[0]));
      set("move-y", String(at[1]));
    }
  }

  // Leaves the mode (a new job was run): the map as it was, the session deleted.
  stop() {
    if (this.modify) this.view.map.removeInteraction(this.modify);
    if (this.clicker) this.view.map.un("singleclick", this.clicker.listener);
    this.view.setLayer("edit", null);
    this.view.setLayer("regions", null);
    if (this.id) fetch("/sessions/" + this.id, { method: "DELETE", headers: headers("application/json") }).catch(() => {});
    this.section.hidden = true;
  }

  save() {
    return this.enqueue(async () => {
      const status = await postJson("/sessions/" + this.id + "/jobs", { outputs: this.request.saveOutputs }, { Prefer: "respond-async" });
      this.message.replaceChildren(el("p", {}, "Saved as job ", el("a", { id: "edit-saved", href: "/jobs/" + status.jobID + "?f=html", text: status.jobID }),
        " (its files equal a fresh job's on the edited seeds)."));
    });
  }
}

