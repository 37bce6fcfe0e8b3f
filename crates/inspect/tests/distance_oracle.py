"""Independent signed distances for lampost-inspect's (crates/inspect/tests/distance_oracle.rs
and `cargo xtask bench inspect`).

usage: distance_oracle.py open3d|trimesh [--repeat N] (NV NT NP MESH.bin POINTS.bin OUT.bin)...

MESH.bin: NV vertices (float64 x y z, little-endian) then NT triangles (uint32 a b c);
POINTS.bin: NP points (float64). OUT.bin gets NP float64 signed distances (negative
inside), and the script prints the seconds the distance query alone took (the best of
N runs, default 1), one line a job.

open3d: RaycastingScene.compute_signed_distance (Open3D computes in float32: vertices and
points are rounded to float32 first; the sign by counting ray crossings, 3 rays).
trimesh: the closest point on every triangle whose bounding box is nearer than the best
found (trimesh.triangles.closest_point, float64), Trimesh.contains for the sign.
"""
import sys
import time

import numpy as np


def main():
    which, args = sys.argv[1], sys.argv[2:]
    repeat = 1
    if args[:1] == ["--repeat"]:
        repeat, args = int(args[1]), args[2:]
    for k in range(0, len(args), 6):
        job(which, repeat, *args[k : k + 6])


def job(which, repeat, nv, nt, npt, mesh, points, out):
    nv, nt, npt = int(nv), int(nt), int(npt)
    raw = open(mesh, "rb").read()
    v = np.frombuffer(raw[: nv * 24], dtype="<f8").reshape(nv, 3)
    t = np.frombuffer(raw[nv * 24 : nv * 24 + nt * 12], dtype="<u4").reshape(nt, 3)
    p = np.fromfile(points, dtype="<f8").reshape(npt, 3)
    best = float("inf")
    if which == "open3d":
        import open3d as o3d

        for _ in range(repeat):
            start = time.perf_counter()
            scene = o3d.t.geometry.RaycastingScene()
            scene.add_triangles(
                o3d.core.Tensor(v.astype(np.float32)), o3d.core.Tensor(t.astype(np.uint32))
            )
            d = scene.compute_signed_distance(
                o3d.core.Tensor(p.astype(np.float32)), nsamples=3
            ).numpy()
            best = min(best, time.perf_counter() - start)
        d = d.astype(np.float64)
    elif which == "trimesh":
        import trimesh

        m = trimesh.Trimesh(vertices=v, faces=t.astype(np.int64), process=False)
        tri = m.triangles
        lo, hi = tri.min(axis=1), tri.max(axis=1)
        start = time.perf_counter()
        dist = np.empty(npt)
        for k, q in enumerate(p):
            # Every triangle whose box is nearer than the best distance found is
            # measured exactly, so the nearest is never missed (trimesh's own
            # proximity.closest_point missed it for a point near eight.off).
            box = np.linalg.norm(np.maximum(0.0, np.maximum(lo - q, q - hi)), axis=1)
            near = np.argpartition(box, min(32, len(box) - 1))[:32]
            cp = trimesh.triangles.closest_point(tri[near], np.repeat(q[None], len(near), 0))
            best_d = np.linalg.norm(cp - q, axis=1).min()
            cand = np.nonzero(box <= best_d)[0]
            cp = trimesh.triangles.closest_point(tri[cand], np.repeat(q[None], len(cand), 0))
            dist[k] = np.linalg.norm(cp - q, axis=1).min()
        inside = m.contains(p)
        best = time.perf_counter() - start
        d = np.where(inside, -dist, dist)
    else:
        raise SystemExit(f"unknown oracle {which}")
    d.astype("<f8").tofile(out)
    print(f"{best:.6f}")


if __name__ == "__main__":
    main()
