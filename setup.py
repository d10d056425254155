"""Builds the rvoronoi Python package (pyproject.toml) through the project's own CMake.

    python3 -m venv --system-site-packages venv && venv/bin/pip install --no-build-isolation .

The extension rvoronoi._rvoronoi is the CMake target _rvoronoi (python/CMakeLists.txt) with the
libraries it links, built for the interpreter that runs this file, in a temporary build tree:
no tests, no map page bundle, nothing downloaded. The version is CMake's project(VERSION).
RV_CMAKE_BUILD_DIR=DIR builds the targets in an existing build tree instead (tools/build.sh's
build/, which CI reuses rather than building twice); its module must be for this interpreter.
Before CMake runs, every build dependency is looked for; a missing one stops the build with one
line naming the Debian package to install, and nothing is installed.
"""
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = os.path.dirname(os.path.abspath(__file__))
# setuptools' working files (see the options of setup() below); egg_info wants the folder to exist.
os.makedirs(os.path.join(ROOT, "build-pip"), exist_ok=True)


def project_version():
    with open(os.path.join(ROOT, "CMakeLists.txt"), encoding="utf-8") as f:
        m = re.search(r"project\(rvoronoi\s+VERSION\s+([0-9][0-9.]*)", f.read())
    if not m:
        raise SystemExit("setup.py: no project(rvoronoi VERSION ...) in CMakeLists.txt")
    return m.group(1)


# What the build needs, each as (what, how to find it, the Debian package that brings it).
def _header(*paths):
    return lambda: any(os.path.exists(p) for p in paths)


def _program(name):
    return lambda: shutil.which(name) is not None


def _python_header():
    include = sysconfig.get_paths().get("include", "")
    return os.path.exists(os.path.join(include, "Python.h"))


def _pybind11():
    return any(os.path.exists(os.path.join(d, "pybind11Config.cmake"))
               for d in ("/usr/lib/cmake/pybind11", "/usr/share/cmake/pybind11"))


REQUIREMENTS = [
    ("CMake", _program("cmake"), "cmake"),
    ("a C++20 compiler", lambda: shutil.which("c++") is not None or shutil.which("g++") is not None,
     "build-essential"),
    ("pkg-config", _program("pkg-config"), "pkg-config"),
    ("the Python headers of " + sys.executable, _python_header, "python3-dev"),
    ("pybind11", _pybind11, "pybind11-dev"),
    ("GDAL", _header("/usr/include/gdal/gdal.h"), "libgdal-dev"),
    ("PROJ", _header("/usr/include/proj.h"), "libproj-dev"),
    ("GeographicLib", _header("/usr/include/GeographicLib/Geodesic.hpp"), "libgeographiclib-dev"),
    ("libtiff", _header("/usr/include/x86_64-linux-gnu/tiffio.h", "/usr/include/tiffio.h"), "libtiff-dev"),
    ("zstd", _header("/usr/include/zstd.h"), "libzstd-dev"),
    ("libdeflate", _header("/usr/include/libdeflate.h"), "libdeflate-dev"),
    ("SQLite", _header("/usr/include/sqlite3.h"), "libsqlite3-dev"),
    ("Boost", _header("/usr/include/boost/beast.hpp"), "libboost-dev"),
    ("nlohmann/json", _header("/usr/include/nlohmann/json.hpp"), "nlohmann-json3-dev"),
    ("OpenCV", _header("/usr/include/opencv4/opencv2/core.hpp"), "libopencv-dev"),
]


def check_requirements():
    for what, present, package in REQUIREMENTS:
        if not present():
            raise SystemExit(f"rvoronoi: {what} is missing: install the Debian package {package} "
                             f"(apt-get install {package}), then run pip again")


class CMakeBuild(build_ext):
    """Builds the extension with CMake instead of compiling sources itself."""

    def build_extension(self, ext):
        check_requirements()
        target = self.get_ext_fullpath(ext.name)
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
        generator = ["-G", "Ninja"] if shutil.which("ninja") else []
        existing = os.environ.get("RV_CMAKE_BUILD_DIR")
        with tempfile.TemporaryDirectory(prefix="rvoronoi-build-") as temporary:
            build = existing or temporary
            if not existing:
                configure = ["cmake", "-S", ROOT, "-B", build, *generator, "-DCMAKE_BUILD_TYPE=Release",
                             "-DRV_BUILD_TESTS=OFF", "-DRV_WEB_APP=OFF", "-DRV_PYTHON=ON",
                             f"-DPython3_EXECUTABLE={sys.executable}"]
                self._run(configure, "configuring")
            self._run(["cmake", "--build", build, "--target", "_rvoronoi", "rvoronoi_stub", "-j", jobs], "building")
            built = os.path.join(build, "python", "rvoronoi")
            os.makedirs(os.path.dirname(target), exist_ok=True)
            module = [f for f in os.listdir(built) if f.startswith("_rvoronoi") and f.endswith(".so")]
            if len(module) != 1:
                raise SystemExit(f"rvoronoi: the build made {module or 'no native module'} in {built}")
            suffix = sysconfig.get_config_var("EXT_SUFFIX")
            if not module[0].endswith(suffix):
                raise SystemExit(f"rvoronoi: {built}/{module[0]} is not for {sys.executable} (its modules end in "
                                 f"{suffix}); build without RV_CMAKE_BUILD_DIR")
            shutil.copyfile(os.path.join(built, module[0]), target)
            # The typing stub and marker the build made from the option table go beside it.
            for name in ("__init__.pyi", "py.typed"):
                shutil.copyfile(os.path.join(built, name), os.path.join(os.path.dirname(target), name))

    @staticmethod
    def _run(command, what):
        result = subprocess.run(command, cwd=ROOT)
        if result.returncode != 0:
            raise SystemExit(f"rvoronoi: {what} with CMake failed (exit {result.returncode}); its output is above")


setup(
    version=project_version(),
    packages=["rvoronoi"],
    package_dir={"rvoronoi": "python/rvoronoi"},
    ext_modules=[Extension("rvoronoi._rvoronoi", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    # setuptools' own working files out of CMake's build/ and out of the sources.
    options={"build": {"build_base": "build-pip"}, "egg_info": {"egg_base": "build-pip"}},
    zip_safe=False,
)
