// The map: the seeds, the owner raster (the job's Cloud Optimized GeoTIFF read in the browser
// with range requests, decoded with its compression and predictor by geotiff.js), the boundary,
// tripoint and limit layers, a scale bar, and the read-out of one cell's owner and distance
// from the rasters themselves. Everything is drawn in the grid's CRS: the rasters are never
// warped, so a cell on screen is a cell of the file.

import OlMap from "ol/Map.js";
import View from "ol/View.js";
import Projection from "ol/proj/Projection.js";
import { addProjection, get as getProjection } from "ol/proj.js";
import VectorLayer from "ol/layer/Vector.js";
import VectorSource from "ol/source/Vector.js";
import GeoJSON from "ol/format/GeoJSON.js";
import WebGLTileLayer from "ol/layer/WebGLTile.js";
import GeoTIFF from "ol/source/GeoTIFF.js";
import ScaleLine from "ol/control/ScaleLine.js";
import { defaults as defaultControls } from "ol/control/defaults.js";
import { Style, Fill, Stroke, Circle as CircleStyle } from "ol/style.js";
import { fromUrl } from "geotiff";
import { headers } from "../client.js";

// The quicklook's land colour (service/include/rv/preview.hpp, kLandColour, as RGB).
export const LAND = "#decdaa";
const LAND_EDGE = "#7d6a48";
const LINE = "#1b2631";
// WebGL palettes are textures: a bounded number of colours. Codes beyond repeat the palette.
const PALETTE_SIZE = 4096;

// The map projection for a CRS described by describe-seeds ({code, geographic, metresPerUnit}).
// Longitude/latitude on WGS 84 and Web Mercator are OpenLayers' own; any other CRS is a plain
// projection of its units: nothing is reprojected, so no transformation is needed.
export function projectionFor(crs, bbox) {
  if (crs.code === "EPSG:4326" || crs.code === "OGC:CRS84") return getProjection("EPSG:4326");
  if (crs.code === "EPSG:3857") return getProjection("EPSG:3857");
  const code = "rvoronoi:" + (crs.code || crs.name || "grid");
  const existing = getProjection(code);
  if (existing) return existing;
  const p = new Projection({
    code,
    units: crs.geographic ? "degrees" : "m",
    metersPerUnit: crs.geographic ? undefined : crs.metresPerUnit || 1,
    extent: bbox || undefined,
  });
  addProjection(p);
  return p;
}

function seedStyle(colourOf) {
  const cache = new Map();
  return (feature) => {
    const type = feature.getGeometry() ? feature.getGeometry().getType() : "";
    const colour = colourOf(feature) || "#566573";
    const key = type + colour;
    if (!cache.has(key)) {
      if (type.includes("Polygon")) {
        cache.set(key, new Style({ fill: new Fill({ color: LAND }), stroke: new Stroke({ color: LAND_EDGE, width: 1 }) }));
      } else if (type.includes("Line")) {
        cache.set(key, new Style({ stroke: new Stroke({ color: colour, width: 2 }) }));
      } else {
        cache.set(key, new Style({ image: new CircleStyle({ radius: 4, fill: new Fill({ color: colour }), stroke: new Stroke({ color: "#fff", width: 1.5 }) }) }));
      }
    }
    return cache.get(key);
  };
}

const STYLES = {
  boundaries: new Style({ stroke: new Stroke({ color: LINE, width: 2.2 }) }),
  limits: new Style({ stroke: new Stroke({ color: "#1a5276", width: 1.6, lineDash: [8, 6] }) }),
  tripoints: new Style({ image: new CircleStyle({ radius: 6, fill: new Fill({ color: "#c0392b" }), stroke: new Stroke({ color: "#fff", width: 2 }) }) }),
};

export class MapView {
  constructor(target) {
    this.scale = new ScaleLine({ bar: true, text: true, minWidth: 140 });
    this.map = new OlMap({
      target,
      controls: defaultControls().extend([this.scale]),
      layers: [],
      view: new View({ projection: "EPSG:4326", center: [0, 0], zoom: 2 }),
    });
    this.layers = {};
    this.rasters = null;
  }

  // A new view in `projection`, showing `bbox`.
  frame(projection, bbox) {
    this.projection = projection;
    const view = new View({ projection, showFullExtent: true, constrainResolution: false });
    this.map.setView(view);
    if (bbox && bbox[2] > bbox[0] && bbox[3] > bbox[1]) view.fit(bbox, { padding: [24, 24, 24, 24] });
    else view.setCenter([0, 0]);
  }

  setLayer(name, layer, z) {
    if (this.layers[name]) this.map.removeLayer(this.layers[name]);
    delete this.layers[name];
    if (!layer) return;
    layer.setZIndex(z);
    this.layers[name] = layer;
    this.map.addLayer(layer);
  }

  showSeeds(collection, colourOf) {
    if (!collection) return this.setLayer("seeds", null);
    const format = new GeoJSON({ dataProjection: this.projection, featureProjection: this.projection });
    const source = new VectorSource({ features: format.readFeatures(collection) });
    this.setLayer("seeds", new VectorLayer({ source, style: seedStyle(colourOf) }), 2);
  }

  showVector(name, collection) {
    if (!collection) return this.setLayer(name, null);
    const format = new GeoJSON({ dataProjection: this.projection, featureProjection: this.projection });
    const source = new VectorSource({ features: format.readFeatures(collection) });
    const z = { limits: 3, boundaries: 4, tripoints: 5 }[name];
    this.setLayer(name, new VectorLayer({ source, style: STYLES[name] }), z);
  }

  // A job's or session's regions (one multipolygon per owner, GeoJSON with its "label") filled in
  // the owners' colours, `colourOf(label)`, under the lines: the owners' sea as the deliverable
  // draws it (a live session's, where no raster of the current state exists).
  showRegions(collection, colourOf) {
    if (!collection) return this.setLayer("regions", null);
    const format = new GeoJSON({ dataProjection: this.projection, featureProjection: this.projection });
    const source = new VectorSource({ features: format.readFeatures(collection) });
    const cache = new Map();
    const style = (f) => {
      const colour = colourOf(String(f.get("label"))) || "#999999";
      if (!cache.has(colour)) {
        const rgb = [1, 3, 5].map((i) => parseInt(colour.slice(i, i + 2), 16));
        cache.set(colour, new Style({ fill: new Fill({ color: [...rgb, 0.75] }), stroke: new Stroke({ color: colour, width: 0.5 }) }));
      }
      return cache.get(colour);
    };
    this.setLayer("regions", new VectorLayer({ source, style }), 1);
  }

  // The owner raster at `url` in the colours `colours` (code -> CSS colour); `distanceUrl` for
  // the cell read-out.
  showOwners(url, distanceUrl, colours) {
    const palette = ["rgba(0,0,0,0)"];
    for (let code = 1; code < Math.min(PALETTE_SIZE, colours.length); ++code) palette.push(colours[code] || "#999");
    const source = new GeoTIFF({
      sources: [{ url, nodata: 0 }],
      sourceOptions: { headers: headers("*/*"), allowFullFile: false },
      normalize: false,
      interpolate: false,
      projection: this.projection,
    });
    const index = ["+", ["%", ["-", ["band", 1], 1], PALETTE_SIZE - 1], 1];
    const layer = new WebGLTileLayer({ source, style: { color: ["palette", index, palette] } });
    this.setLayer("owners", layer, 1);
    this.rasters = { owners: fromUrl(url, { headers: headers("*/*") }), distance: fromUrl(distanceUrl, { headers: headers("*/*") }) };
    return new Promise((resolve, reject) => {
      const check = () => {
        const state = source.getState();
        if (state === "ready") resolve();
        else if (state === "error") reject(source.getError ? source.getError() : new Error("the owner raster could not be read"));
      };
      source.on("change", check);
      check();
    });
  }

  // The cell under map coordinate [x, y] in the rasters: {row, col, code, distance} (null
  // outside the grid), read from the files at full resolution.
  async cellAt([x, y]) {
    if (!this.rasters) return null;
    const [owners, distances] = await Promise.all([this.rasters.owners, this.rasters.distance]);
    const image = await owners.getImage(0);
    const [ox, oy] = image.getOrigin();
    const [rx, ry] = image.getResolution();
    const col = Math.floor((x - ox) / rx);
    const row = Math.floor((y - oy) / ry);
    if (col < 0 || row < 0 || col >= image.getWidth() || row >= image.getHeight()) return null;
    const window = [col, row, col + 1, row + 1];
    const [code, dist] = await Promise.all([
      image.readRasters({ window }),
      distances.getImage(0).then((d) => d.readRasters({ window })),
    ]);
    return { row, col, code: Number(code[0][0]), distance: Number(dist[0][0]), x: ox + (col + 0.5) * rx, y: oy + (row + 0.5) * ry };
  }
}
