#!/usr/bin/env python3
"""Cross-check pqm's Hausdorff distance against MeshLab's (via pymeshlab).

Setup (this script installs nothing itself):

    pip install -r scripts/requirements.txt      # pymeshlab, numpy

Usage:

    python3 scripts/hausdorff_check.py [--tolerance 0.05] [--keep DIR]

For each case below the script builds a pair of triangle meshes from a shared
mesh (`<repo>/../shared/meshes`) with pymeshlab itself:

  * `decimate`: the mesh against its quadric-edge-collapse decimation
    (pymeshlab's `meshing_decimation_quadric_edge_collapse`);
  * `noise`: the mesh against a copy whose vertices are displaced by seeded
    Gaussian noise (sigma given as a fraction of the bounding-box diagonal).

Both meshes of a pair are written as triangle-only ASCII OFF files, so both
tools measure exactly the same surfaces. pqm is run through

    cargo run --release -p pqm-core --example hausdorff -- A B --json

(forward = samples on A, distances to B; backward = samples on B, distances
to A) and MeshLab through `get_hausdorff_distance` in both directions
(`maxdist` large enough never to clip a sample). With N = pqm's default
target (10 x the larger triangle count):

  * max: a sampled max only approaches the true max from below, and MeshLab's
    Monte Carlo samples converge slowly, so the reference is MeshLab with
    `samplenum` = 10 N (all vertices, 10 N edge points, 10 N random face
    points). pqm samples all vertices, edge points and stratified face points
    up to `--samples 2N + V`, about as many samples as MeshLab takes at
    `samplenum` = N (the "meshlab@N" column shows that figure for reference);
  * mean: both sample faces only (MeshLab `sampleface` with N Monte Carlo
    samples, pqm `--no-vertices --no-edges --samples N`), so both estimate the
    same area-weighted mean. (With vertex and edge samples mixed in, the means
    depend on how many of each a tool takes, and the tools differ there.)

The script asserts that every max and mean agrees within the tolerance
(relative, default 5 %) and exits with status 1 otherwise. Distances are
compared in absolute units.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

try:
    import numpy as np
    import pymeshlab
except ImportError as exc:  # keep the message actionable
    sys.exit("hausdorff_check.py needs pymeshlab and numpy: "
             "pip install -r scripts/requirements.txt (%s)" % exc)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.normpath(os.path.join(ROOT, "..", "shared", "meshes"))

# (mesh, kind, parameter): decimate -> kept face fraction, noise -> sigma / diag.
CASES = [
    ("tri/fandisk.off", "decimate", 0.10),
    ("tri/fertility.off", "decimate", 0.25),
    ("tri/bunny.off", "decimate", 0.05),
    ("quad/fandisk_quads.off", "noise", 0.002),
    ("quad/spot_quadrangulated.obj", "decimate", 0.20),
    ("large/skull.obj", "noise", 0.001),
]


def make_pair(path, kind, param, out_dir, stem):
    """Writes `<stem>_a.off` (the mesh, triangulated) and `<stem>_b.off`."""
    a_path = os.path.join(out_dir, stem + "_a.off")
    b_path = os.path.join(out_dir, stem + "_b.off")
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(path)
    save = dict(save_vertex_normal=False, save_vertex_color=False, save_polygonal=False)
    ms.save_current_mesh(a_path, **save)
    if kind == "decimate":
        target = max(4, int(ms.current_mesh().face_number() * param))
        ms.meshing_decimation_quadric_edge_collapse(targetfacenum=target,
                                                    preservetopology=True)
    elif kind == "noise":
        m = ms.current_mesh()
        v = m.vertex_matrix()
        diag = m.bounding_box().diagonal()
        rng = np.random.default_rng(12345)
        moved = v + rng.normal(scale=param * diag, size=v.shape)
        ms.add_mesh(pymeshlab.Mesh(vertex_matrix=moved, face_matrix=m.face_matrix()))
    else:
        raise ValueError(kind)
    ms.save_current_mesh(b_path, **save)
    return a_path, b_path


def run_pqm(exe, a_path, b_path, *flags):
    out = subprocess.run([exe, a_path, b_path, "--json", *flags], check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out)


def run_meshlab(a_path, b_path, samplenum, faces_only):
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(a_path)  # id 0
    ms.load_new_mesh(b_path)  # id 1
    # Never clip a sample: ten times the larger diagonal, in absolute units.
    diag = max(ms.mesh(0).bounding_box().diagonal(), ms.mesh(1).bounding_box().diagonal())
    big = pymeshlab.PureValue(10.0 * diag)

    def one(sampled, target):
        r = ms.get_hausdorff_distance(sampledmesh=sampled, targetmesh=target,
                                      samplevert=not faces_only, sampleedge=not faces_only,
                                      sampleface=True, samplenum=samplenum, maxdist=big)
        return {"max": r["max"], "mean": r["mean"], "n": r["n_samples"]}

    return one(0, 1), one(1, 0)


def pymeshlab_vertex_count(path):
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(path)
    return ms.current_mesh().vertex_number()


def rel(a, b):
    return abs(a - b) / max(abs(a), abs(b), 1e-300)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tolerance", type=float, default=0.05)
    ap.add_argument("--keep", help="write the mesh pairs here instead of a temp dir")
    args = ap.parse_args()

    subprocess.run(["cargo", "build", "--release", "-q", "-p", "pqm-core",
                    "--example", "hausdorff"], check=True, cwd=ROOT)
    exe = os.path.join(ROOT, "target", "release", "examples", "hausdorff")

    failures = 0
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = args.keep or tmp
        os.makedirs(out_dir, exist_ok=True)
        print("%-30s %-8s %-8s %11s %11s %11s %7s   %11s %11s %7s" % (
            "mesh", "kind", "dir", "pqm max", "meshlab@10N", "meshlab@N", "diff",
            "pqm mean", "meshlab", "diff"))
        for name, kind, param in CASES:
            path = os.path.join(SHARED, name)
            if not os.path.exists(path):
                print("skip %s (not found)" % path)
                continue
            stem = os.path.basename(name).rsplit(".", 1)[0]
            a_path, b_path = make_pair(path, kind, param, out_dir, stem)
            default = run_pqm(exe, a_path, b_path)
            n = default["report"]["forward_samples"]  # pqm's default target N
            nv = max(pymeshlab_vertex_count(a_path), pymeshlab_vertex_count(b_path))
            ours_max = run_pqm(exe, a_path, b_path, "--samples", str(2 * n + nv))
            ours_mean = run_pqm(exe, a_path, b_path, "--samples", str(n),
                                "--no-vertices", "--no-edges")
            ml_max = run_meshlab(a_path, b_path, 10 * n, faces_only=False)
            ml_max_n = run_meshlab(a_path, b_path, n, faces_only=False)
            ml_mean = run_meshlab(a_path, b_path, n, faces_only=True)
            for i, direction in enumerate(("forward", "backward")):
                mine_max = ours_max["absolute"][direction]["max"]
                mine_mean = ours_mean["absolute"][direction]["mean"]
                theirs_max, theirs_mean = ml_max[i]["max"], ml_mean[i]["mean"]
                d_max, d_mean = rel(mine_max, theirs_max), rel(mine_mean, theirs_mean)
                bad = d_max > args.tolerance or d_mean > args.tolerance
                failures += bad
                print("%-30s %-8s %-8s %11.5g %11.5g %11.5g %6.2f%%   %11.5g %11.5g %6.2f%% %s" % (
                    name, kind, direction, mine_max, theirs_max, ml_max_n[i]["max"],
                    100 * d_max, mine_mean, theirs_mean, 100 * d_mean,
                    "FAIL" if bad else "ok"))
            print("%-30s pqm default sampling: %.2fs for %d + %d samples" % (
                "", default["seconds"], n, default["report"]["backward_samples"]))
    if failures:
        print("%d comparison(s) outside %.1f %%" % (failures, 100 * args.tolerance))
        return 1
    print("all comparisons within %.1f %%" % (100 * args.tolerance))
    return 0


if __name__ == "__main__":
    sys.exit(main())
