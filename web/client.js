// What every page of the daemon shares (the resource pages, pages.js, and the map page,
// app/main.js): building DOM from text only, requests that carry the person's token, the
// server's problem+json shown in plain words, downloads fetched with the token.
//
// Everything a server or an upload says goes into text nodes (textContent), never into markup.
// The token is kept in this tab's sessionStorage, sent as "Authorization: Bearer" on every
// request a page makes (downloads and the map's raster reads included), never put in a URL.

export const TOKEN_KEY = "rvoronoi-token";

// ---- DOM helpers: text only -------------------------------------------------------------

export function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null) continue;
    if (k === "class") e.className = v;
    else if (k === "text") e.textContent = String(v);
    else if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
    else e.setAttribute(k, String(v));
  }
  for (const c of children) if (c !== null && c !== undefined) e.append(c instanceof Node ? c : String(c));
  return e;
}

export function table(headers, rows, caption) {
  const t = el("table");
  if (caption) t.append(el("caption", { class: "muted", text: caption }));
  t.append(el("thead", {}, el("tr", {}, ...headers.map((h) => el("th", { scope: "col", text: h })))));
  const body = el("tbody");
  for (const r of rows) body.append(el("tr", {}, ...r.map((c) => el("td", {}, c ?? ""))));
  t.append(body);
  return t;
}

// Name / value rows: the names are row headers.
export function facts(rows) {
  const body = el("tbody");
  for (const [name, value] of rows) body.append(el("tr", {}, el("th", { scope: "row", text: name }), el("td", {}, value ?? "")));
  return el("table", { class: "facts" }, body);
}

// ---- Requests ---------------------------------------------------------------------------

export function token() {
  return sessionStorage.getItem(TOKEN_KEY) || "";
}

export function headers(accept) {
  const h = { Accept: accept };
  if (token()) h.Authorization = "Bearer " + token();
  return h;
}

export class Problem extends Error {
  constructor(status, body) {
    super((body && (body.detail || body.title)) || "HTTP " + status);
    this.status = status;
    this.body = body || {};
  }
}

export async function getJson(url) {
  const u = new URL(url, location.href);
  u.searchParams.delete("f");
  const r = await fetch(u, { headers: headers("application/json") });
  const type = r.headers.get("Content-Type") || "";
  const body = type.includes("json") ? await r.json() : await r.text();
  if (!r.ok) throw new Problem(r.status, typeof body === "object" ? body : { detail: body });
  return body;
}

// ---- Problems and the token ---------------------------------------------------------------

// `onToken` runs once a token was typed (the page draws itself again).
export function problemView(p, onToken) {
  const b = p.body;
  const box = el("section", { class: "problem", role: "alert" },
    el("h1", { text: b.title || "Request failed" }),
    el("p", { text: b.detail || p.message }),
    el("p", { class: "muted", text: "HTTP " + p.status + (b.type ? " · " + b.type : "") }));
  if (p.status === 401) box.append(tokenForm(onToken));
  return box;
}

export function tokenForm(onToken) {
  const input = el("input", { id: "token", name: "token", type: "password", autocomplete: "off", required: "" });
  const form = el("form", { class: "token" },
    el("label", { for: "token", text: "Access token (given by the administrator of this server)" }),
    input,
    el("button", { type: "submit", text: "Use this token" }));
  form.addEventListener("submit", (ev) => {
    ev.preventDefault();
    sessionStorage.setItem(TOKEN_KEY, input.value.trim());
    onToken();
  });
  return form;
}

// The header's token line: "Token set" and a button that forgets it, then runs `onForget`.
export function sessionBar(onForget) {
  const bar = document.getElementById("session");
  if (!bar) return;
  bar.replaceChildren();
  if (token()) {
    bar.append("Token set ",
      el("button", { type: "button", text: "Forget", onclick: () => { sessionStorage.removeItem(TOKEN_KEY); onForget(); } }));
  }
}

// ---- Files ----------------------------------------------------------------------------

export function humanBytes(n) {
  if (n === null || n === undefined || isNaN(n)) return "";
  const units = ["B", "KB", "MB", "GB", "TB"];
  let i = 0;
  while (n >= 1000 && i < units.length - 1) { n /= 1000; ++i; }
  return (i ? n.toFixed(1) : String(n)) + " " + units[i];
}

export async function download(href, name) {
  const r = await fetch(href, { headers: headers("*/*") });
  if (!r.ok) throw new Problem(r.status, await r.json().catch(() => ({})));
  saveBlob(await r.blob(), name);
}

// Offers `blob` to the person as a file called `name`.
export function saveBlob(blob, name) {
  const url = URL.createObjectURL(blob);
  const a = el("a", { href: url, download: name });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
}

