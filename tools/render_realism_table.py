#!/usr/bin/env python3
"""Markdown tables of tools/bench_render_realism.sh: real samples against renders.

    tools/render_realism_table.py STATS_DIR

STATS_DIR holds mcvo_bench_image_stats outputs named real_<sample>.json and
render_<name>.json. Every figure is the mean over a dataset's cameras.
"""
import json
import os
import sys


def load(stats, name):
    path = os.path.join(stats, name + ".json")
    return json.load(open(path)) if os.path.exists(path) else None


def mean(values):
    values = [v for v in values if v is not None]
    return sum(values) / len(values) if values else None


def noise_at(cam, lo, key="noise"):
    for b in cam[key]["bins"]:
        if b["lo"] == lo and b["pixels"] >= 2000:
            return b["sigma"]
    return None


ROWS = [
    ("noise sigma, grey 32-64 (grey levels)", lambda c: noise_at(c, 32)),
    ("noise sigma, grey 96-128", lambda c: noise_at(c, 96)),
    ("noise sigma, grey 160-192", lambda c: noise_at(c, 160)),
    ("noise fit_lower a (sigma^2 = a v + b)", lambda c: c["noise"].get("fit_lower", {}).get("a")),
    ("noise fit_lower b", lambda c: c["noise"].get("fit_lower", {}).get("b")),
    ("edge blur sigma (px, beyond the pixel)", lambda c: c["sharpness"].get("sigma_px")),
    ("edge width 10-90 % (px)", lambda c: c["sharpness"].get("edge_width_px")),
    ("step edges per frame", lambda c: c["sharpness"]["edges"] / c["frames"]),
    ("brightness at radius 0.5-0.6 / centre", lambda c: c["vignetting"]["relative_mean"][5]),
    ("brightness at radius 0.9-1.0 / centre", lambda c: c["vignetting"]["relative_mean"][9]),
    ("grey p1", lambda c: c["exposure"]["p1"]),
    ("grey p50", lambda c: c["exposure"]["p50"]),
    ("grey p99", lambda c: c["exposure"]["p99"]),
    ("pixels at 255 (%)", lambda c: 100 * c["exposure"]["fraction_255"]),
    ("pixels at 0 (%)", lambda c: 100 * c["exposure"]["fraction_0"]),
    ("per-frame grey std", lambda c: c["exposure"]["frame_std"]),
    ("min-eigenvalue median", lambda c: c["texture"]["min_eigen_median"]),
    ("min-eigenvalue p90", lambda c: c["texture"]["min_eigen_p90"]),
    ("pixels with gradient > 4 /px (%)", lambda c: 100 * c["texture"]["gradient_over_4"]),
    ("pixels with gradient > 16 /px (%)", lambda c: 100 * c["texture"]["gradient_over_16"]),
    ("FAST-20 corners per 10^4 px", lambda c: c["texture"]["fast20_per_10k_px"]),
    ("power spectrum slope", lambda c: c["texture"]["spectrum_slope"]),
    ("JPEG 8x8 grid ratio (max of both axes)",
     lambda c: max(c["compression"]["across_columns"]["grid_ratio"], c["compression"]["across_rows"]["grid_ratio"])),
]


def value(data, row):
    if data is None:
        return None
    return mean([row[1](c) for c in data["cameras"]])


def fmt(v):
    if v is None:
        return "-"
    if abs(v) >= 100:
        return "%.0f" % v
    if abs(v) >= 10:
        return "%.1f" % v
    if abs(v) >= 1:
        return "%.2f" % v
    return "%.3f" % v


def table(stats, columns, real, before, after):
    """columns: (header, file); real/before/after: files for the gap columns."""
    data = {f: load(stats, f) for _, f in columns}
    heads = [h for h, _ in columns] + ["gap before", "gap after"]
    print("| statistic | " + " | ".join(heads) + " |")
    print("|---|" + "---:|" * len(heads))
    for row in ROWS:
        vals = [value(data[f], row) for _, f in columns]
        r, b, a = (value(data[f], row) for f in (real, before, after))
        gap_b = None if r is None or b is None else b - r
        gap_a = None if r is None or a is None else a - r
        print("| %s | %s |" % (row[0], " | ".join(fmt(v) for v in vals + [gap_b, gap_a])))
    print()


def noise_table(stats, columns):
    data = [(h, load(stats, f), key) for h, f, key in columns]
    print("| grey | " + " | ".join(h for h, _, _ in data) + " |")
    print("|---|" + "---:|" * len(data))
    for lo in range(0, 256, 32):
        cells = []
        for _, d, key in data:
            cells.append(fmt(mean([noise_at(c, lo, key) for c in d["cameras"]])) if d else "-")
        print("| %d-%d | %s |" % (lo, lo + 32, " | ".join(cells)))
    print()


def main():
    stats = sys.argv[1]
    print("### KITTI odometry against renders (mean over the cameras)\n")
    table(stats, [("kitti06 (real)", "real_kitti06_stereo"), ("kitti01 (real)", "real_kitti01_stereo"),
                  ("kitti00 (real)", "real_kitti00_mono"),
                  ("stereo urban, no effects", "render_stereo_urban_clean"),
                  ("stereo urban, suite effects", "render_stereo_urban_suite"),
                  ("stereo indoor, suite effects", "render_stereo_indoor_suite"),
                  ("stereo open, suite effects", "render_stereo_open_suite"),
                  ("KITTI rig urban, no effects", "render_kitti_urban_clean"),
                  ("KITTI rig urban, suite effects (before)", "render_kitti_urban_suite"),
                  ("KITTI rig urban, realism flags (after)", "render_kitti_urban_after")],
          "real_kitti06_stereo", "render_kitti_urban_suite", "render_kitti_urban_after")
    print("Gaps: render minus kitti06_stereo, before = KITTI rig with the suite's effects, after = with the "
          "realism flags.\n")
    print("### EuRoC against the suite's EuRoC-like rig (roof_pair, indoor)\n")
    table(stats, [("euroc_v101 (real)", "real_euroc_v101_static"),
                  ("roof_pair indoor, no effects", "render_euroc_indoor_clean"),
                  ("roof_pair indoor, suite effects (before)", "render_euroc_indoor_suite"),
                  ("roof_pair indoor, realism flags (after)", "render_euroc_indoor_after")],
          "real_euroc_v101_static", "render_euroc_indoor_suite", "render_euroc_indoor_after")
    print("### Noise sigma per brightness bin (grey levels; '-': fewer than 2000 flat-block pixels)\n")
    noise_table(stats, [("kitti06", "real_kitti06_stereo", "noise"), ("kitti01", "real_kitti01_stereo", "noise"),
                        ("kitti00", "real_kitti00_mono", "noise"),
                        ("KITTI rig, no effects", "render_kitti_urban_clean", "noise"),
                        ("KITTI rig, suite (before)", "render_kitti_urban_suite", "noise"),
                        ("KITTI rig, after", "render_kitti_urban_after", "noise"),
                        ("euroc, spatial", "real_euroc_temporal", "noise"),
                        ("euroc, temporal", "real_euroc_temporal", "temporal_noise"),
                        ("roof_pair, suite (before)", "render_euroc_indoor_suite", "noise"),
                        ("roof_pair, after", "render_euroc_indoor_after", "noise")])


if __name__ == "__main__":
    main()
