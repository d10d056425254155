"""The rvoronoi server as the plugin talks to it: JSON requests through QGIS's own network stack
(its proxies and TLS settings), the bearer token from QGIS's authentication database, and every
answer that is not what was asked for turned into one clear ServerError.

The token: QGIS 3.22 has no authentication method that sends a bearer header, so the
configuration named by `authcfg` is a Basic one whose password is the token. It is read from the
authentication database for each request and set as "Authorization: Bearer" on the plugin's own
requests only; it never goes into a URL, a project, a setting or a log.
"""
import json
import os

from qgis.core import (QgsApplication, QgsAuthMethodConfig, QgsBlockingNetworkRequest, QgsNetworkAccessManager,
                       QgsSettings)
from qgis.PyQt.QtCore import QByteArray, QEventLoop, QUrl
from qgis.PyQt.QtNetwork import QNetworkReply, QNetworkRequest

SETTINGS_URL = "rvoronoi/server_url"
SETTINGS_AUTHCFG = "rvoronoi/authcfg"
SETTINGS_MODE = "rvoronoi/mode"  # "auto" (the server when set, else local), "server", "local"


class ServerError(Exception):
    """A request that did not give what it asked for: unreachable, refused, or not the API."""

    def __init__(self, message, status=None, problem=None):
        super().__init__(message)
        self.status = status
        self.problem = problem or {}


def setting(key, env, default=""):
    """A setting of the provider: the environment first (qgis_process runs have no settings dialog),
    then QGIS's settings."""
    value = os.environ.get(env)
    if value:
        return value
    return QgsSettings().value(key, default) or default


def server_url():
    return setting(SETTINGS_URL, "RVORONOI_URL").rstrip("/")


def mode():
    return setting(SETTINGS_MODE, "RVORONOI_MODE", "auto")


def token_of(authcfg):
    """The token held as the password of the authentication configuration `authcfg` ("" = none)."""
    if not authcfg:
        return ""
    manager = QgsApplication.authManager()
    config = QgsAuthMethodConfig()
    if not manager.loadAuthenticationConfig(authcfg, config, True) or not config.isValid(True):
        raise ServerError(f"the authentication configuration '{authcfg}' cannot be read (is the master password set?)")
    token = config.config("password") or ""
    if not token:
        raise ServerError(f"the authentication configuration '{authcfg}' holds no token (its password)")
    return token


def problem_text(problem, status):
    """A problem+json in one line: its title and detail."""
    title = problem.get("title") or f"HTTP {status}"
    detail = problem.get("detail") or ""
    return f"{title}: {detail}" if detail else title


class Client:
    """Requests to one server. Not thread-safe: an algorithm run makes its own."""

    def __init__(self, url=None, authcfg=None, feedback=None):
        self.url = (url if url is not None else server_url()).rstrip("/")
        if not self.url:
            raise ServerError("no rvoronoi server is configured: set its URL in the Processing options "
                              "(Providers > rvoronoi) or RVORONOI_URL")
        self.token = token_of(authcfg if authcfg is not None else setting(SETTINGS_AUTHCFG, "RVORONOI_AUTHCFG"))
        self.feedback = feedback

    def _request(self, path, accept):
        request = QNetworkRequest(QUrl(self.url + path))
        request.setRawHeader(b"Accept", accept.encode())
        if self.token:
            request.setRawHeader(b"Authorization", b"Bearer " + self.token.encode())
        return request

    def _send(self, method, path, body=None, headers=None, accept="application/json"):
        request = self._request(path, accept)
        for name, value in (headers or {}).items():
            request.setRawHeader(name.encode(), value.encode())
        blocking = QgsBlockingNetworkRequest()
        if method == "GET":
            blocking.get(request, True, self.feedback)
        elif method == "POST":
            request.setHeader(QNetworkRequest.ContentTypeHeader, "application/json")
            blocking.post(request, QByteArray(json.dumps(body).encode()), True, self.feedback)
        elif method == "DELETE":
            blocking.deleteResource(request, self.feedback)
        else:
            raise ValueError(method)
        reply = blocking.reply()
        status = reply.attribute(QNetworkRequest.HttpStatusCodeAttribute)
        if status is None:
            # No HTTP answer at all: the connection failed. Qt's message, never the request.
            raise ServerError(f"the rvoronoi server at {self.url} cannot be reached: {blocking.errorMessage()}")
        headers = {bytes(k).decode("latin-1").lower(): bytes(reply.rawHeader(k)).decode("latin-1")
                   for k in reply.rawHeaderList()}
        return int(status), headers, bytes(reply.content())

    def call(self, method, path, body=None, headers=None, ok=(200,)):
        """A JSON request; returns (status, headers, document). A problem+json, or an answer that is
        not JSON where JSON was asked for, raises ServerError."""
        status, h, payload = self._send(method, path, body, headers)
        if status in ok and status == 304:
            return status, h, None
        if "json" not in h.get("content-type", ""):
            raise ServerError(f"{self.url}{path} answered HTTP {status} with {h.get('content-type') or 'no content type'},"
                              " not the rvoronoi API: is the URL right?", status)
        try:
            doc = json.loads(payload) if payload else None
        except ValueError:
            raise ServerError(f"{self.url}{path} answered HTTP {status} with text that is not JSON", status)
        if status not in ok:
            problem = doc if isinstance(doc, dict) else {}
            raise ServerError(problem_text(problem, status), status, problem)
        return status, h, doc

    def download(self, path, destination):
        """Writes the bytes of `path` (a result file) to `destination` as they arrive, so that a
        result of any size costs QGIS a network buffer, not its size in memory. They go to
        `destination`.part, renamed when whole: a cut connection, a short answer or a cancel (the
        feedback's) raises ServerError and leaves no file. Returns the number of bytes."""
        request = self._request(path, "*/*")
        # Not into QGIS's network cache either: a result is downloaded once, and may be large.
        request.setAttribute(QNetworkRequest.CacheLoadControlAttribute, QNetworkRequest.AlwaysNetwork)
        request.setAttribute(QNetworkRequest.CacheSaveControlAttribute, False)
        reply = QgsNetworkAccessManager.instance().get(request)
        # Without a bound Qt reads the socket as fast as it can into the reply, whatever the slot
        # below has taken: the whole file in memory again on a fast link. With it, Qt stops reading
        # when 1 MiB waits, and TCP slows the sender.
        reply.setReadBufferSize(1 << 20)
        part = destination + ".part"
        written = 0
        try:
            with open(part, "wb") as out:
                def take():
                    nonlocal written
                    # A refusal (problem+json, small) is read whole once finished.
                    if reply.attribute(QNetworkRequest.HttpStatusCodeAttribute) == 200:
                        data = bytes(reply.readAll())
                        out.write(data)
                        written += len(data)

                loop = QEventLoop()
                reply.readyRead.connect(take)
                reply.finished.connect(loop.quit)
                cancel = self.feedback.canceled if self.feedback is not None else None
                if cancel is not None:
                    cancel.connect(reply.abort)
                try:
                    if not reply.isFinished():
                        loop.exec_()
                finally:
                    if cancel is not None:
                        cancel.disconnect(reply.abort)
                take()
            status = reply.attribute(QNetworkRequest.HttpStatusCodeAttribute)
            if self.feedback is not None and self.feedback.isCanceled():
                raise ServerError(f"the download of {path} was cancelled")
            if status is None:
                raise ServerError(f"the rvoronoi server at {self.url} cannot be reached: {reply.errorString()}")
            if int(status) != 200:
                payload = bytes(reply.readAll())
                try:
                    problem = json.loads(payload)
                except ValueError:
                    problem = {}
                raise ServerError(problem_text(problem, int(status)), int(status), problem)
            length = reply.header(QNetworkRequest.ContentLengthHeader)
            if reply.error() != QNetworkReply.NoError or (length is not None and int(length) != written):
                raise ServerError(f"the download of {path} from {self.url} broke off after {written} of "
                                  f"{length if length is not None else 'unknown'} bytes: {reply.errorString()}")
            os.replace(part, destination)
            return written
        finally:
            reply.deleteLater()
            if os.path.exists(part):
                os.remove(part)
