#!/usr/bin/python3
"""The walk-through of docs/python.md as one script; it produced the pictures in docs/python/.

    PYTHONPATH=build/python /usr/bin/python3 docs/python/walkthrough.py [cityscapes stem]

Needs the shared Cityscapes frames (../shared/data/cityscapes); falls back to the bundled KITTI
frame (with its camera) when they are missing, and says so.
"""
import pathlib
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.colors as mcolors
import matplotlib.patches as mpatches
import matplotlib.pyplot as plt
import numpy as np

import photosite as ps

ROOT = pathlib.Path(__file__).resolve().parents[2]
OUT = ROOT / "docs" / "python"
CITY = ROOT / ".." / "shared" / "data" / "cityscapes"
stem = sys.argv[1] if len(sys.argv) > 1 else "aachen_000000_000019"

# 1. load a Cityscapes frame: 8-bit sRGB codes and labelIds, as NumPy arrays
img = CITY / "leftImg8bit" / f"{stem}_leftImg8bit.png"
if img.exists():
    day = ps.read_codes(str(img))                                             # uint8 H x W x 3
    labels = ps.read_codes(str(CITY / "gtFine" / f"{stem}_gtFine_labelIds.png"))  # uint8 H x W
    instances = ps.read_codes(str(CITY / "gtFine" / f"{stem}_gtFine_instanceIds.png"))
    cam = ps.Camera("onsemi-ar0331")  # Cityscapes' camera
    source = f"Cityscapes {stem}"
else:
    print("Cityscapes frames not found: using the bundled KITTI frame", file=sys.stderr)
    day = ps.read_codes(str(ROOT / "samples/kitti/image_2/000000_10.png"))
    labels = ps.read_codes(str(ROOT / "samples/kitti/semantic/000000_10.png"))
    instances = None
    cam = ps.Camera("sony-icx267-flea2")
    source = "KITTI 000000_10"
print(source, day.shape, day.dtype, labels.shape, labels.dtype)

# 2. translate it to night
night = ps.night(day, labels, instances, camera=cam, exposure_s=0.02, seed=0, frame=0)
x, y, conf, method = night.vanishing_point
print(f"vanishing point ({x:.0f}, {y:.0f}) px, {method}, confidence {conf:.2f}")


# 3. radiance and depth
def log_lum(rad):  # log10 of a luminance proxy (Rec. 709 weights over band radiance)
    return np.log10(np.maximum(rad @ np.array([0.2126, 0.7152, 0.0722], np.float32), 1e-6))


fig, ax = plt.subplots(1, 3, figsize=(15, 3.4))
ax[0].imshow(day); ax[0].set_title("day (sRGB codes)")
im = ax[1].imshow(log_lum(night.radiance), cmap="magma", vmin=-4, vmax=1)
ax[1].set_title("night radiance, log10 (W.sr-1.m-2, luma weights)"); fig.colorbar(im, ax=ax[1], fraction=0.025)
# night.depth is metres along the optical axis; the sky holds 65504 (the largest half), drawn
# apart in grey. Log colour scale from 1 m to 1000 m (night-urban's max_depth_m).
sky = night.depth >= 65504
depth = np.ma.masked_array(night.depth, mask=sky)
cmap = matplotlib.colormaps["viridis"].with_extremes(bad="0.75")
im = ax[2].imshow(depth, cmap=cmap, norm=mcolors.LogNorm(vmin=1, vmax=1000)); ax[2].plot([x], [y], "r+", ms=12)
ax[2].legend(handles=[mpatches.Patch(color="0.75", label="sky")], loc="upper right", fontsize=8)
ax[2].set_title("depth, m along the optical axis (log), + vanishing point", fontsize=10)
fig.colorbar(im, ax=ax[2], fraction=0.025, label="m")
print(f"depth {night.depth[~sky].min():.2f} .. {night.depth[~sky].max():.1f} m, sky {sky.mean():.1%} of the frame")
for a in ax: a.axis("off")
fig.tight_layout(); fig.savefig(OUT / "radiance_depth.png", dpi=80)

# 4. expose the same night radiance at three exposure times
times = [0.005, 0.02, 0.08]
fig, ax = plt.subplots(1, 3, figsize=(15, 3.4))
for a, t in zip(ax, times):
    out = cam.expose(night.radiance, exposure_s=t, seed=0)
    print(f"exposure_s={t}: mean {out.electrons.mean():.1f} e-, raw max {out.raw.max()} DN")
    a.imshow(out.preview()); a.axis("off")
    a.set_title(f"exposure_s={t}: mean {out.electrons.mean():.0f} e-, raw max {out.raw.max()} DN")
fig.tight_layout(); fig.savefig(OUT / "exposures.png", dpi=80)

# 5. photon-transfer curve from characterize (EMVA 1288)
c = ps.characterize(cam.preset, roi=128)
ptc = np.array(c["photon_transfer"])  # photons, mean DN above dark, temporal variance above dark DN^2
K = c["system_gain_dn_per_e"]
fig, ax = plt.subplots(figsize=(6, 4))
ax.loglog(ptc[:, 1], ptc[:, 2], "o", ms=4, label="measured (simulated camera)")
mu = np.linspace(ptc[:, 1].min(), ptc[:, 1].max(), 100)
ax.loglog(mu, K["preset"] * mu, "-", label=f"K = {K['preset']:.3g} DN/e- (preset): variance = K mu")
ax.set_xlabel("mean signal above dark, DN"); ax.set_ylabel("temporal variance above dark, DN^2")
ax.set_title(f"photon transfer: {c['preset']}, K measured {K['measured']:.4g} +/- {K['uncertainty']:.2g}")
ax.legend(fontsize=8); fig.tight_layout(); fig.savefig(OUT / "photon_transfer.png", dpi=80)
print("wrote", *(OUT / n for n in ("radiance_depth.png", "exposures.png", "photon_transfer.png")))
