"""A process description (OGC API - Processes) read into Processing parameters, and the values a
run is given written back as the execute request's inputs.

Each input id becomes its name in upper snake case (ownerField -> OWNER_FIELD), each output id the
same (nearestFeature -> NEAREST_FEATURE). The types follow the JSON schema and the rvoronoi
extensions that OGC clients ignore (the option table's, rv/options.hpp):
  - x-rvoronoi-upload: layers (several when "multiple"), sent as GeoPackage with their CRS;
  - x-rvoronoi-field-of: a field of that layer input;
  - x-rvoronoi-crs: a CRS; an array of four numbers or a bbox object: an extent with its CRS;
  - numbers with their range and default, booleans, enumerations;
  - lengths and distance lists (a value with its unit) as text ("1mm", "12nmi,24nmi").
Anything else becomes a plain text parameter with its description, and a warning in the log: an
input the server adds later still appears, without a change to the plugin.
"""
import re

from qgis.core import (
    Qgis,
    QgsMessageLog,
    QgsProcessing,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterCrs,
    QgsProcessingParameterEnum,
    QgsProcessingParameterExtent,
    QgsProcessingParameterField,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterMultipleLayers,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterDestination,
    QgsProcessingParameterString,
    QgsProcessingParameterVectorDestination,
    QgsProcessingParameterVectorLayer,
)

LOG_TAG = "rvoronoi"

GEOMETRY_TYPES = {"polygon": QgsProcessing.TypeVectorPolygon, "line": QgsProcessing.TypeVectorLine,
                  "point": QgsProcessing.TypeVectorPoint}
UNIT_WORDS = {"m": "metres", "crs": "units of the grid's CRS", "distance": "the distance units",
              "cells": "cells"}


def layers_field_wrapper():
    """The dialog's widget for a field of a several-layers input (SEEDS): QGIS 3.22's own field
    widget takes its fields from one layer only and stays empty under a list of layers. This one
    offers the first layer's fields (an owner field must be in every layer; the job says which
    layer lacks it). None where Processing's GUI is not there."""
    try:
        from processing.gui.wrappers import DIALOG_BATCH, DIALOG_STANDARD, TableFieldWidgetWrapper
    except ImportError:  # pragma: no cover
        return None

    class LayersFieldWrapper(TableFieldWidgetWrapper):
        @staticmethod
        def _first(value):
            if isinstance(value, (list, tuple)):
                return value[0] if value else None
            return value

        def postInitialize(self, wrappers):  # noqa: N802 (QGIS's name)
            for wrapper in wrappers:
                if wrapper.parameterDefinition().name() == self.parameterDefinition().parentLayerParameterName():
                    if self.dialogType in (DIALOG_STANDARD, DIALOG_BATCH):
                        self.setLayer(self._first(wrapper.parameterValue()))
                        wrapper.widgetValueHasChanged.connect(self.parentValueChanged)
                    break

        def parentValueChanged(self, wrapper):  # noqa: N802
            self.setLayer(self._first(wrapper.parameterValue()))

    return LayersFieldWrapper


def extension(path):
    """A destination's extension, lower case ("" for none)."""
    return path.rsplit(".", 1)[-1].lower() if "." in path else ""


def media_types(entry):
    """The media types a described output can be written as."""
    schema = entry.get("schema", {})
    return [v.get("contentMediaType", "") for v in schema.get("oneOf", [schema])]


def upper_snake(name):
    """ownerField -> OWNER_FIELD; describe-seeds -> DESCRIBE_SEEDS."""
    return re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "_", name).replace("-", "_").upper()


def kind_of(schema):
    """What a schema asks for: upload, field, crs, extent, number, integer, boolean, enum, text,
    or None (a type this plugin does not know)."""
    if "x-rvoronoi-upload" in schema:
        return "upload"
    if "x-rvoronoi-field-of" in schema:
        return "field"
    if schema.get("x-rvoronoi-crs"):
        return "crs"
    if "enum" in schema:
        return "enum"
    variants = schema.get("oneOf", [])
    if any(v.get("type") == "array" and v.get("minItems") == 4 and v.get("maxItems") == 4 for v in variants):
        return "extent"
    if variants and any(v.get("type") == "string" for v in variants):
        return "text"  # a length or a distance with its unit
    if schema.get("type") == "array":
        return "list"
    return {"number": "number", "integer": "integer", "boolean": "boolean", "string": "text"}.get(schema.get("type"))


def help_text(entry):
    schema = entry.get("schema", {})
    text = entry.get("description", "")
    unit = schema.get("x-rvoronoi-unit")
    if unit:
        text += f" (in {UNIT_WORDS.get(unit, unit)})"
    return text


def input_parameter(input_id, entry, description=None):
    """The Processing parameter of one described input (`description`: the whole process's, to see
    what a field's layer input is)."""
    schema = entry.get("schema", {})
    name = upper_snake(input_id)
    title = entry.get("title") or input_id
    optional = entry.get("minOccurs", 0) == 0
    default = schema.get("default")
    kind = kind_of(schema)
    if kind == "upload":
        upload = schema["x-rvoronoi-upload"]
        geometry = GEOMETRY_TYPES.get(upload.get("geometry"), QgsProcessing.TypeVectorAnyGeometry)
        if upload.get("multiple"):
            p = QgsProcessingParameterMultipleLayers(name, title, geometry, None, optional)
        else:
            p = QgsProcessingParameterVectorLayer(name, title, [geometry], None, optional)
    elif kind == "field":
        parent = schema["x-rvoronoi-field-of"]
        p = QgsProcessingParameterField(name, title, None, upper_snake(parent), QgsProcessingParameterField.Any, False,
                                        optional)
        parent_schema = ((description or {}).get("inputs", {}).get(parent, {}) or {}).get("schema", {})
        wrapper = layers_field_wrapper() if parent_schema.get("x-rvoronoi-upload", {}).get("multiple") else None
    elif kind == "crs":
        p = QgsProcessingParameterCrs(name, title, None, optional)
    elif kind == "extent":
        p = QgsProcessingParameterExtent(name, title, None, optional)
    elif kind in ("number", "integer"):
        number_type = QgsProcessingParameterNumber.Integer if kind == "integer" else QgsProcessingParameterNumber.Double
        p = QgsProcessingParameterNumber(name, title, number_type, default, optional)
        if "minimum" in schema:
            p.setMinimum(schema["minimum"])
        if "maximum" in schema:
            p.setMaximum(schema["maximum"])
    elif kind == "boolean":
        p = QgsProcessingParameterBoolean(name, title, bool(default) if default is not None else False, True)
    elif kind == "enum":
        options = [str(v) for v in schema["enum"]]
        p = QgsProcessingParameterEnum(name, title, options, False, default if default in options else None,
                                       optional, True)
    else:
        if kind is None:
            QgsMessageLog.logMessage(f"input '{input_id}' has a type this plugin does not know; "
                                     "it is offered as text, sent as written", LOG_TAG, Qgis.Warning)
        p = QgsProcessingParameterString(name, title, default if isinstance(default, str) else None, False, optional)
    p.setHelp(help_text(entry))
    metadata = {"rvoronoi": {"input": input_id, "kind": kind or "unknown"}}
    if kind == "field" and wrapper is not None:
        metadata["widget_wrapper"] = {"class": wrapper}
    p.setMetadata(metadata)
    return p


def output_parameter(output_id, entry):
    """The destination of one described output: a raster, a vector file or a file."""
    types = media_types(entry)
    name = upper_snake(output_id)
    title = entry.get("title") or output_id
    # Only the ownership raster is made by default: the others when a destination is given.
    by_default = output_id == "ownership"
    if any(t.startswith("image/tiff") for t in types):
        p = QgsProcessingParameterRasterDestination(name, title, None, not by_default, by_default)
    elif any("geo+json" in t or "geopackage" in t for t in types):
        p = QgsProcessingParameterVectorDestination(name, title, QgsProcessing.TypeVectorAnyGeometry, None, True, False)
    else:
        filters = []
        if any(t == "application/json" for t in types):
            filters.append("JSON (*.json)")
        if any(t == "text/csv" for t in types):
            filters.append("CSV (*.csv)")
        if any(t == "image/png" for t in types):
            filters.append("PNG (*.png)")
        p = QgsProcessingParameterFileDestination(name, title, ";;".join(filters), None, True, False)
    p.setHelp(entry.get("description", ""))
    p.setMetadata({"rvoronoi": {"output": output_id, "media": types}})
    return p


def media_type_for(output_id, entry, path):
    """The media type to ask the server for, from the destination's extension ("" = the default)."""
    types = media_types(entry)
    ext = extension(path)
    wanted = {"gpkg": "geopackage", "geojson": "geo+json", "json": "json", "csv": "text/csv", "png": "image/png",
              "tif": "image/tiff", "tiff": "image/tiff"}.get(ext)
    for t in types:
        if wanted and wanted in t:
            return t
    return ""
