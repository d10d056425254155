"""Starting and talking to a daemon process for the Python tests of tests/service.

A Daemon runs `BINARY serve`-style arguments (--listen 127.0.0.1:0 --data-dir D --config C) and
learns its port from its "listening" event (a JSON line; what it logs before, e.g. an identity
provider's key set loaded, is kept in `log`). Its later stderr is
kept in memory (`log`) by a thread, so that a chatty daemon never blocks on a full pipe.
Only the standard library: http.client for requests.
"""
import http.client
import http.server
import json
import os
import signal
import ssl
import subprocess
import threading
import time


class Daemon:
    def __init__(self, argv, data_dir, config, env=None, preexec_fn=None):
        self.config_path = data_dir.rstrip("/") + ".config.json"
        with open(self.config_path, "w") as f:
            json.dump(config, f)
        full_env = dict(os.environ)
        full_env.update(env or {})
        self.proc = subprocess.Popen(
            argv + ["--listen", "127.0.0.1:0", "--data-dir", data_dir, "--config", self.config_path],
            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, env=full_env, preexec_fn=preexec_fn)
        self.log = []
        while True:
            first = self.proc.stderr.readline()
            try:
                self.startup = json.loads(first)
            except ValueError:
                self.proc.kill()
                raise RuntimeError(f"daemon did not start: {''.join(self.log)}{first!r} {self.proc.stderr.read()!r}")
            self.log.append(first)
            if self.startup.get("event") == "listening":
                break
        self.port = int(self.startup["address"].rsplit(":", 1)[1])
        self.pid = self.proc.pid
        self._reader = threading.Thread(target=self._drain, daemon=True)
        self._reader.start()

    def _drain(self):
        for line in self.proc.stderr:
            self.log.append(line)

    def kill9(self):
        """SIGKILL: no cleanup of any kind runs in the daemon."""
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(timeout=30)

    def stop(self, timeout=30):
        """SIGTERM, then the exit code (None if it had to be killed). On return `log` holds every
        line the daemon wrote: the reader has seen its stderr close."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                code = self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                code = None
        else:
            code = self.proc.returncode
        self._reader.join(timeout=10)
        return code

    def logged(self, condition, seconds=10.0):
        """Whether some line of the log meets `condition` within `seconds`. The log is read on a
        thread of its own, so a line written before a response may reach `log` after it."""
        end = time.time() + seconds
        while True:
            if any(condition(line) for line in list(self.log)):
                return True
            if time.time() >= end:
                return False
            time.sleep(0.05)

    def alive(self):
        return self.proc.poll() is None

    def rss_bytes(self):
        """Resident set size (VmRSS of /proc/PID/status) in bytes."""
        with open(f"/proc/{self.pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
        raise RuntimeError("no VmRSS")

    def request(self, method, path, body=None, headers=None, timeout=120):
        """One request on a fresh connection. Returns (status, headers dict lower-cased, bytes)."""
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=timeout)
        try:
            hdrs = dict(headers or {})
            data = None
            if body is not None:
                data = body if isinstance(body, bytes) else json.dumps(body).encode()
                hdrs.setdefault("Content-Type", "application/json")
            conn.request(method, path, body=data, headers=hdrs)
            r = conn.getresponse()
            payload = r.read()
            return r.status, {k.lower(): v for k, v in r.getheaders()}, payload
        finally:
            conn.close()

    def json(self, method, path, body=None, headers=None, timeout=120):
        status, h, payload = self.request(method, path, body, headers, timeout)
        try:
            return status, h, json.loads(payload) if payload else None
        except ValueError:
            return status, h, payload

    def wait_status(self, job, states, seconds=60):
        end = time.time() + seconds
        doc = None
        while time.time() < end:
            _, _, doc = self.json("GET", f"/jobs/{job}")
            if isinstance(doc, dict) and doc.get("status") in states:
                return doc
            time.sleep(0.02)
        raise AssertionError(f"job {job} did not reach {states}: {doc}")


def wait_for_file(path, seconds, proc=None):
    """Waits until `path` exists; False on timeout or when `proc` (a Popen) ended meanwhile."""
    end = time.time() + seconds
    while time.time() < end:
        if os.path.exists(path):
            return True
        if proc is not None and proc.poll() is not None:
            return False
        time.sleep(0.005)
    return False


class DocumentServer:
    """A local HTTP server of one document (`document`: bytes, or anything JSON can write; it may be
    swapped while serving), counting its GETs in `fetches` (their monotonic times in `fetch_times`); HTTPS with `tls` = (cert, key) PEM
    files. An identity provider's key set, a web server that is not the API, ..."""

    def __init__(self, document, content_type, tls=None):
        self.document = document
        self.fetches = 0
        self.fetch_times = []
        outer = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_GET(self):
                outer.fetch_times.append(time.monotonic())
                outer.fetches += 1
                doc = outer.document
                body = doc if isinstance(doc, bytes) else json.dumps(doc).encode()
                self.send_response(200)
                self.send_header("Content-Type", content_type)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args):
                pass

        self.httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        port = self.httpd.server_address[1]
        if tls:
            context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
            context.load_cert_chain(*tls)
            self.httpd.socket = context.wrap_socket(self.httpd.socket, server_side=True)
        self.url = f"{'https' if tls else 'http'}://{'localhost' if tls else '127.0.0.1'}:{port}"
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()

    def close(self):
        self.httpd.shutdown()
