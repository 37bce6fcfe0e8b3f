"""The baseline for `cargo xtask bench plan`: trimesh's section_multiplane on the same
mesh at the same plane heights (what a user would script). The mesh is loaded and its
cached properties built before timing; the best of 3 calls is reported.

Usage: python plan_baseline.py MESH.off NX NY NZ HEIGHTS.txt
Prints: seconds loops"""
import sys
import time

import numpy as np
import trimesh


def main():
    mesh = trimesh.load(sys.argv[1], process=False)
    normal = np.array([float(v) for v in sys.argv[2:5]])
    heights = np.loadtxt(sys.argv[5], dtype=np.float64, ndmin=1)
    best = float("inf")
    loops = 0
    for _ in range(3):
        t = time.perf_counter()
        paths = mesh.section_multiplane(
            plane_origin=np.zeros(3), plane_normal=normal, heights=heights
        )
        best = min(best, time.perf_counter() - t)
        loops = sum(0 if p is None else sum(1 for e in p.entities if e.closed) for p in paths)
    print(best, loops)


main()
