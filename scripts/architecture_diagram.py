#!/usr/bin/python3
"""docs/architecture.png: photosite's layers and which may include or link which.

Run with Debian's matplotlib:  /usr/bin/python3 scripts/architecture_diagram.py
The boxes and arrows mirror docs/architecture.md (the include rules) and CMakeLists.txt (the
targets); edit all three together.
"""
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "docs", "architecture.png")

# name: (x, y, width, height, label, face colour)
BOXES = {
    "cli": (0.3, 8.0, 3.0, 1.3, "cli/  →  photosite (executable)\nparsing, printing, --flags,\nexit status", "#f6d7a7"),
    "python": (3.7, 8.0, 3.0, 1.3, "python/  →  _photosite (pybind11)\nkeywords, numpy arrays,\nPython exceptions", "#f6d7a7"),
    "consumer": (7.1, 8.0, 3.0, 1.3, "another project\nfind_package(photosite)\n(tests/consumer)", "#f6d7a7"),
    "api": (0.3, 5.6, 9.8, 1.4, "include/photosite/   the public API (installed)\n"
            "image.h io.h error.h environment.h backend.h outputs.h batch.h night_chain.h characterize.h\n"
            "sensor/  scene/  gpu/   — standard library only, no third-party header, no *_detail.h", "#bcd9ea"),
    "core": (0.3, 2.9, 2.2, 1.8, "core/\nerrors, I/O, environment,\nbackend choice, batch,\noutputs, night chain", "#d5e8d4"),
    "sensor": (2.8, 2.9, 2.2, 1.8, "sensor/\npresets, optics, noise,\nPoisson, demosaic,\nEMVA 1288", "#d5e8d4"),
    "scene": (5.3, 2.9, 2.2, 1.8, "scene/\nlabels, lights, darken,\nbloom, scene presets", "#d5e8d4"),
    "gpu": (7.8, 2.9, 2.3, 1.8, "gpu/ + kernels/\nVulkan host layer (dlopen)\n*.comp → SPIR-V,\nembedded", "#d5e8d4"),
    "libs": (0.3, 0.3, 9.8, 1.6, "object libraries photosite_core + photosite_gpu, combined twice:\n"
             "photosite_lib (static: cli, tests, python module)   and   libphotosite.so = photosite::photosite (installed)\n"
             "private to both: OpenCV, OpenEXR, libspng, libjpeg, libtiff, nlohmann-json, fmt, toml++, OpenMP (photosite_deps)", "#e1d5e7"),
}

ARROWS = [  # (from, to, label)
    ("cli", "api", "includes"),
    ("python", "api", "includes"),
    ("consumer", "api", "includes"),
    ("core", "api", "implements"),
    ("sensor", "api", ""),
    ("scene", "api", ""),
    ("gpu", "api", ""),
    ("core", "libs", "compiled into"),
    ("sensor", "libs", ""),
    ("scene", "libs", ""),
    ("gpu", "libs", ""),
]


def centre(name):
    x, y, w, h, _, _ = BOXES[name]
    return x + w / 2, y + h / 2


def edge(name, towards):
    x, y, w, h, _, _ = BOXES[name]
    cx, cy = centre(name)
    tx, ty = centre(towards)
    return (cx, y) if ty < cy else (cx, y + h)


def main():
    fig, ax = plt.subplots(figsize=(11, 10))
    ax.set_xlim(0, 10.4)
    ax.set_ylim(0, 9.6)
    ax.axis("off")
    for name, (x, y, w, h, label, colour) in BOXES.items():
        ax.add_patch(FancyBboxPatch((x, y), w, h, boxstyle="round,pad=0.05", fc=colour, ec="#333333"))
        ax.text(x + w / 2, y + h / 2, label, ha="center", va="center", fontsize=9, family="DejaVu Sans")
    for a, b, label in ARROWS:
        start, end = edge(a, b), edge(b, a)
        end = (start[0], end[1])  # vertical arrows
        ax.add_patch(FancyArrowPatch(start, end, arrowstyle="-|>", mutation_scale=14, color="#333333"))
        if label:
            ax.text(start[0] + 0.08, (start[1] + end[1]) / 2, label, fontsize=8, style="italic")
    ax.text(0.3, 9.45, "the faces: they translate library errors (ParameterError) to their own words",
            fontsize=9, style="italic")
    ax.set_title("photosite: one library, its faces, and what each layer may include", fontsize=12)
    fig.tight_layout()
    fig.savefig(OUT, dpi=110)
    print("wrote", os.path.relpath(OUT))


if __name__ == "__main__":
    main()
