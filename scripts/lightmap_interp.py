#!/usr/bin/python3
"""The ground pools' interpolation (scene preset street_lamps.interp_tolerance, scene/street.cpp):
speed and error against the exact path for a few tolerances, as docs/lightmap_interp.csv and
docs/lightmap_interp.png.

  /usr/bin/python3 scripts/lightmap_interp.py [--bin build/photosite] [--repeats 7] [--out docs]

Per tolerance (0 = the exact per-pixel evaluation, the reference): `photosite bench night
--threads 1 --cpu-clock` (light map alone and pools + heads alone, process CPU clock, with the
OpenCV cvtColor peer of the same run), and `photosite night --backend cpu` on three Cityscapes
frames (aachen_000000/1/3) whose `lights` layer on the ground pixels (is_ground: labels 6-10 and 22,
ground, road, sidewalk, parking, rail track, terrain: only the pools reach them) and `night_radiance` are compared with
tolerance 0's: the largest and the median relative difference |a − b|/b over the pixels with b > 0.
Each tolerance runs from a copy of presets/ with the key changed (PHOTOSITE_PRESET_DIR). The
EXR layers are read through oiiotool (FITS, big-endian float32)."""
import argparse, csv, os, shutil, subprocess, sys, tempfile
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CITY = os.path.join(ROOT, "..", "shared", "data", "cityscapes")
FRAMES = ["aachen_000000_000019", "aachen_000001_000019", "aachen_000003_000019"]
TOLS = [0, 1e-4, 3e-4, 6e-4, 1e-3, 3e-3, 1e-2]


def read_fits(path):
    with open(path, "rb") as f:
        data = f.read()
    hdr, off = {}, 0
    while True:
        block = data[off:off + 2880].decode("ascii")
        off += 2880
        for i in range(0, 2880, 80):
            card = block[i:i + 80]
            if "=" in card[:10]:
                hdr[card[:8].strip()] = card[10:].split("/")[0].strip()
        if any(block[i:i + 3] == "END" for i in range(0, 2880, 80)):
            break
    dims = [int(hdr["NAXIS%d" % k]) for k in range(int(hdr["NAXIS"]), 0, -1)]
    return np.frombuffer(data[off:off + 4 * int(np.prod(dims))], dtype=">f4").reshape(dims).astype(np.float64)


def layer(exr, chans, tmp):
    out = os.path.join(tmp, "layer.fits")
    subprocess.run(["oiiotool", exr, "--ch", chans, "-d", "float", "-o", out], check=True)
    return read_fits(out)


def presets_with(tol, tmp):
    d = os.path.join(tmp, "presets_%g" % tol)
    shutil.copytree(os.path.join(ROOT, "presets"), d)
    for name in ("night-urban.toml", "night-rural.toml"):
        p = os.path.join(d, "scenes", name)
        lines = open(p).read().split("\n")
        lines = [("interp_tolerance = %r" % tol) + l[l.index("#") - 1:] if l.startswith("interp_tolerance") else l
                 for l in lines]
        open(p, "w").write("\n".join(lines))
    return d


def bench(binary, env, repeats, tmp):
    subprocess.run([binary, "bench", "night", "--threads", "1", "--cpu-clock", "--repeats", str(repeats), "--out-dir",
                    tmp], check=True, env=env, stdout=subprocess.DEVNULL)
    rows = {r["stage"]: r for r in csv.DictReader(open(os.path.join(tmp, "night_bench.csv")))}
    return (float(rows["cpu: light map (alone)"]["median_ms"]), float(rows["cpu: pools + heads (alone)"]["median_ms"]),
            float(rows["cpu: peer"]["median_ms"]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default=os.path.join(ROOT, "build", "photosite"))
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--out", default=os.path.join(ROOT, "docs"))
    a = ap.parse_args()
    if not os.path.isdir(CITY):
        sys.exit("lightmap_interp.py: needs ../shared/data/cityscapes")
    tmp = tempfile.mkdtemp(prefix="lightmap_interp_")
    ref, rows = {}, []
    for tol in TOLS:
        env = dict(os.environ, PHOTOSITE_PRESET_DIR=presets_with(tol, tmp))
        lm, pools, peer = bench(a.bin, env, a.repeats, tmp)
        rel_l, rel_n = [], []
        for fr in FRAMES:
            exr = os.path.join(tmp, "night_%s.exr" % fr)
            subprocess.run([a.bin, "night", "--image", os.path.join(CITY, "leftImg8bit", fr + "_leftImg8bit.png"),
                            "--labels", os.path.join(CITY, "gtFine", fr + "_gtFine_labelIds.png"), "--instances",
                            os.path.join(CITY, "gtFine", fr + "_gtFine_instanceIds.png"), "--backend", "cpu",
                            "--compression", "none", "--overwrite", "--out", exr], check=True, env=env,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            lights = layer(exr, "lights.R,lights.G,lights.B", tmp)
            night = layer(exr, "night_radiance.R,night_radiance.G,night_radiance.B", tmp)
            # uint32 ids, which oiiotool's float conversion normalises by 2^32 − 1
            labels = np.rint(layer(exr, "labels.Y", tmp).reshape(lights.shape[:2]) * 4294967295.0)
            if tol == 0:
                ref[fr] = (lights, night)
                continue
            ground = ((labels >= 6) & (labels <= 10)) | (labels == 22)  # is_ground (scene/labels.cpp)
            l0, n0 = ref[fr]
            m = ground[..., None] & (l0 > 0)
            rel_l.append(np.abs(lights - l0)[m] / l0[m])
            mn = n0 > 0
            rel_n.append(np.abs(night - n0)[mn] / n0[mn])
        rl = np.concatenate(rel_l) if rel_l else np.zeros(1)
        rn = np.concatenate(rel_n) if rel_n else np.zeros(1)
        rows.append({"tolerance": tol, "light_map_ms": lm, "pools_heads_ms": pools, "peer_ms": peer,
                     "light_map_x_peer": lm / peer, "pools_heads_x_peer": pools / peer,
                     "lights_ground_max_rel": rl.max(), "lights_ground_median_rel": np.median(rl),
                     "night_radiance_max_rel": rn.max()})
        print(rows[-1], flush=True)
    shutil.rmtree(tmp)
    path = os.path.join(a.out, "lightmap_interp.csv")
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: ("%.6g" % v) for k, v in r.items()})
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    t = [max(r["tolerance"], 3e-5) for r in rows]
    ax1.semilogx(t, [r["pools_heads_x_peer"] for r in rows], "o-", label="pools + heads")
    ax1.semilogx(t, [r["light_map_x_peer"] for r in rows], "s-", label="light map")
    ax1.set_xlabel("street_lamps.interp_tolerance (0 plotted at 3e-5)")
    ax1.set_ylabel("x OpenCV cvtColor peer (1 thread, CPU clock)")
    ax1.legend()
    nz = [r for r in rows if r["tolerance"] > 0]
    ax2.loglog([r["tolerance"] for r in nz], [r["lights_ground_max_rel"] for r in nz], "o-", label="lights, ground: largest")
    ax2.loglog([r["tolerance"] for r in nz], [max(r["lights_ground_median_rel"], 1e-9) for r in nz], "s-",
               label="lights, ground: median")
    ax2.loglog([r["tolerance"] for r in nz], [r["tolerance"] for r in nz], "k--", label="bound: tolerance")
    ax2.set_xlabel("street_lamps.interp_tolerance")
    ax2.set_ylabel("relative difference to the exact path")
    ax2.legend()
    fig.suptitle("ground pools at adaptive samples (aachen_000000/1/3, 2048x1024)")
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "lightmap_interp.png"), dpi=100)
    print(path)


if __name__ == "__main__":
    main()
