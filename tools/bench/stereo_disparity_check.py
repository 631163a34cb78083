#!/usr/bin/env python3
"""Cross-camera matches of an `mcvo track` file against an independent
disparity search (tools/bench_stereo_far.sh; results/stereo_far_points.md).

    stereo_disparity_check.py TRACK_FILE DATASET_FOLDER

For a rectified stereo pair in mcvo's generic layout (rig.json, frames.csv,
images/<camera>/ in frame order): every match of camera 0's feature in
camera 1 (track file version 2+, docs/track-format.md) is searched again
along the row by zero-mean normalised SSD of an 11 x 11 patch (both images
bilinearly sampled at 0.05 px steps, +-0.75 px around mcvo's disparity,
parabola through the best three), independently of LK. Prints one JSON
object: per disparity bin the number of matches, the mean and median of
(search - mcvo) in px, and the mean vertical offset y_b - y_a of mcvo's
matches (0 on a perfectly rectified pair).
"""
import glob
import json
import os
import struct
import sys

import numpy as np
from PIL import Image

R = 5  # patch half size
STEP = 0.05
STEPS = 15
BINS = [(0, 5), (5, 10), (10, 20), (20, 40), (40, 1000)]


def read_matches(path):
    data = open(path, "rb").read()
    if data[:8] != b"MCVOTRK1":
        sys.exit(f"{path}: not an mcvo track file")
    (length,) = struct.unpack_from("<I", data, 8)
    header = json.loads(data[12:12 + length])
    if header["format_version"] < 2:
        sys.exit(f"{path}: format_version {header['format_version']} has no cross-camera matches")
    desc = header["descriptor_size"] * (4 if header["descriptor_type"] == "f32" else 1)
    fixed = 4 * 7 + 16 + 1 if header["format_version"] >= 3 else 4 * 6 + 16 + 1
    o, rows = 12 + length, []
    while True:
        (frame,) = struct.unpack_from("<i", data, o)
        if frame < 0:
            return header["cameras"], rows
        o += 12
        features = []
        for _ in header["cameras"]:
            o += fixed
            (n,) = struct.unpack_from("<I", data, o)
            o += 4
            f = {}
            for _ in range(n):
                fid, x, y = struct.unpack_from("<Qff", data, o)
                f[fid] = (x, y)
                o += 24 + desc
            features.append(f)
        (pairs,) = struct.unpack_from("<I", data, o)
        o += 4 + 40 * pairs
        (m,) = struct.unpack_from("<I", data, o)
        o += 4
        for _ in range(m):
            ca, ida, cb, xb, yb = struct.unpack_from("<BQBff", data, o)
            o += 18
            if ca == 0 and cb == 1:
                rows.append((frame, *features[ca][ida], xb, yb))


def bilinear(img, x, y):
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - x0, y - y0
    return (img[y0, x0] * (1 - fx) * (1 - fy) + img[y0, x0 + 1] * fx * (1 - fy)
            + img[y0 + 1, x0] * (1 - fx) * fy + img[y0 + 1, x0 + 1] * fx * fy)


def normalised(p):
    return (p - p.mean()) / (p.std() + 1e-6)


def main():
    track, folder = sys.argv[1:3]
    cameras, rows = read_matches(track)
    images = [sorted(glob.glob(os.path.join(folder, "images", c, "*"))) for c in cameras[:2]]
    gy, gx = np.mgrid[-R:R + 1, -R:R + 1].astype(float)
    loaded, out = {}, []
    for frame, xa, ya, xb, yb in rows:
        if frame not in loaded:
            loaded = {frame: [np.asarray(Image.open(images[c][frame]).convert("L"), float) for c in (0, 1)]}
        a, b = loaded[frame]
        h, w = a.shape
        margin = R + STEPS * STEP + 2
        if not (margin < xa < w - margin and margin < xb < w - margin and margin < ya < h - margin
                and margin < yb < h - margin):
            continue
        pa = normalised(bilinear(a, xa + gx, ya + gy))
        d0 = xa - xb
        disparities = d0 + np.arange(-STEPS, STEPS + 1) * STEP
        cost = np.array([((pa - normalised(bilinear(b, xa - d + gx, yb + gy))) ** 2).sum() for d in disparities])
        k = int(np.argmin(cost))
        if k in (0, len(cost) - 1):
            continue
        c0, c1, c2 = cost[k - 1:k + 2]
        bend = c0 + c2 - 2 * c1
        offset = 0.5 * (c0 - c2) / bend if bend > 0 else 0.0
        out.append((d0, disparities[k] + offset * STEP - d0, yb - ya))
    o = np.array(out)
    result = {"track_file": track, "matches": len(rows), "compared": len(out),
              "vertical_offset_px_mean": float(o[:, 2].mean()) if len(out) else None, "bins": []}
    for lo, hi in BINS:
        sel = (o[:, 0] >= lo) & (o[:, 0] < hi) if len(out) else np.zeros(0, bool)
        n = int(sel.sum())
        result["bins"].append({"disparity_px": [lo, hi], "n": n,
                               "search_minus_mcvo_mean_px": float(o[sel, 1].mean()) if n else None,
                               "search_minus_mcvo_median_px": float(np.median(o[sel, 1])) if n else None})
    print(json.dumps(result))


if __name__ == "__main__":
    main()
