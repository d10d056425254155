"""How the results look when QGIS loads them: the ownership raster paletted with each owner's
colour and label from the job's report (the colours of the map page and the quicklook), the
boundaries solid and the limit lines dashed, each labelled, tripoints as red markers, regions in
their owner's colour with their areas.

style(layer, output_id, owners) applies one; Styler is the post-processor Processing calls on each
result it loads. `owners` is the report's seeds.owners: [{"code", "label", "colour"}].
"""
from qgis.core import (
    QgsCategorizedSymbolRenderer,
    QgsFillSymbol,
    QgsLineSymbol,
    QgsMarkerSymbol,
    QgsPalettedRasterRenderer,
    QgsPalLayerSettings,
    QgsProcessingLayerPostProcessorInterface,
    QgsRendererCategory,
    QgsSingleSymbolRenderer,
    QgsTextFormat,
    QgsVectorLayerSimpleLabeling,
)
from qgis.PyQt.QtGui import QColor

BOUNDARY = "#1a1a1a"
LIMIT = "#20427a"
TRIPOINT = "#e31a1c"


def _labels(layer, expression, placement=QgsPalLayerSettings.Line):
    settings = QgsPalLayerSettings()
    settings.isExpression = True
    settings.fieldName = expression
    settings.placement = placement
    text = QgsTextFormat()
    text.setSize(8)
    settings.setFormat(text)
    layer.setLabeling(QgsVectorLayerSimpleLabeling(settings))
    layer.setLabelsEnabled(True)


def style_ownership(layer, owners):
    classes = [QgsPalettedRasterRenderer.Class(int(o["code"]), QColor(o["colour"]), o["label"]) for o in owners]
    renderer = QgsPalettedRasterRenderer(layer.dataProvider(), 1, classes)
    layer.setRenderer(renderer)


def style_boundaries(layer):
    layer.setRenderer(QgsSingleSymbolRenderer(QgsLineSymbol.createSimple(
        {"line_color": BOUNDARY, "line_width": "0.6", "line_style": "solid"})))
    _labels(layer, "\"label_a\" || ' / ' || \"label_b\"")


def style_limits(layer):
    layer.setRenderer(QgsSingleSymbolRenderer(QgsLineSymbol.createSimple(
        {"line_color": LIMIT, "line_width": "0.5", "line_style": "dash"})))
    _labels(layer, "format_number(\"distance\", 1) || ' ' || \"units\"")


def style_tripoints(layer):
    layer.setRenderer(QgsSingleSymbolRenderer(QgsMarkerSymbol.createSimple(
        {"name": "circle", "color": TRIPOINT, "outline_color": "#ffffff", "size": "2.6"})))


def style_regions(layer, owners):
    categories = []
    for o in owners:
        symbol = QgsFillSymbol.createSimple({"color": o["colour"], "outline_color": "#404040", "outline_width": "0.2"})
        symbol.setOpacity(0.55)
        categories.append(QgsRendererCategory(int(o["code"]), symbol, o["label"]))
    layer.setRenderer(QgsCategorizedSymbolRenderer("owner", categories))
    _labels(layer, "\"label\" || '\\n' || format_number(\"area\" / 1e6, 1) || ' km²'",
            QgsPalLayerSettings.OverPoint)


def style(layer, output_id, owners):
    """Styles `layer` (a result QGIS opened) as the output `output_id`; False when it has no style."""
    if output_id == "ownership" and owners:
        style_ownership(layer, owners)
    elif output_id == "boundaries":
        style_boundaries(layer)
    elif output_id == "limits":
        style_limits(layer)
    elif output_id == "tripoints":
        style_tripoints(layer)
    elif output_id == "regions" and owners:
        style_regions(layer, owners)
    else:
        return False
    layer.triggerRepaint()
    return True


class Styler(QgsProcessingLayerPostProcessorInterface):
    """Styles one loaded result. Processing keeps only a pointer: `keep` holds the instances until
    the layers are styled."""
    keep = []

    def __init__(self, output_id, owners):
        super().__init__()
        self.output_id = output_id
        self.owners = owners

    def postProcessLayer(self, layer, context, feedback):  # noqa: N802
        style(layer, self.output_id, self.owners)

    @classmethod
    def create(cls, output_id, owners):
        styler = cls(output_id, owners)
        cls.keep.append(styler)
        return styler
