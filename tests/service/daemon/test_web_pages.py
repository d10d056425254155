"""The daemon's HTML pages (issue 34) in a real browser: headless Chromium driven by Selenium.

    /usr/bin/python3 tests/service/daemon/test_web_pages.py RVORONOI ARTEFACT_DIR

Against daemons this test starts (without and with a bearer token):
  1. content negotiation: JSON stays the default (curl's */*), a browser's Accept or ?f=html gets
     the page, with a Content-Security-Policy that forbids inline scripts; result files are never
     pages; assets are served, and nothing outside web_dir;
  2. every resource renders in the browser: landing, conformance, processes, the process
     description (inputs with types and defaults), the job list, a job's status, its results (with
     sizes, the report's owners and the preview image); no JavaScript errors in the console;
  3. hostile data: a job whose owner label is <script>...</script> and an <img onerror> label:
     the labels show as text, nothing runs (no alert, no injected element), and the page's
     markup holds no element from them;
  4. with authentication on (a principal of auth.principals, by its token's SHA-256), the page
     asks for the token (a labelled field), the header says "Not signed in", then renders with
     it: the header says "Signed in as alice (user)", the job list has a Principal column with
     her name and a job's page names her among its facts; Forget signs out; the token never
     appears in a URL. Without authentication the header says "Open server". A deprecated
     plaintext token (auth.tokens) signs in as its principal "token-<8 hex of its SHA-256>"; an
     identity provider's JWT (RS256, its key in auth.jwt's key set) typed in the same field signs
     in as its subject, the header giving its expiry;
  5. accessibility basics: every form field has a label, every image an alt text.
Screenshots of each page go to ARTEFACT_DIR.
"""
import base64
import hashlib
import json
import os
import sys
import tempfile
import time
import urllib.parse

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from daemon_harness import Daemon  # noqa: E402

from selenium import webdriver  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

RVORONOI, ARTEFACTS = sys.argv[1], sys.argv[2]
FAILURES = []
HOSTILE = "<script>alert(1)</script>"
HOSTILE_IMG = '<img src=x onerror="document.title=\'pwned\'">'


def check(condition, what):
    if not condition:
        FAILURES.append(what)
        print("FAIL:", what, flush=True)
    return condition


def job_body(labels):
    pts = [(labels[0], 401000, 6101000), (labels[1], 409000, 6109000), (labels[0], 403000, 6108000)]
    fc = {"type": "FeatureCollection",
          "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}},
          "features": [{"type": "Feature", "properties": {"state": s}, "geometry": {"type": "Point", "coordinates": [x, y]}}
                       for s, x, y in pts]}
    return {"inputs": {"seeds": {"value": fc, "mediaType": "application/geo+json"}, "ownerField": "state",
                       "resolution": 100, "extent": [400000, 6100000, 410000, 6110000]},
            "outputs": {"ownership": {}, "boundaries": {}, "regions": {}, "preview": {}, "report": {}}}


def run_job(d, labels, headers=None):
    h = {"Prefer": "respond-async"}
    h.update(headers or {})
    status, _, doc = d.json("POST", "/processes/voronoi/execution", job_body(labels), h)
    check(status == 201, "job accepted: %s %s" % (status, doc))
    job = doc["jobID"]
    end = time.time() + 60
    while time.time() < end:
        _, _, s = d.json("GET", "/jobs/" + job, headers=headers)
        if s["status"] in ("successful", "failed"):
            check(s["status"] == "successful", "job finished: %s" % s)
            return job
        time.sleep(0.05)
    check(False, "job finished in time")
    return job


def browser():
    o = webdriver.ChromeOptions()
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1280,1000"):
        o.add_argument(a)
    o.binary_location = "/usr/bin/chromium"
    o.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    from selenium.webdriver.chrome.service import Service
    return webdriver.Chrome(service=Service(executable_path="/usr/bin/chromedriver"), options=o)


def settle(drv, text=None, seconds=20):
    """Waits until the page is drawn (aria-busy false) and, when given, shows `text`."""
    WebDriverWait(drv, seconds).until(
        lambda d: d.find_element(By.ID, "content").get_attribute("aria-busy") == "false"
        and (text is None or text in d.find_element(By.ID, "content").text))


def session(drv, state, seconds=20):
    """Waits until the header's session line is in `state` (data-session); returns its text."""
    WebDriverWait(drv, seconds).until(
        lambda d: d.find_element(By.ID, "session").get_attribute("data-session") == state)
    return drv.find_element(By.ID, "session").text


def console_errors(drv):
    return [e for e in drv.get_log("browser") if e["level"] == "SEVERE"]


def accessibility(drv, where):
    for inp in drv.find_elements(By.CSS_SELECTOR, "input, select, textarea"):
        ident = inp.get_attribute("id")
        labelled = ident and drv.find_elements(By.CSS_SELECTOR, "label[for='%s']" % ident)
        check(labelled or inp.get_attribute("aria-label"), "%s: a form field without a label" % where)
    for img in drv.find_elements(By.TAG_NAME, "img"):
        check(bool(img.get_attribute("alt")), "%s: an image without alt text" % where)


def shot(drv, name):
    drv.save_screenshot(os.path.join(ARTEFACTS, name + ".png"))


def negotiation(d):
    status, h, body = d.request("GET", "/processes", headers={"Accept": "*/*"})
    check(status == 200 and h["content-type"].startswith("application/json"), "JSON stays the default")
    browser_accept = "text/html,application/xhtml+xml,application/xml;q=0.9,image/avif,image/webp,*/*;q=0.8"
    for path, headers in (("/processes", {"Accept": browser_accept}), ("/jobs?f=html", {})):
        status, h, body = d.request("GET", path, headers=headers)
        check(status == 200 and h["content-type"].startswith("text/html"), "%s is a page" % path)
        csp = h.get("content-security-policy", "")
        check("script-src 'self'" in csp and "unsafe-inline" not in csp, "%s: CSP forbids inline scripts" % path)
        check(b"<script>" not in body.replace(b'<script type="module" src="/static/pages.js"></script>', b""),
              "%s: the page has no inline script" % path)
    status, h, _ = d.request("GET", "/jobs?f=json", headers={"Accept": browser_accept})
    check(h["content-type"].startswith("application/json"), "f=json wins over Accept")
    status, h, _ = d.request("GET", "/static/pages.js")
    check(status == 200 and h["content-type"].startswith("text/javascript"), "the script is served")
    for bad in ("/static/../page.html", "/static/%2e%2e%2fjobs.sqlite", "/static/.hidden", "/static/"):
        status, _, _ = d.request("GET", bad)
        check(status == 404, "%s is not served (%d)" % (bad, status))


def pages(drv, base, job, hostile):
    visits = [("/?f=html", "rvoronoi", "landing"), ("/conformance?f=html", "ogcapi-processes-1", "conformance"),
              ("/processes?f=html", "voronoi", "processes"), ("/processes/voronoi?f=html", "resolution", "process"),
              ("/jobs?f=html", job, "jobs"), ("/jobs/%s?f=html" % job, "successful", "job"),
              ("/jobs/%s/results?f=html" % job, "Download ownership", "results"), ("/api?f=html", "openapi", "api")]
    for path, text, name in visits:
        drv.get(base + path)
        settle(drv, text)
        line = session(drv, "open")
        check(line == "Open server", "%s: the header says the server is open: %r" % (path, line))
        shot(drv, name)
        errors = console_errors(drv)
        check(not errors, "%s: console errors %s" % (path, errors))
        accessibility(drv, path)
    # The process description lists its inputs with types and defaults.
    drv.get(base + "/processes/voronoi?f=html")
    settle(drv, "resolution")
    rows = {r.find_elements(By.TAG_NAME, "td")[0].text: [c.text for c in r.find_elements(By.TAG_NAME, "td")]
            for r in drv.find_elements(By.CSS_SELECTOR, "table tbody tr") if r.find_elements(By.TAG_NAME, "td")}
    check("metric" in rows and "auto" in rows["metric"][3], "the metric input shows its default: %s" % rows.get("metric"))
    check("resolution" in rows and "number" in rows["resolution"][2], "the resolution input shows its type")
    # Without authentication every job is the anonymous principal's.
    drv.get(base + "/jobs?f=html")
    settle(drv, job)
    check(job_row(drv, job).get("Principal") == "anonymous", "the job list names the anonymous principal")
    # Results: sizes, the owners of the report (as text), the preview with its alt text.
    drv.get(base + "/jobs/%s/results?f=html" % job)
    settle(drv, "Owners")
    text = drv.find_element(By.ID, "content").text
    check(" KB" in text or " B" in text, "results show sizes")
    check("Sea area (m^2)" in text, "the owners' areas from the regions")
    for label in hostile:
        check(label in text, "the label %r shows as text" % label)
    injected = drv.execute_script(
        "return document.querySelectorAll('#content [onerror], #content script, #content img:not(.preview)').length")
    check(injected == 0, "no element made from the labels (%d found)" % injected)
    html = drv.find_element(By.ID, "content").get_attribute("innerHTML")
    check("&lt;script&gt;alert(1)&lt;/script&gt;" in html, "the script label is escaped text in the markup")
    check(drv.title != "pwned", "the hostile image ran nothing")
    check(len(drv.find_elements(By.CSS_SELECTOR, "#content script")) == 0, "no script element injected")
    imgs = drv.find_elements(By.CSS_SELECTOR, "img.preview")
    check(len(imgs) == 1 and drv.execute_script("return arguments[0].naturalWidth", imgs[0]) > 0,
          "the preview image is drawn")
    try:
        alert = drv.switch_to.alert
        check(False, "an alert opened: %s" % alert.text)
    except Exception:
        pass


def session_pages(drv, d, base, hostile):
    """The session resources (issue 54) as pages: list, status with the owners' areas, the
    deliverables kept, the features and a deliverable as tables; labels stay text."""
    body = job_body(hostile)
    body["outputs"] = {"boundaries": {}, "regions": {}}
    status, _, doc = d.json("POST", "/sessions", body)
    if not check(status == 201, "session created: %s %s" % (status, doc)):
        return
    sid = doc["sessionID"]
    visits = [("/sessions?f=html", sid, "sessions"), ("/sessions/%s?f=html" % sid, "Areas", "session"),
              ("/sessions/%s/deliverables?f=html" % sid, "boundaries", "session-deliverables"),
              ("/sessions/%s/features?f=html" % sid, "3 features", "session-features"),
              ("/sessions/%s/deliverables/regions?f=html" % sid, "2 features", "session-regions")]
    for path, text, name in visits:
        drv.get(base + path)
        settle(drv, text)
        shot(drv, name)
        errors = console_errors(drv)
        check(not errors, "%s: console errors %s" % (path, errors))
        accessibility(drv, path)
        injected = drv.execute_script("return document.querySelectorAll('#content [onerror], #content script').length")
        check(injected == 0, "%s: an element made from the labels" % path)
    drv.get(base + "/sessions/%s?f=html" % sid)
    settle(drv, "Areas")
    text = drv.find_element(By.ID, "content").text
    for label in hostile:
        check(label in text, "the session's area table shows the label %r as text" % label)
    check("Region" in text and "Cells' area" in text, "the session's areas: cells' and regions'")


def job_row(drv, job):
    """The job list's row of `job`: {column header: cell text}."""
    head = [th.text for th in drv.find_elements(By.CSS_SELECTOR, "#content table thead th")]
    for r in drv.find_elements(By.CSS_SELECTOR, "#content table tbody tr"):
        cells = [td.text for td in r.find_elements(By.TAG_NAME, "td")]
        if cells and cells[0] == job:
            return dict(zip(head, cells))
    return {}


def with_token(drv, d, base, token, name="alice"):
    drv.get(base + "/jobs?f=html")
    settle(drv, "Access token")
    check(session(drv, "signed-out") == "Not signed in", "the header says nobody is signed in")
    shot(drv, "token-form")
    accessibility(drv, "token form")
    check("401" in drv.find_element(By.ID, "content").text, "the page says why it needs a token")
    # The one error so far is the refused request itself (Chromium logs every 4xx response).
    before = console_errors(drv)
    check(all("401" in e["message"] for e in before), "only the 401 before the token: %s" % before)
    field = drv.find_element(By.ID, "token")
    field.send_keys(token)
    drv.find_element(By.CSS_SELECTOR, "form.token button").click()
    settle(drv, "Jobs")
    line = session(drv, "signed-in")
    check(line.startswith("Signed in as %s (user)" % name) and "Forget" in line, "the header says who: %r" % line)
    shot(drv, "signed-in")
    job = run_job(d, ["A", "B"], {"Authorization": "Bearer " + token})
    drv.get(base + "/jobs?f=html")
    settle(drv, job)
    row = job_row(drv, job)
    check(row.get("Principal") == name, "the job list's Principal column names %s: %s" % (name, row))
    check(session(drv, "signed-in").startswith("Signed in as %s (user)" % name), "the header, on the next page")
    drv.get(base + "/jobs/%s?f=html" % job)
    settle(drv, "successful")
    facts = {r.find_element(By.TAG_NAME, "th").text: r.find_element(By.TAG_NAME, "td").text
             for r in drv.find_elements(By.CSS_SELECTOR, "table.facts tr")}
    check(facts.get("Principal") == name, "the job's page names its principal: %s" % facts)
    drv.get(base + "/me?f=html")
    settle(drv, "Signed in as " + name)
    text = drv.find_element(By.ID, "content").text
    check("user" in text and "a token of this server" in text, "/me as a page: %r" % text)
    drv.get(base + "/jobs/%s/results?f=html" % job)
    settle(drv, "Owners")
    shot(drv, "results-with-token")
    check(token not in drv.current_url, "the token is not in the URL")
    errors = console_errors(drv)
    check(not errors, "no console errors with a token: %s" % errors)
    status, _, _ = d.request("GET", "/jobs/%s/results/ownership" % job)
    check(status == 401, "the files themselves still need the token")
    # A file linked from the job's page is fetched with the token (a download, not a navigation
    # that would carry none): the fetch succeeds and the page stays.
    drv.get(base + "/jobs/%s?f=html" % job)
    settle(drv, "successful")
    drv.execute_script("""
      window.__fetched = [];
      const real = window.fetch;
      window.fetch = (u, o) => real(u, o).then((r) => { window.__fetched.push([String(u), r.status]); return r; });""")
    buttons = [b for b in drv.find_elements(By.CSS_SELECTOR, "button.link") if b.text == "ownership"]
    check(len(buttons) == 1, "the ownership link is a download button")
    if buttons:
        buttons[0].click()
        WebDriverWait(drv, 20).until(lambda x: x.execute_script("return window.__fetched.length") > 0)
        fetched = drv.execute_script("return window.__fetched")
        check(fetched[0][0].endswith("/results/ownership") and fetched[0][1] == 200,
              "the download was fetched with the token: %s" % fetched)
        check("/jobs/%s" % job in drv.current_url, "the page stayed")
    # Forget: the token is dropped, the header says so and the page asks for one again.
    drv.find_element(By.CSS_SELECTOR, "#session button").click()
    check(session(drv, "signed-out") == "Not signed in", "after Forget, nobody is signed in")
    settle(drv, "Access token")
    # A wrong token: refused, the header says so (and keeps Forget to drop it).
    drv.find_element(By.ID, "token").send_keys("not-" + token)
    drv.find_element(By.CSS_SELECTOR, "form.token button").click()
    line = session(drv, "signed-out")
    check(line.startswith("Not signed in") and "Forget" in line, "a refused token signs nobody in: %r" % line)
    check(drv.find_element(By.ID, "session").get_attribute("title") == "the bearer token is not valid for this server",
          "the header tells why the token was refused")
    drv.execute_script("sessionStorage.clear()")
    drv.get_log("browser")  # the refused requests are logged by the browser


def sign_in(drv, base, token):
    """A fresh tab's session: the job list, the token typed into its form."""
    drv.execute_script("sessionStorage.clear()")
    drv.get(base + "/jobs?f=html")
    settle(drv, "Access token")
    drv.find_element(By.ID, "token").send_keys(token)
    drv.find_element(By.CSS_SELECTOR, "form.token button").click()
    settle(drv, "Jobs")


def deprecated_token(drv, d, base, token):
    """A plaintext token of auth.tokens: its principal is named after the token's SHA-256."""
    sign_in(drv, base, token)
    name = "token-" + hashlib.sha256(token.encode()).hexdigest()[:8]
    line = session(drv, "signed-in")
    check(line.startswith("Signed in as %s (user)" % name), "a deprecated token signs in as %s: %r" % (name, line))
    drv.execute_script("sessionStorage.clear()")


def b64url(data):
    return base64.urlsafe_b64encode(data).rstrip(b"=").decode()


def jwt_daemon(binary, tmp, subject):
    """A daemon that takes an identity provider's JWTs (an RSA key made here, its JWKS in a file)
    and such a token for `subject`, valid ten minutes: (daemon, token)."""
    from cryptography.hazmat.primitives import hashes
    from cryptography.hazmat.primitives.asymmetric import padding, rsa
    key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
    pub = key.public_key().public_numbers()
    number = lambda n: b64url(n.to_bytes((n.bit_length() + 7) // 8, "big"))  # noqa: E731
    jwks = os.path.join(tmp, "jwks.json")
    with open(jwks, "w") as f:
        json.dump({"keys": [{"kty": "RSA", "kid": "k1", "use": "sig", "alg": "RS256", "n": number(pub.n), "e": number(pub.e)}]}, f)
    issuer, now = "https://idp.example.org/realms/test", int(time.time())
    header = {"alg": "RS256", "typ": "JWT", "kid": "k1"}
    claims = {"iss": issuer, "aud": "rvoronoi", "sub": subject, "iat": now, "exp": now + 600}
    signing_input = b64url(json.dumps(header).encode()) + "." + b64url(json.dumps(claims).encode())
    signature = key.sign(signing_input.encode(), padding.PKCS1v15(), hashes.SHA256())
    config = {"auth": {"jwt": {"issuer": issuer, "audience": "rvoronoi", "jwks_file": jwks}}}
    return Daemon([binary, "serve"], os.path.join(tmp, "closed-jwt"), config), signing_input + "." + b64url(signature)


def with_jwt(drv, base, token, subject):
    sign_in(drv, base, token)
    line = session(drv, "signed-in")
    check(line.startswith("Signed in as %s (user)" % subject), "a JWT signs in as its subject: %r" % line)
    title = drv.find_element(By.ID, "session").get_attribute("title")
    check(title.startswith("The token expires "), "the header gives the JWT's expiry: %r" % title)
    drv.get(base + "/me?f=html")
    settle(drv, "Signed in as " + subject)
    text = drv.find_element(By.ID, "content").text
    check("identity provider" in text and "Expires" in text, "/me of a JWT as a page: %r" % text)
    shot(drv, "me-jwt")
    drv.execute_script("sessionStorage.clear()")


def closed_daemon(binary, tmp, config=None, name="alice", deprecated=False):
    """A daemon (rvoronoi `binary`) under tmp that requires a fresh bearer token: (daemon, token).

    The token is the principal `name`'s (a user of auth.principals, configured by its SHA-256),
    or, `deprecated`, a plaintext token of auth.tokens."""
    token = "s3cret-" + os.urandom(6).hex()
    if deprecated:
        auth = {"tokens": [token]}
    else:
        auth = {"principals": [{"name": name, "role": "user", "token_sha256": hashlib.sha256(token.encode()).hexdigest()}]}
    directory = os.path.join(tmp, "closed-deprecated" if deprecated else "closed")
    return Daemon([binary, "serve"], directory, dict(config or {}, auth=auth)), token


def outcome(what, artefacts):
    """The exit status of a browser test, said in one line."""
    if FAILURES:
        print("%d failure(s)" % len(FAILURES))
        return 1
    print(what + ": all checks passed; screenshots in", artefacts)
    return 0


def main():
    os.makedirs(ARTEFACTS, exist_ok=True)
    drv = browser()
    try:
        with tempfile.TemporaryDirectory() as tmp:
            d = Daemon([RVORONOI, "serve"], os.path.join(tmp, "open"), {})
            try:
                negotiation(d)
                labels = [HOSTILE, HOSTILE_IMG]
                job = run_job(d, labels)
                pages(drv, "http://127.0.0.1:%d" % d.port, job, labels)
                session_pages(drv, d, "http://127.0.0.1:%d" % d.port, labels)
            finally:
                d.stop()
            d, token = closed_daemon(RVORONOI, tmp)
            try:
                with_token(drv, d, "http://127.0.0.1:%d" % d.port, token)
            finally:
                d.stop()
            d, token = closed_daemon(RVORONOI, tmp, deprecated=True)
            try:
                deprecated_token(drv, d, "http://127.0.0.1:%d" % d.port, token)
            finally:
                d.stop()
            d, token = jwt_daemon(RVORONOI, tmp, "carol")
            try:
                with_jwt(drv, "http://127.0.0.1:%d" % d.port, token, "carol")
            finally:
                d.stop()
    finally:
        drv.quit()
    return outcome("web pages", ARTEFACTS)


if __name__ == "__main__":
    sys.exit(main())
