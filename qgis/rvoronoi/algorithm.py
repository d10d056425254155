"""One Processing algorithm per described process (rvoronoi:voronoi, rvoronoi:describe-seeds),
its parameters made from the description (parameters.py), run on the server as an asynchronous
job: the layers uploaded as GeoPackage, progress and the status message into `feedback`,
cancelling dismisses the job, a problem+json becomes a QgsProcessingException with its title and
detail, and the results are downloaded into the destinations.
"""
import base64
import json
import os
import tempfile
import time

from qgis.core import (
    QgsCoordinateReferenceSystem,
    QgsProcessingAlgorithm,
    QgsProcessingException,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterRasterDestination,
    QgsProcessingParameterVectorDestination,
    QgsProject,
    QgsVectorFileWriter,
    QgsVectorLayer,
)

from .client import Client, ServerError
from .parameters import extension, input_parameter, media_type_for, output_parameter
from .styles import Styler

POLL_S = 0.25
VECTOR_OUTPUTS = ("boundaries", "tripoints", "limits", "regions")
# The stages' shares of the whole, as the daemon reports a job's progress.
STAGES = {"read": (0, 10), "compute": (10, 90), "validate": (50, 90), "write": (90, 99), "deliver": (90, 99)}


def overall_percent(stage, fraction):
    lo, hi = STAGES.get(stage, (0, 10))
    return lo + (hi - lo) * min(max(fraction, 0.0), 1.0)


def convert_vector(source, path, output_id):
    """A vector file written again in the format `path`'s extension names (Shapefile, ...)."""
    ext = extension(path)
    layer = QgsVectorLayer(source, output_id, "ogr")
    options = QgsVectorFileWriter.SaveVectorOptions()
    options.driverName = QgsVectorFileWriter.driverForExtension(ext) or "GPKG"
    result = QgsVectorFileWriter.writeAsVectorFormatV3(layer, path, QgsProject.instance().transformContext(), options)
    if result[0] != QgsVectorFileWriter.NoError:
        raise QgsProcessingException(f"{output_id}: cannot write {path}: {result[1]}")


def crs_text(crs):
    """A CRS as the server takes it: its authority code, else its WKT."""
    return crs.authid() or crs.toWkt(QgsCoordinateReferenceSystem.WKT_PREFERRED)


def geopackage_file(layer, directory, index):
    """`layer` (any vector layer QGIS opens, its filter as it stands) written as a GeoPackage with
    its CRS; returns the file's path."""
    path = os.path.join(directory, f"seeds_{index}.gpkg")
    options = QgsVectorFileWriter.SaveVectorOptions()
    options.driverName = "GPKG"
    options.layerName = layer.name() or f"layer_{index}"
    result = QgsVectorFileWriter.writeAsVectorFormatV3(layer, path, QgsProject.instance().transformContext(), options)
    if result[0] != QgsVectorFileWriter.NoError:
        raise QgsProcessingException(f"cannot write layer '{layer.name()}' as a GeoPackage: {result[1]}")
    return path


def geopackage_upload(layer, directory, index):
    """The layer as the execute request's qualified value: a base64 GeoPackage."""
    with open(geopackage_file(layer, directory, index), "rb") as f:
        data = base64.b64encode(f.read()).decode()
    return {"value": data, "mediaType": "application/geopackage+sqlite3", "encoding": "base64"}


class DescribedAlgorithm(QgsProcessingAlgorithm):
    def __init__(self, process_id, description, local=False):
        super().__init__()
        self.process_id = process_id
        self.description = description
        self.local = local  # run through the Python module in QGIS's own process

    # ---- What QGIS shows -------------------------------------------------------------------

    def name(self):
        return self.process_id

    def displayName(self):  # noqa: N802
        return self.description.get("title") or self.process_id

    def group(self):
        return "Delimitation"

    def groupId(self):  # noqa: N802
        return "delimitation"

    def shortHelpString(self):  # noqa: N802
        return self.description.get("description", "")

    def tags(self):
        return list(self.description.get("keywords", []))

    def createInstance(self):  # noqa: N802
        return DescribedAlgorithm(self.process_id, self.description, self.local)

    def initAlgorithm(self, config=None):  # noqa: N802
        for input_id, entry in self.description.get("inputs", {}).items():
            self.addParameter(input_parameter(input_id, entry, self.description))
        for output_id, entry in self.description.get("outputs", {}).items():
            self.addParameter(output_parameter(output_id, entry))

    # ---- A run --------------------------------------------------------------------------------

    def _inputs(self, parameters, context, feedback, directory, upload):
        """The execute request's inputs from the values given (only those given); each layer of an
        upload input becomes upload(layer, directory, name): a qualified value for the server, a
        path for the module."""
        inputs = {}
        grid_crs = None
        for p in self.parameterDefinitions():
            meta = p.metadata().get("rvoronoi", {})
            input_id, kind = meta.get("input"), meta.get("kind")
            if input_id is None or parameters.get(p.name()) in (None, "", []):
                continue
            name = p.name()
            if kind == "upload":
                if p.type() == "multilayer":
                    layers = self.parameterAsLayerList(parameters, name, context)
                else:
                    layers = [self.parameterAsVectorLayer(parameters, name, context)]
                layers = [layer for layer in layers if layer is not None]
                if not layers:
                    raise QgsProcessingException(f"{p.description()}: no vector layer could be opened")
                for layer in layers:
                    if not isinstance(layer, QgsVectorLayer):
                        raise QgsProcessingException(f"{p.description()}: '{layer.name()}' is not a vector layer")
                uploads = [upload(layer, directory, f"{input_id}_{i}") for i, layer in enumerate(layers)]
                feedback.pushInfo(f"{p.description()}: {len(uploads)} layer(s) as GeoPackage")
                inputs[input_id] = uploads if p.type() == "multilayer" else uploads[0]
            elif kind == "field":
                value = self.parameterAsString(parameters, name, context)
                if value:
                    inputs[input_id] = value
            elif kind == "crs":
                crs = self.parameterAsCrs(parameters, name, context)
                if crs.isValid():
                    grid_crs = crs
                    inputs[input_id] = crs_text(crs)
            elif kind == "enum":
                inputs[input_id] = self.parameterAsEnumString(parameters, name, context)
            elif kind == "boolean":
                inputs[input_id] = self.parameterAsBool(parameters, name, context)
            elif kind == "integer":
                inputs[input_id] = self.parameterAsInt(parameters, name, context)
            elif kind == "number":
                inputs[input_id] = self.parameterAsDouble(parameters, name, context)
            elif kind == "list":
                text = self.parameterAsString(parameters, name, context)
                inputs[input_id] = [item.strip() for item in text.split(",") if item.strip()]
            elif kind == "unknown":
                text = self.parameterAsString(parameters, name, context)
                try:
                    inputs[input_id] = json.loads(text)
                except ValueError:
                    inputs[input_id] = text
            elif kind != "extent":
                inputs[input_id] = self.parameterAsString(parameters, name, context)
        # The extent last: in the grid's CRS when one is given (the server wants them to agree),
        # else in its own, which then defines the grid's.
        for p in self.parameterDefinitions():
            meta = p.metadata().get("rvoronoi", {})
            if meta.get("kind") != "extent" or parameters.get(p.name()) in (None, ""):
                continue
            crs = grid_crs or self.parameterAsExtentCrs(parameters, p.name(), context)
            box = self.parameterAsExtent(parameters, p.name(), context, crs)
            extent = {"bbox": [box.xMinimum(), box.yMinimum(), box.xMaximum(), box.yMaximum()]}
            if crs.isValid():
                extent["crs"] = crs_text(crs)
            inputs[meta["input"]] = extent
        return inputs

    def _destinations(self, parameters, context):
        """{output id: (parameter name, path)} of every destination given."""
        out = {}
        for p in self.destinationParameterDefinitions():
            output_id = p.metadata().get("rvoronoi", {}).get("output")
            if output_id is None:
                continue
            if isinstance(p, (QgsProcessingParameterRasterDestination, QgsProcessingParameterVectorDestination)):
                path = self.parameterAsOutputLayer(parameters, p.name(), context)
            elif isinstance(p, QgsProcessingParameterFileDestination):
                path = self.parameterAsFileOutput(parameters, p.name(), context)
            else:
                continue
            if path:
                out[output_id] = (p.name(), path)
        return out

    def processAlgorithm(self, parameters, context, feedback):  # noqa: N802
        if self.process_id != "voronoi":
            raise QgsProcessingException(f"rvoronoi:{self.process_id} runs on the server's pages; "
                                         "this provider runs rvoronoi:voronoi")
        if self.local:
            return self._run_locally(parameters, context, feedback)
        return self._run_on_server(parameters, context, feedback)

    def _run_on_server(self, parameters, context, feedback):
        try:
            client = Client(feedback=feedback)
        except ServerError as e:
            raise QgsProcessingException(str(e))
        outputs_described = self.description.get("outputs", {})
        # Who the server takes us for, before any upload: a refused token is said at once, not after
        # megabytes of layers (a server refusing a request answers before reading its body).
        try:
            _, _, me = client.call("GET", "/me")
        except ServerError as e:
            raise QgsProcessingException(str(e))
        feedback.pushInfo(f"{client.url}: signed in as {me.get('name')} ({me.get('role')})")
        with tempfile.TemporaryDirectory(prefix="rvoronoi_qgis_") as directory:
            inputs = self._inputs(parameters, context, feedback, directory, geopackage_upload)
            destinations = self._destinations(parameters, context)
            requested = {}
            for output_id, (_, path) in destinations.items():
                media = media_type_for(output_id, outputs_described.get(output_id, {}), path)
                requested[output_id] = {"format": {"mediaType": media}} if media else {}
            requested.setdefault("report", {})
            job = self._submit(client, inputs, requested, feedback)
            self._follow(client, job, feedback)
            results = {}
            for output_id, (name, path) in destinations.items():
                self._fetch(client, job, output_id, path, directory, feedback)
                results[name] = path
            report = destinations.get("report", (None, os.path.join(directory, "report.json")))[1]
            if "report" not in destinations:
                self._fetch(client, job, "report", report, directory, feedback)
            self._style_on_load(context, destinations, report)
            return results

    def _run_locally(self, parameters, context, feedback):
        """The same job through the Python module in QGIS's own process: the layers as GeoPackage
        files, the inputs as the module's keywords (the option table's), the files written as the
        CLI writes them."""
        from . import module

        rvoronoi = module.load()
        if rvoronoi is None:
            raise QgsProcessingException("the rvoronoi Python module is not installed (the local mode needs it)")
        keyword_of = {k["input"]: k["keyword"] for k in rvoronoi.keywords() if k.get("input")}
        with tempfile.TemporaryDirectory(prefix="rvoronoi_qgis_") as directory:
            inputs = self._inputs(parameters, context, feedback, directory, geopackage_file)
            seeds = inputs.pop("seeds")
            options = {}
            for input_id, value in inputs.items():
                if input_id not in keyword_of:
                    raise QgsProcessingException(f"input '{input_id}' has no keyword in the local module")
                options[keyword_of[input_id]] = value
            destinations = self._destinations(parameters, context)
            outputs, converted = {}, {}
            for output_id, (name, path) in destinations.items():
                ext = extension(path)
                if output_id in VECTOR_OUTPUTS and ext not in ("gpkg", "geojson", "json"):
                    converted[output_id] = (path, os.path.join(directory, f"{output_id}.gpkg"))
                    outputs[output_id] = converted[output_id][1]
                else:
                    outputs[output_id] = path
            outputs.setdefault("report", os.path.join(directory, "report.json"))
            names = {output_id: name for output_id, (name, _) in destinations.items()}
            feedback.pushInfo(f"local: rvoronoi {rvoronoi.__version__}")

            said = []

            def progress(stage, fraction):
                feedback.setProgress(overall_percent(stage, fraction))
                if not said or said[-1] != stage:
                    said.append(stage)
                    feedback.setProgressText(f"running: {stage}")

            try:
                rvoronoi.run(seeds, outputs, progress=progress, cancelled=feedback.isCanceled, **options)
            except rvoronoi.Cancelled:
                raise QgsProcessingException("cancelled")
            except rvoronoi.Error as e:
                raise QgsProcessingException(f"{type(e).__name__}: {e}")
            for output_id, (path, written) in converted.items():
                convert_vector(written, path, output_id)
                outputs[output_id] = path
            self._style_on_load(context, {o: (names[o], p) for o, p in outputs.items() if o in names},
                                outputs["report"])
            return {names[o]: p for o, p in outputs.items() if o in names}

    @staticmethod
    def _style_on_load(context, destinations, report_path):
        """The results QGIS loads when the run ends are styled then, from the report's owners."""
        try:
            with open(report_path) as f:
                owners = json.load(f).get("seeds", {}).get("owners", [])
        except (OSError, ValueError):
            owners = []
        for output_id, (_, path) in destinations.items():
            if context.willLoadLayerOnCompletion(path):
                context.layerToLoadOnCompletionDetails(path).setPostProcessor(Styler.create(output_id, owners))

    def _submit(self, client, inputs, outputs, feedback):
        try:
            _, _, doc = client.call("POST", f"/processes/{self.process_id}/execution",
                                    {"inputs": inputs, "outputs": outputs}, {"Prefer": "respond-async"}, ok=(201,))
        except ServerError as e:
            raise QgsProcessingException(str(e))
        job = doc["jobID"]
        feedback.pushInfo(f"job {job} on {client.url}")
        return job

    def _follow(self, client, job, feedback):
        """Polls the job to its end: progress and messages into `feedback`; a cancel dismisses it."""
        last = None
        while True:
            if feedback.isCanceled():
                try:
                    client.call("DELETE", f"/jobs/{job}")
                except ServerError as e:
                    feedback.reportError(f"dismissing job {job}: {e}")
                raise QgsProcessingException(f"cancelled: job {job} was dismissed")
            try:
                _, _, status = client.call("GET", f"/jobs/{job}")
            except ServerError as e:
                raise QgsProcessingException(str(e))
            feedback.setProgress(status.get("progress", 0))
            if status.get("message") != last:
                last = status.get("message")
                feedback.setProgressText(last or "")
            if status["status"] == "successful":
                return
            if status["status"] in ("failed", "dismissed"):
                try:
                    client.call("GET", f"/jobs/{job}/results")
                except ServerError as e:
                    raise QgsProcessingException(str(e))
                raise QgsProcessingException(status.get("message") or status["status"])
            time.sleep(POLL_S)

    def _fetch(self, client, job, output_id, path, directory, feedback):
        """Downloads one result into its destination; a vector destination of another format than
        the server writes is converted."""
        ext = extension(path)
        convert = output_id in VECTOR_OUTPUTS and ext not in ("gpkg", "geojson", "json")
        target = os.path.join(directory, f"{output_id}.gpkg") if convert else path
        try:
            size = client.download(f"/jobs/{job}/results/{output_id}", target)
        except ServerError as e:
            raise QgsProcessingException(f"{output_id}: {e}")
        if convert:
            convert_vector(target, path, output_id)
        feedback.pushInfo(f"{output_id}: {size} bytes -> {path}")
