"""The rvoronoi Python module (the engine) for the local mode.

The plugin's own package is named rvoronoi too (QGIS names a plugin's package after its folder),
so `import rvoronoi` inside the plugin is the plugin. The module is found on sys.path by what
only it has, its compiled extension (_rvoronoi*.so), and loaded under the name rvoronoi_module.
"""
import glob
import importlib.util
import os
import sys

NAME = "rvoronoi_module"
PLUGIN_PARENT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def load():
    """The module, or None when no installed rvoronoi module can be found."""
    if NAME in sys.modules:
        return sys.modules[NAME]
    for entry in sys.path:
        directory = os.path.join(entry or ".", "rvoronoi")
        init = os.path.join(directory, "__init__.py")
        if os.path.abspath(entry or ".") == PLUGIN_PARENT or not os.path.exists(init):
            continue
        if not glob.glob(os.path.join(directory, "_rvoronoi*.so")):
            continue
        spec = importlib.util.spec_from_file_location(NAME, init, submodule_search_locations=[directory])
        module = importlib.util.module_from_spec(spec)
        sys.modules[NAME] = module
        try:
            spec.loader.exec_module(module)
        except Exception:
            del sys.modules[NAME]
            raise
        return module
    return None
