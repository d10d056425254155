// What every page of the daemon shares (the resource pages, pages.js, and the map page,
// app/main.js): building DOM from text only, requests that carry the person's token, the
// server's problem+json shown in plain words, downloads fetched with the token.
//
// Everything a server or an upload says goes into text nodes (textContent), never into markup.
// The token (one the administrator gave, or an identity provider's JWT: both are bearer tokens)
// is kept in this tab's sessionStorage, sent as "Authorization: Bearer" on every request a page
// makes (downloads and the map's raster reads included), never put in a URL. The header says
// who that token signs in as (GET /me).

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

async function fetchJson(url) {
  const u = new URL(url, location.href);
  u.searchParams.delete("f");
  const r = await fetch(u, { headers: headers("application/json") });
  const type = r.headers.get("Content-Type") || "";
  const body = type.includes("json") ? await r.json() : await r.text();
  if (!r.ok) throw new Problem(r.status, typeof body === "object" ? body : { detail: body });
  return body;
}

export async function getJson(url) {
  try {
    return await fetchJson(url);
  } catch (e) {
    // The token stopped working meanwhile (a JWT expired, the administrator removed it): the
    // header, which said who it signed in as, asks again.
    if (e instanceof Problem && e.status === 401) sessionStale();
    throw e;
  }
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
    el("label", { for: "token", text: "Access token (given by the administrator of this server, or your identity provider's token)" }),
    input,
    el("button", { type: "submit", text: "Use this token" }));
  form.addEventListener("submit", (ev) => {
    ev.preventDefault();
    sessionStorage.setItem(TOKEN_KEY, input.value.trim());
    onToken();
  });
  return form;
}

// ---- Who is signed in ------------------------------------------------------------------------

// GET /me, asked once per token: a page that draws itself again (a job's page while it runs)
// does not ask again. { doc } or { problem }.
let who = { token: null, answer: null, onForget: null };

function whoAmI() {
  const t = token();
  if (who.token !== t || !who.answer) {
    const answer = fetchJson("/me").then((doc) => ({ doc }), (problem) => {
      // Only a refusal of the token is kept; anything else (a network error) is asked again.
      if (!(problem instanceof Problem && problem.status === 401) && who.answer === answer) who.answer = null;
      return { problem };
    });
    who = { ...who, token: t, answer };
  }
  return who.answer;
}

// A request was refused 401: when the header said "signed in", it asks /me again.
async function sessionStale() {
  const answer = who.answer;
  if (!answer || !(await answer).doc || who.answer !== answer) return;
  who.answer = null;
  if (who.onForget) sessionBar(who.onForget);
}

// The header's line: who the token signs in as ("Signed in as alice (user)", the name a link to
// /me) and a button that forgets the token, then runs `onForget`; "Not signed in" when the
// server refuses the token or needs one; "Open server" when it asks for none. data-session says
// which (signed-in, signed-out, open, unknown) for scripts and tests.
export async function sessionBar(onForget) {
  const bar = document.getElementById("session");
  if (!bar) return;
  who.onForget = onForget;
  const t = token();
  const { doc, problem } = await whoAmI();
  if (token() !== t) return;  // the token changed meanwhile: a later call draws the line
  const forget = () => el("button", { type: "button", text: "Forget", title: "Forget the token in this tab",
    onclick: () => { sessionStorage.removeItem(TOKEN_KEY); onForget(); } });
  const parts = [];
  let state;
  bar.removeAttribute("title");
  if (doc && doc.authentication === "none") {
    state = "open";
    parts.push(el("span", { class: "open", text: "Open server", title: "This server asks for no token: everyone using it sees every job." }));
  } else if (doc) {
    state = "signed-in";
    parts.push(el("span", { class: "who" }, "Signed in as ", el("a", { href: "/me?f=html", text: String(doc.name) }),
      " (" + String(doc.role) + ")"));
    if (doc.expires) bar.title = "The token expires " + new Date(doc.expires).toLocaleString();
  } else if (problem instanceof Problem && problem.status === 401) {
    state = "signed-out";
    parts.push(el("span", { class: "who", text: "Not signed in" }));
    if (t) bar.title = problem.body.detail || problem.message;  // why the token was refused
  } else {
    state = "unknown";  // /me could not be asked
    if (t) parts.push(el("span", { class: "who", text: "Token set" }));
  }
  if (t) parts.push(" ", forget());
  bar.replaceChildren(...parts);
  bar.dataset.session = state;
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

