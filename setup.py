"""`pip install .`: builds the _hexsim extension module with CMake (the project's own build, target
_hexsim only) and packages python/hexsim with worlds/ as hexsim/data/worlds (found by
hexsim/__init__.py). Environment: HEXSIM_PIP_BUILD_DIR (default build-pip/cmake, reused: a second
install rebuilds only what changed; an existing CMake build such as build/ works too, then only the
module is rebuilt for the venv's interpreter), HEXSIM_PIP_JOBS (default 2), HEXSIM_CMAKE_ARGS
(extra -D...).
"""
import os
import shlex
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext
from setuptools.command.build_py import build_py

ROOT = os.path.dirname(os.path.abspath(__file__))


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build_dir = os.environ.get("HEXSIM_PIP_BUILD_DIR", os.path.join(ROOT, "build-pip", "cmake"))
        configure = ["cmake", "-S", ROOT, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release",
                     f"-DPython3_EXECUTABLE={sys.executable}", "-DHEXSIM_PYTHON=ON"]
        if shutil.which("ninja"):
            configure += ["-G", "Ninja"]
        if shutil.which("ccache"):
            configure += ["-DCMAKE_CXX_COMPILER_LAUNCHER=ccache", "-DCMAKE_C_COMPILER_LAUNCHER=ccache"]
        configure += shlex.split(os.environ.get("HEXSIM_CMAKE_ARGS", ""))
        subprocess.run(configure, check=True)
        jobs = os.environ.get("HEXSIM_PIP_JOBS", "2")
        subprocess.run(["cmake", "--build", build_dir, "--target", "_hexsim", "-j", jobs], check=True)
        built = os.path.join(build_dir, "python", "hexsim", os.path.basename(self.get_ext_filename(ext.name)))
        target = self.get_ext_fullpath(ext.name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copyfile(built, target)


class BuildPyWithWorlds(build_py):
    def run(self):
        super().run()
        data = os.path.join(self.build_lib, "hexsim", "data", "worlds")
        shutil.rmtree(data, ignore_errors=True)
        shutil.copytree(os.path.join(ROOT, "worlds"), data)


setup(
    packages=["hexsim"],
    package_dir={"hexsim": "python/hexsim"},
    ext_modules=[CMakeExtension("hexsim._hexsim")],
    cmdclass={"build_ext": CMakeBuild, "build_py": BuildPyWithWorlds},
    options={"build": {"build_base": "build-pip"}, "egg_info": {"egg_base": "build-pip"}},
    zip_safe=False,
)
