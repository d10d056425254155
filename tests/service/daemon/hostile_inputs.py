"""Hostile seed uploads, built as bytes, for tests/service/daemon/test_hostile.py and for the fuzz
corpora (tools/make-hostile-corpus.py writes small ones into tests/fuzz/corpus).

Each builder returns the bytes of one file as an attacker would upload it. GeoPackages are
written with GDAL (python3-gdal) and then altered with sqlite3, so that what GDAL later reads is
exactly the hostile part. Only Debian's python3, python3-gdal and the standard library.
"""
import os
import random
import sqlite3
import struct
import tempfile
import zipfile
import zlib

from osgeo import gdal, ogr, osr

gdal.UseExceptions()

POINTS = [(500000.0, 6000000.0), (501000.0, 6000000.0), (500500.0, 6001000.0)]


def _read(path):
    with open(path, "rb") as f:
        return f.read()


def _gpkg_path(directory, field="state", values=(b"A", b"B", b"C")):
    """A GeoPackage of three points in EPSG:32633 with one text field; returns its path."""
    path = os.path.join(directory, "seeds.gpkg")
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(path)
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(32633)
    layer = ds.CreateLayer("seeds", srs, ogr.wkbPoint)
    layer.CreateField(ogr.FieldDefn(field, ogr.OFTString))
    for (x, y), _ in zip(POINTS, values):
        f = ogr.Feature(layer.GetLayerDefn())
        f.SetField(field, "x")
        f.SetGeometry(ogr.CreateGeometryFromWkt(f"POINT({x} {y})"))
        layer.CreateFeature(f)
    ds = None
    con = sqlite3.connect(path)
    # The GeoPackage triggers call spatial functions Python's sqlite3 does not have; updating an
    # attribute column fires none that matter, but SQLite resolves them when it prepares.
    for name in ("ST_IsEmpty", "ST_MinX", "ST_MaxX", "ST_MinY", "ST_MaxY"):
        con.create_function(name, 1, lambda blob: 0)
    for fid, value in enumerate(values, start=1):
        con.execute(f'UPDATE seeds SET "{field}" = CAST(? AS TEXT) WHERE fid = ?', (value, fid))
    con.commit()
    con.close()
    return path


def _rewrite_schema(path, table, transform):
    """Rewrites the CREATE statement of `table` in sqlite_master with `transform(bytes)`."""
    con = sqlite3.connect(path)
    con.text_factory = bytes
    sql = con.execute("SELECT sql FROM sqlite_master WHERE name = ?", (table,)).fetchone()[0]
    con.execute("PRAGMA writable_schema = 1")
    con.execute("UPDATE sqlite_master SET sql = ? WHERE name = ?", (transform(sql), table))
    con.commit()
    con.close()


def gpkg_owner_values(values):
    """Owner field "state" with the given raw byte values (e.g. b"A\\x80")."""
    with tempfile.TemporaryDirectory() as d:
        return _read(_gpkg_path(d, values=values))


def gpkg_column_named(raw_name):
    """A column whose name is raw bytes (e.g. b"o\\x80"); its values are A, B, C."""
    with tempfile.TemporaryDirectory() as d:
        path = _gpkg_path(d, field="ox")
        _rewrite_schema(path, "seeds", lambda sql: sql.replace(b'"ox"', b'"' + raw_name + b'"'))
        return _read(path)


def gpkg_broken_schema():
    """The table's schema SQL holds byte 0x80 where SQLite cannot parse it: opening the table
    fails and GDAL's message quotes the broken SQL."""
    with tempfile.TemporaryDirectory() as d:
        path = _gpkg_path(d)
        _rewrite_schema(path, "seeds", lambda sql: sql.replace(b'"state" TEXT)', b'"state" TEXT) \x80\xff'))
        return _read(path)


def gpkg_view_layer():
    """A layer that is a view generating rows without end (a recursive CTE): tiny file, endless
    features, unless the feature limit stops it."""
    with tempfile.TemporaryDirectory() as d:
        path = _gpkg_path(d)
        con = sqlite3.connect(path)
        con.execute("CREATE VIEW endless AS WITH RECURSIVE c(fid) AS (SELECT 1 UNION ALL SELECT fid + 1 FROM c) "
                    "SELECT c.fid AS fid, s.geom AS geom, s.state AS state FROM c, seeds s WHERE s.fid = 1")
        con.execute("INSERT INTO gpkg_contents (table_name, data_type, identifier, srs_id) "
                    "VALUES ('endless', 'features', 'endless', 32633)")
        con.execute("INSERT INTO gpkg_geometry_columns VALUES ('endless', 'geom', 'POINT', 32633, 0, 0)")
        con.commit()
        con.close()
        return _read(path)


def fgb(values=("A", "B", "C"), layer="seeds", field="state"):
    """A valid FlatGeobuf of the three points."""
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "seeds.fgb")
        ds = ogr.GetDriverByName("FlatGeobuf").CreateDataSource(path)
        srs = osr.SpatialReference()
        srs.ImportFromEPSG(32633)
        lyr = ds.CreateLayer(layer, srs, ogr.wkbPoint, ["SPATIAL_INDEX=NO"])
        lyr.CreateField(ogr.FieldDefn(field, ogr.OFTString))
        for (x, y), v in zip(POINTS, values):
            f = ogr.Feature(lyr.GetLayerDefn())
            f.SetField(field, v)
            f.SetGeometry(ogr.CreateGeometryFromWkt(f"POINT({x} {y})"))
            lyr.CreateFeature(f)
        ds = None
        return _read(path)


def fgb_with_raw_text(raw):
    """A FlatGeobuf whose layer name, field name and owner values are replaced, byte for byte,
    by `raw` (same length as "seeds"/"state": 5 bytes) - strings GDAL hands out unchecked."""
    assert len(raw) == 5
    data = fgb(values=("state", "state", "state"), layer="seeds", field="state")
    return data.replace(b"seeds", raw).replace(b"state", raw)


def fgb_mutants(count, seed=1):
    """`count` FlatGeobuf files with a few random bytes changed each (the magic kept)."""
    base = bytearray(fgb())
    rng = random.Random(seed)
    out = []
    for _ in range(count):
        m = bytearray(base)
        for _ in range(rng.randint(1, 8)):
            i = rng.randrange(8, len(m))
            m[i] = rng.choice([0x00, 0x80, 0xFF, 0xC3, 0x7F, rng.randrange(256)])
        out.append(bytes(m))
    return out


def _shp_header(shape_type, file_words, bbox=(0.0, 0.0, 0.0, 0.0)):
    return (struct.pack(">7i", 9994, 0, 0, 0, 0, 0, file_words) + struct.pack("<2i", 1000, shape_type) +
            struct.pack("<8d", bbox[0], bbox[1], bbox[2], bbox[3], 0, 0, 0, 0))


def _dbf_one_record():
    """A dBASE III file with one record of one character field "state" = "A"."""
    header = struct.pack("<BBBBIHH20x", 3, 126, 1, 1, 1, 32 + 32 + 1, 1 + 1)
    field = b"state".ljust(11, b"\0") + b"C" + b"\0" * 4 + bytes([1, 0]) + b"\0" * 14
    return header + field + b"\r" + b" A" + b"\x1a"


def _zipped_one_record_shapefile(name, shape_type, record_head, points):
    """A zipped Shapefile of one record: `record_head` (the record's fields before its points), then
    `points` points all at (0, 0). The .shp inflates to 16 bytes a point; the zip holds a few
    hundred bytes per megabyte of it."""
    content_bytes = len(record_head) + 16 * points
    shp_words = (100 + 8 + content_bytes) // 2
    shx = _shp_header(shape_type, (100 + 8) // 2) + struct.pack(">2i", 50, content_bytes // 2)
    with tempfile.SpooledTemporaryFile(max_size=1 << 20) as raw:
        with zipfile.ZipFile(raw, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as z:
            z.writestr(name + ".shx", shx)
            z.writestr(name + ".dbf", _dbf_one_record())
            z.writestr(name + ".prj", osr.SpatialReference(wkt=_utm33_wkt()).ExportToWkt())
            with z.open(name + ".shp", "w", force_zip64=True) as f:
                f.write(_shp_header(shape_type, shp_words))
                f.write(struct.pack(">2i", 1, content_bytes // 2))
                f.write(record_head)
                zeros = bytes(16 * 65536)
                left = points
                while left > 0:
                    n = min(left, 65536)
                    f.write(zeros[: 16 * n])
                    left -= n
        raw.seek(0)
        return raw.read()


def shapefile_multipoint_bomb(points=20_000_000):
    """A zipped Shapefile of one MultiPoint of `points` points all at (0, 0)."""
    return _zipped_one_record_shapefile("bomb", 8, struct.pack("<i4di", 8, 0.0, 0.0, 0.0, 0.0, points), points)


def shapefile_line_bomb(vertices=30_000_000):
    """A zipped Shapefile of one PolyLine of one part of `vertices` vertices all at (0, 0)."""
    head = struct.pack("<i4d3i", 3, 0.0, 0.0, 0.0, 0.0, 1, vertices, 0)  # one part, starting at vertex 0
    return _zipped_one_record_shapefile("line", 3, head, vertices)


def _utm33_wkt():
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(32633)
    return srs.ExportToWkt()


def zip_of_zeros(member_bytes, name="padding.bin"):
    """A zip whose one member is `member_bytes` zero bytes (deflate: about 1/1000 of it)."""
    with tempfile.SpooledTemporaryFile(max_size=1 << 20) as raw:
        with zipfile.ZipFile(raw, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as z:
            with z.open(name, "w", force_zip64=True) as f:
                block = bytes(1 << 20)
                left = member_bytes
                while left > 0:
                    f.write(block[: min(left, len(block))])
                    left -= min(left, len(block))
        raw.seek(0)
        return raw.read()


def zip_truncated():
    """A valid zipped Shapefile of three points, cut in the middle."""
    data = zipped_points()
    return data[: len(data) // 2]


def zip_random(seed=3, size=4096):
    """The zip magic followed by random bytes."""
    rng = random.Random(seed)
    return b"PK\x03\x04" + bytes(rng.randrange(256) for _ in range(size))


def zipped_points(values=("A", "B", "C"), raw_first=None):
    """A valid zipped Shapefile of the three points with owner field "state"; `raw_first`, when
    given, replaces the first value's bytes in the .dbf (e.g. b"\x80": not text in any encoding
    the .cpg names)."""
    if raw_first is not None:
        values = ("Q" * len(raw_first),) + tuple(values[1:])
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "pts.shp")
        ds = ogr.GetDriverByName("ESRI Shapefile").CreateDataSource(path)
        srs = osr.SpatialReference()
        srs.ImportFromEPSG(32633)
        lyr = ds.CreateLayer("pts", srs, ogr.wkbPoint)
        lyr.CreateField(ogr.FieldDefn("state", ogr.OFTString))
        for (x, y), v in zip(POINTS, values):
            f = ogr.Feature(lyr.GetLayerDefn())
            f.SetField("state", v)
            f.SetGeometry(ogr.CreateGeometryFromWkt(f"POINT({x} {y})"))
            lyr.CreateFeature(f)
        ds = None
        if raw_first is not None:
            dbf = _read(os.path.join(d, "pts.dbf"))
            with open(os.path.join(d, "pts.dbf"), "wb") as f:
                f.write(dbf.replace(b"Q" * len(raw_first), raw_first, 1))
        out = os.path.join(d, "pts.zip")
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
            for ext in ("shp", "shx", "dbf", "prj"):
                z.write(os.path.join(d, "pts." + ext), "pts." + ext)
        return _read(out)


def kml_with_raw_names(raw):
    """A KML document whose placemark names and a schema field carry raw bytes."""
    return (b'<?xml version="1.0" encoding="UTF-8"?><kml xmlns="http://www.opengis.net/kml/2.2"><Document>'
            b'<Placemark><name>' + raw + b'</name><Point><coordinates>10,55</coordinates></Point></Placemark>'
            b'<Placemark><name>B</name><Point><coordinates>11,55</coordinates></Point></Placemark>'
            b'</Document></kml>')


def geojson_with_raw_owner(raw):
    """GeoJSON text whose owner value holds raw bytes (not valid JSON text when they are not
    UTF-8: the CLI reads such files; the daemon's JSON body cannot carry them)."""
    return (b'{"type":"FeatureCollection","features":['
            b'{"type":"Feature","properties":{"state":"' + raw + b'"},"geometry":{"type":"Point","coordinates":[10,55]}},'
            b'{"type":"Feature","properties":{"state":"B"},"geometry":{"type":"Point","coordinates":[11,55]}}]}')


def crc_ok(data):
    """True when every member of a zip archive reads back with a correct CRC."""
    import io
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            return z.testzip() is None
    except (zipfile.BadZipFile, zlib.error):
        return False
