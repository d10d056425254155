#!/usr/bin/python3
"""Writes the hostile input classes of issues 28 and 50 (tests/service/daemon/hostile_inputs.py) into the seed
corpora of the fuzz targets: uploads of each format into tests/fuzz/corpus/fuzz_upload_<format>/,
whole execute requests into tests/fuzz/corpus/fuzz_execute/. Small enough for libFuzzer to
mutate: the bombs with fewer points and bytes than in the daemon's test, still over the fuzz
targets' limits (20 000 vertices, 8 MiB inflated). Run again after changing a builder; the files
are committed.

usage: tools/make-hostile-corpus.py
"""
import base64
import json
import os
import sys

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(root, "tests", "service", "daemon"))
import hostile_inputs as hi  # noqa: E402

corpus = {
    "gpkg": {
        "owner_invalid_utf8.gpkg": hi.gpkg_owner_values((b"A\x80", b"A", b"B")),
        "column_invalid_utf8.gpkg": hi.gpkg_column_named(b"o\x80"),
        "schema_invalid_utf8.gpkg": hi.gpkg_broken_schema(),
        "endless_view.gpkg": hi.gpkg_view_layer(),
    },
    "zip": {
        "points.zip": hi.zipped_points(),
        "points_invalid_utf8.zip": hi.zipped_points(raw_first=b"A\x80"),
        "multipoint_bomb.zip": hi.shapefile_multipoint_bomb(200_000),
        "line_bomb.zip": hi.shapefile_line_bomb(200_000),  # issue 50: one line of many vertices
        "inflates_16mib.zip": hi.zip_of_zeros(16 << 20),
        "truncated.zip": hi.zip_truncated(),
        "random.zip": hi.zip_random(),
    },
    "fgb": {
        "points.fgb": hi.fgb(),
        "names_invalid_utf8.fgb": hi.fgb_with_raw_text(b"s\x80\xffte"),
        **{f"mutant_{i}.fgb": m for i, m in enumerate(hi.fgb_mutants(4, seed=7))},
    },
    "kml": {
        "names_invalid_utf8.kml": hi.kml_with_raw_names(b"A\x80"),
        "points.kml": hi.kml_with_raw_names(b"A"),
    },
    "geojson": {
        "owner_invalid_utf8.geojson": hi.geojson_with_raw_owner(b"A\x80\xff"),
        "owner_backslash_x.geojson": hi.geojson_with_raw_owner(b"A\\\\x80"),
    },
}

for fmt, files in corpus.items():
    directory = os.path.join(root, "tests", "fuzz", "corpus", "fuzz_upload_" + fmt)
    os.makedirs(directory, exist_ok=True)
    for name, data in files.items():
        with open(os.path.join(directory, name), "wb") as f:
            f.write(data)
        print(f"{directory}/{name}: {len(data)} bytes")


def feature_collection(points):
    return {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"state": s}, "geometry": {"type": "Point", "coordinates": c}}
        for s, c in points]}


def upload(data, media):
    return {"value": base64.b64encode(data).decode(), "mediaType": media, "encoding": "base64"}


requests = {
    "long_crs": {"inputs": {"seeds": feature_collection([("A", [10, 55]), ("B", [11, 55])]), "resolution": 0.1,
                            "ownerField": "state", "crs": "PROJCS[" + "W" * 100000}},
    "huge_coordinates": {"inputs": {"seeds": feature_collection([("N", [1e308, 1e308]), ("S", [-1e308, -1e308])]),
                                    "resolution": 1000, "ownerField": "state"}},
    "both_poles": {"inputs": {"seeds": feature_collection([("N", [0, 90]), ("S", [10, -90])]), "resolution": 5,
                              "ownerField": "state"}},
    "zip_bomb_small": {"inputs": {"seeds": upload(hi.shapefile_multipoint_bomb(200_000), "application/zip"),
                                  "resolution": 100}},
    "gpkg_owner_invalid_utf8": {"inputs": {"seeds": upload(hi.gpkg_owner_values((b"A\x80", b"A", b"B")),
                                                           "application/geopackage+sqlite3"),
                                           "resolution": 100, "ownerField": "state"}},
    "truncated_zip_missing_field": {"inputs": {"seeds": upload(hi.zip_truncated(), "application/zip"),
                                               "resolution": 100, "ownerField": "nope"}},
}
directory = os.path.join(root, "tests", "fuzz", "corpus", "fuzz_execute")
for name, request in requests.items():
    text = json.dumps(request)
    with open(os.path.join(directory, name), "w") as f:
        f.write(text)
    print(f"{directory}/{name}: {len(text)} bytes")
