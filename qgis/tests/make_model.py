"""Writes reproject_voronoi_clip.model3: a Processing model that reprojects the seeds to a CRS,
runs rvoronoi:voronoi on them, and clips the regions to an area of interest. The tests run the
model with qgis_process (tests/qgis/test_qgis_provider.py); this script made it, and makes it
again after a change of the algorithm's parameters:

    QT_QPA_PLATFORM=offscreen QGIS_PLUGINPATH=qgis RVORONOI_MODE=local PYTHONPATH=build/python \\
        /usr/bin/python3 qgis/tests/make_model.py qgis/tests/reproject_voronoi_clip.model3
"""
import os
import sys

from qgis.core import (
    QgsApplication,
    QgsProcessingModelAlgorithm,
    QgsProcessingModelChildAlgorithm,
    QgsProcessingModelChildParameterSource,
    QgsProcessingModelOutput,
    QgsProcessingModelParameter,
    QgsProcessingParameterCrs,
    QgsProcessingParameterNumber,
    QgsProcessingParameterString,
    QgsProcessingParameterVectorLayer,
    QgsProcessing,
)

app = QgsApplication([], False)
app.initQgis()
sys.path.insert(0, os.environ["QGIS_PLUGINPATH"])
sys.path.insert(0, "/usr/share/qgis/python/plugins")
from processing.core.Processing import Processing  # noqa: E402

Processing.initialize()
from rvoronoi.provider import RvoronoiProvider  # noqa: E402

provider = RvoronoiProvider()  # kept: the registry does not own a Python provider
QgsApplication.processingRegistry().addProvider(provider)

model = QgsProcessingModelAlgorithm("Reproject, rvoronoi, clip", "rvoronoi", "rvoronoi_tests")
inputs = [
    QgsProcessingParameterVectorLayer("seeds", "Seeds", [QgsProcessing.TypeVectorAnyGeometry]),
    QgsProcessingParameterString("owner_field", "Owner field", "iso2"),
    QgsProcessingParameterCrs("grid_crs", "Grid CRS", "EPSG:3035"),
    QgsProcessingParameterNumber("resolution", "Resolution", QgsProcessingParameterNumber.Double, 2000.0),
    QgsProcessingParameterVectorLayer("area", "Area of interest", [QgsProcessing.TypeVectorPolygon]),
]
for p in inputs:
    model.addModelParameter(p, QgsProcessingModelParameter(p.name()))

reproject = QgsProcessingModelChildAlgorithm("native:reprojectlayer")
reproject.setChildId("reproject")
reproject.addParameterSources("INPUT", [QgsProcessingModelChildParameterSource.fromModelParameter("seeds")])
reproject.addParameterSources("TARGET_CRS", [QgsProcessingModelChildParameterSource.fromModelParameter("grid_crs")])
model.addChildAlgorithm(reproject)

voronoi = QgsProcessingModelChildAlgorithm("rvoronoi:voronoi")
voronoi.setChildId("voronoi")
voronoi.addParameterSources("SEEDS", [QgsProcessingModelChildParameterSource.fromChildOutput("reproject", "OUTPUT")])
voronoi.addParameterSources("OWNER_FIELD", [QgsProcessingModelChildParameterSource.fromModelParameter("owner_field")])
voronoi.addParameterSources("RESOLUTION", [QgsProcessingModelChildParameterSource.fromModelParameter("resolution")])
voronoi.addParameterSources("REGIONS", [QgsProcessingModelChildParameterSource.fromStaticValue("TEMPORARY_OUTPUT")])
voronoi.addParameterSources("OWNERSHIP", [QgsProcessingModelChildParameterSource.fromStaticValue("TEMPORARY_OUTPUT")])
ownership = QgsProcessingModelOutput("ownership", "Ownership")
ownership.setChildOutputName("OWNERSHIP")
ownership.setChildId("voronoi")
voronoi.setModelOutputs({"ownership": ownership})
model.addChildAlgorithm(voronoi)

clip = QgsProcessingModelChildAlgorithm("native:clip")
clip.setChildId("clip")
clip.addParameterSources("INPUT", [QgsProcessingModelChildParameterSource.fromChildOutput("voronoi", "REGIONS")])
clip.addParameterSources("OVERLAY", [QgsProcessingModelChildParameterSource.fromModelParameter("area")])
clipped = QgsProcessingModelOutput("clipped_regions", "Clipped regions")
clipped.setChildOutputName("OUTPUT")
clipped.setChildId("clip")
clip.setModelOutputs({"clipped_regions": clipped})
model.addChildAlgorithm(clip)

model.updateDestinationParameters()
problems = model.validate()
if not problems[0]:
    sys.exit("the model is not valid: %s" % problems[1])
if not model.toFile(sys.argv[1]):
    sys.exit("cannot write %s" % sys.argv[1])
print("wrote", sys.argv[1])
app.exitQgis()
