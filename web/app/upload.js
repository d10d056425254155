// A seed file from the person's disk to an upload the daemon accepts (the "seeds" input of both
// processes), and its description by the process describe-seeds.

import { headers, Problem } from "../client.js";

// Extension -> media type of the uploads the daemon reads (openapi.yaml, qualifiedSeeds).
const KINDS = [
  [/\.(geo)?json$/i, "application/geo+json"],
  [/\.gpkg$/i, "application/geopackage+sqlite3"],
  [/\.zip$/i, "application/zip"],
  [/\.fgb$/i, "application/flatgeobuf"],
];

export const ACCEPT = ".geojson,.json,.gpkg,.zip,.fgb";

function base64(bytes) {
  // In slices: String.fromCharCode takes a bounded number of arguments.
  let text = "";
  for (let i = 0; i < bytes.length; i += 0x8000) text += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(text);
}

// The "seeds" input value for a File: GeoJSON as its text, the binary formats in base64.
export async function seedInput(file) {
  const kind = KINDS.find(([re]) => re.test(file.name));
  if (!kind) {
    throw new Problem(0, {
      title: "Not a seed file this page reads",
      detail: "“" + file.name + "” is not GeoJSON (.geojson, .json), GeoPackage (.gpkg), a zipped Shapefile (.zip) or FlatGeobuf (.fgb).",
    });
  }
  const media = kind[1];
  if (media === "application/geo+json") return { value: await file.text(), mediaType: media };
  return { value: base64(new Uint8Array(await file.arrayBuffer())), mediaType: media, encoding: "base64" };
}

export async function postJson(url, body, extra = {}) {
  const r = await fetch(url, {
    method: "POST",
    headers: { ...headers("application/json"), "Content-Type": "application/json", ...extra },
    body: JSON.stringify(body),
  });
  const type = r.headers.get("Content-Type") || "";
  const answer = type.includes("json") ? await r.json() : { detail: await r.text() };
  if (!r.ok) throw new Problem(r.status, answer);
  return answer;
}

// The description of the seeds (layers, fields, CRS, box) with their features in `crs` (the
// first layer's when empty). Data too large to draw is described without its features.
export async function describeSeeds(seeds, crs) {
  const inputs = { seeds, features: true };
  if (crs) inputs.crs = crs;
  try {
    return await postJson("/processes/describe-seeds/execution", { inputs });
  } catch (e) {
    // Over the server's limit for drawing (too-large): described again without the features.
    if (!(e instanceof Problem) || !String(e.body.type || "").endsWith("/too-large")) throw e;
    inputs.features = false;
    const d = await postJson("/processes/describe-seeds/execution", { inputs });
    d.warnings = [...(d.warnings || []), "The seeds are too large to draw here; they are described, and computed, all the same."];
    return d;
  }
}
