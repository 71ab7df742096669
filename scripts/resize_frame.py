#!/usr/bin/python3
"""A day frame and its labels at another size, for timing the night chain on frames that are not
2048x1024 (docs/benchmarks.md, "Fifty-third session: frames of other sizes").

    /usr/bin/python3 scripts/resize_frame.py IMAGE LABELS WIDTH HEIGHT OUT_PREFIX

writes OUT_PREFIX.png (the image, bilinear) and OUT_PREFIX_labels.png (the labels, nearest: ids
are names, never blended). Neither output may exist already.
"""
import os
import sys

from PIL import Image


def main(argv):
    if len(argv) != 6:
        sys.stderr.write(__doc__)
        return 2
    image, labels, width, height, prefix = argv[1], argv[2], argv[3], argv[4], argv[5]
    try:
        w, h = int(width), int(height)
    except ValueError:
        sys.stderr.write(f"resize_frame: WIDTH and HEIGHT must be integers, got {width!r} {height!r}\n")
        return 2
    if w < 2 or h < 2:
        sys.stderr.write(f"resize_frame: {w}x{h} is too small (at least 2x2)\n")
        return 2
    outs = (prefix + ".png", prefix + "_labels.png")
    for o in outs:
        if os.path.exists(o):
            sys.stderr.write(f"resize_frame: {o} exists; not overwritten\n")
            return 2
    try:
        im = Image.open(image)
        lb = Image.open(labels)
    except OSError as e:
        sys.stderr.write(f"resize_frame: {e}\n")
        return 2
    im.resize((w, h), Image.BILINEAR).save(outs[0])
    lb.resize((w, h), Image.NEAREST).save(outs[1])
    print(outs[0], outs[1])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
