#!/usr/bin/env python3
"""Writes the example trajectory pair in examples/trajectories/ (standard library only).

ground truth: a closed 10 Hz drive of about 520 m (about 8 m/s, smooth
heading, small pitch and roll), world z up, body x forward.
estimate: the ground truth's frame-to-frame motions re-integrated with the
errors a visual odometry makes: 0.8 % scale error, a yaw rate bias, and
small per-step noise (fixed seed), so ATE/RPE/scale have known causes.

Re-run to regenerate: python3 tools/make_example_trajectories.py
"""
import math
import random

N = 620          # frames at 10 Hz
DT_NS = 100_000_000
T0_NS = 1_000_000_000_000


def rot_zyx(yaw, pitch, roll):
    cy, sy = math.cos(yaw), math.sin(yaw)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cr, sr = math.cos(roll), math.sin(roll)
    return [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr]]


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def transpose(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]


def apply(r, v):
    return [sum(r[i][k] * v[k] for k in range(3)) for i in range(3)]


def quat_xyzw(r):
    tr = r[0][0] + r[1][1] + r[2][2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        w, x, y, z = 0.25 * s, (r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s
    elif r[0][0] > r[1][1] and r[0][0] > r[2][2]:
        s = math.sqrt(1.0 + r[0][0] - r[1][1] - r[2][2]) * 2
        w, x, y, z = (r[2][1] - r[1][2]) / s, 0.25 * s, (r[0][1] + r[1][0]) / s, (r[0][2] + r[2][0]) / s
    elif r[1][1] > r[2][2]:
        s = math.sqrt(1.0 + r[1][1] - r[0][0] - r[2][2]) * 2
        w, x, y, z = (r[0][2] - r[2][0]) / s, (r[0][1] + r[1][0]) / s, 0.25 * s, (r[1][2] + r[2][1]) / s
    else:
        s = math.sqrt(1.0 + r[2][2] - r[0][0] - r[1][1]) * 2
        w, x, y, z = (r[1][0] - r[0][1]) / s, (r[0][2] + r[2][0]) / s, (r[1][2] + r[2][1]) / s, 0.25 * s
    if w < 0:
        w, x, y, z = -w, -x, -y, -z
    return x, y, z, w


def ground_truth():
    poses = []
    for i in range(N):
        th = 2 * math.pi * i / N
        # A smooth (analytic) closed loop of about 520 m: an ellipse with a bend.
        x = 100.0 * math.cos(th) + 8.0 * math.cos(3 * th)
        y = 60.0 * math.sin(th) + 12.0 * math.sin(2 * th)
        z = 1.5 * math.sin(2 * th)
        poses.append([x, y, z])
    out = []
    for i in range(N):
        p0, p1 = poses[i - 1], poses[(i + 1) % N]
        yaw = math.atan2(p1[1] - p0[1], p1[0] - p0[0])
        pitch = -math.atan2(p1[2] - p0[2], math.hypot(p1[0] - p0[0], p1[1] - p0[1]))
        roll = 0.02 * math.sin(6 * math.pi * i / N)
        out.append((rot_zyx(yaw, pitch, roll), poses[i]))
    return out


def estimate(gt, rng):
    r_est, p_est = gt[0][0], list(gt[0][1])
    out = [(r_est, list(p_est))]
    for i in range(1, len(gt)):
        r0, p0 = gt[i - 1]
        r1, p1 = gt[i]
        d_r = matmul(transpose(r0), r1)                      # body0_from_body1
        d_p = apply(transpose(r0), [p1[k] - p0[k] for k in range(3)])
        d_p = [1.008 * v + rng.gauss(0.0, 0.01) for v in d_p]
        d_r = matmul(d_r, rot_zyx(0.0004 + rng.gauss(0.0, 0.0005), rng.gauss(0.0, 0.0003), rng.gauss(0.0, 0.0003)))
        p_est = [p_est[k] + apply(r_est, d_p)[k] for k in range(3)]
        r_est = matmul(r_est, d_r)
        out.append((r_est, list(p_est)))
    return out


def write_tum(path, poses, header):
    with open(path, "w") as f:
        f.write("# " + header + "\n# timestamp tx ty tz qx qy qz qw\n")
        for i, (r, p) in enumerate(poses):
            t_ns = T0_NS + i * DT_NS
            q = quat_xyzw(r)
            f.write("%d.%09d %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n" % (t_ns // 10**9, t_ns % 10**9, *p, *q))


if __name__ == "__main__":
    gt = ground_truth()
    est = estimate(gt, random.Random(7))
    write_tum("examples/trajectories/loop_gt.tum", gt, "example ground truth: closed drive, world_from_body")
    write_tum("examples/trajectories/loop_est.tum", est,
              "example estimate: gt motions + 0.8% scale error, yaw-rate bias, noise (tools/make_example_trajectories.py)")
