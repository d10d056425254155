"""The process descriptions the algorithms are made from, and their cache.

From a server: GET / (its version), GET /processes, then each /processes/{id} with the ETag kept
from last time (If-None-Match: a 304 keeps the cached one). The cache is a JSON file in the QGIS
profile, keyed by the server's URL, its version and each description's ETag. When the server
cannot be reached, the cached descriptions are served with a warning, so that saved models and
batch files still open.
"""
import json
import os

from qgis.core import Qgis, QgsApplication, QgsMessageLog

from .client import Client, ServerError

LOG_TAG = "rvoronoi"
PROCESSES = ("voronoi", "describe-seeds")


def cache_path():
    return os.path.join(QgsApplication.qgisSettingsDirPath(), "rvoronoi", "descriptions.json")


def read_cache():
    try:
        with open(cache_path()) as f:
            doc = json.load(f)
        return doc if isinstance(doc, dict) else {}
    except (OSError, ValueError):
        return {}


def write_cache(cache):
    path = cache_path()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(cache, f)
    os.replace(tmp, path)


def from_server(client=None):
    """{process id: description} of the configured server, refreshed through the cache; the
    cached ones (with a warning in the log) when it cannot be reached. Raises ServerError when it
    cannot be reached and nothing is cached for it."""
    cache = read_cache()
    try:
        client = client or Client()
    except ServerError as e:
        QgsMessageLog.logMessage(str(e), LOG_TAG, Qgis.Warning)
        return {}
    entry = cache.get(client.url, {})
    try:
        _, _, landing = client.call("GET", "/")
        version = landing.get("version", "")
        if entry.get("version") != version:
            entry = {"version": version, "processes": {}}
        _, _, listing = client.call("GET", "/processes")
        ids = [p["id"] for p in listing.get("processes", []) if p.get("id") in PROCESSES]
        kept = entry.get("processes", {})
        fresh = {}
        for pid in ids:
            old = kept.get(pid, {})
            headers = {"If-None-Match": old["etag"]} if old.get("etag") else {}
            status, h, doc = client.call("GET", f"/processes/{pid}", headers=headers, ok=(200, 304))
            if status == 304 and old.get("description"):
                fresh[pid] = old
            else:
                fresh[pid] = {"etag": h.get("etag", ""), "description": doc}
        entry["processes"] = fresh
        cache[client.url] = entry
        try:
            write_cache(cache)
        except OSError as e:
            QgsMessageLog.logMessage(f"cannot keep the process descriptions: {e}", LOG_TAG, Qgis.Warning)
    except ServerError as e:
        if not entry.get("processes"):
            QgsMessageLog.logMessage(f"{e}; no algorithms until it answers", LOG_TAG, Qgis.Critical)
            return {}
        QgsMessageLog.logMessage(f"{e}; serving the descriptions cached for version {entry.get('version')}",
                                 LOG_TAG, Qgis.Warning)
    return {pid: p["description"] for pid, p in entry.get("processes", {}).items() if p.get("description")}


def from_module():
    """{process id: description} of the local Python module, when it can be imported."""
    from . import module
    try:
        rvoronoi = module.load()
    except ImportError as e:
        QgsMessageLog.logMessage(f"the rvoronoi module cannot be loaded: {e}", LOG_TAG, Qgis.Warning)
        return {}
    if rvoronoi is None:
        return {}
    describe = getattr(rvoronoi, "process_description", None)
    if describe is None:
        QgsMessageLog.logMessage("the installed rvoronoi module is too old to describe its process",
                                 LOG_TAG, Qgis.Warning)
        return {}
    return {"voronoi": describe()}
