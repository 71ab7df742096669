# The Python package `photosite` (python/photosite + the _photosite extension), built by
# scikit-build through CMake with only the library and the module (no command, tests or benchmarks).
from skbuild import setup

setup(
    name="photosite",
    version="0.1.0",
    description="Camera-sensor simulator with a day-to-night front end (Python module)",
    packages=["photosite"],
    package_dir={"": "python"},
    package_data={"photosite": ["*.pyi", "py.typed"]},
    cmake_args=["-DPHOTOSITE_TESTS=OFF", "-DPHOTOSITE_BENCH=OFF", "-DPHOTOSITE_BUILD_CLI=OFF",
                "-DCMAKE_BUILD_TYPE=Release"],
    cmake_install_dir="python",
    python_requires=">=3.9",
    install_requires=["numpy"],
)
