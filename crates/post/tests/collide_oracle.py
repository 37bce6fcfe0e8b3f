#!/usr/bin/env python3
"""An independent oracle for lampost's part-mesh collision checks (collide.rs).

Run by crates/post/tests/collide_oracle.rs with the interpreter of .tools/py
(scripts/install-python.sh):

    python collide_oracle.py CASES OUT MESH.stl [MESH.stl ...]

CASES has one case a line:

    S mesh ax ay az bx by bz                       a rapid: the tip moves a -> b
    H mesh ax ay az bx by bz ux uy uz r len so     the head: a cylinder of radius r
                                                   along u from tip + so*u to
                                                   tip + len*u, the tip moving a -> b

OUT gets, for each case, `verdict margin t`:

- verdict 1 when the path meets the part (a rapid: trimesh's ray test along a -> b,
  or a starts inside a watertight mesh; the head: the swept cylinder meets a
  triangle, or its centre starts inside a watertight mesh);
- margin, signed (+ clear, - hit): how far the case is from flipping. For a clear
  case, the exact distance from the swept path to the mesh (below), capped at CAP
  of the mesh's size; for a hit, the depth (the swept head's reach into the
  surface; a rapid's deepest point inside a watertight mesh, or on the far side of
  an open one and away from its boundary), sampled, so at most the true depth;
- t: the fraction of a rapid where trimesh's ray first meets the mesh (nan else).

The exact distance uses convexity, not trimesh: for one triangle T and the head C
moving along d, f(t, p) = sdf_C(p - a - t d) is jointly convex in (t, p), so
min over t in [0,1] and p in T is found by nested golden-section searches (t,
then the two barycentric coordinates), after a coarse grid has dropped the
triangles that cannot be nearest. A rapid is the same with a cylinder of radius
and length 0 (the distance to the tip).
"""

import sys

import numpy as np
import trimesh

CAP = 2e-3  # exact margins only below this fraction of the mesh's size
GOLD = 36  # golden-section steps per level: 0.618^36 ~ 2e-8 of each interval


def sdf_cylinder(x, u, r, lo, hi):
    """Signed distance from points x (..., 3), in the tip's frame, to the cylinder of
    radius r along u from lo*u to hi*u (r = lo = hi = 0: the distance to the tip)."""
    s = np.einsum("...k,...k->...", x, u)
    radial = x - s[..., None] * u
    rho = np.sqrt(np.einsum("...k,...k->...", radial, radial))
    mid = 0.5 * (lo + hi)
    half = 0.5 * (hi - lo)
    qx = rho - r
    qy = np.abs(s - mid) - half
    outside = np.hypot(np.maximum(qx, 0.0), np.maximum(qy, 0.0))
    return np.minimum(np.maximum(qx, qy), 0.0) + outside


class Pairs:
    """(case, triangle) pairs in flat arrays, for the convex minimisation."""

    def __init__(self, a, d, u, r, lo, hi, p0, e1, e2):
        self.a, self.d, self.u = a, d, u
        self.r, self.lo, self.hi = r, lo, hi
        self.p0, self.e1, self.e2 = p0, e1, e2

    def f(self, t, al, be):
        p = self.p0 + al[:, None] * self.e1 + be[:, None] * self.e2
        x = p - self.a - t[:, None] * self.d
        return sdf_cylinder(x, self.u, self.r, self.lo, self.hi)


def golden(fun, lo, hi):
    """Minimum of convex functions, elementwise, over [lo, hi] (arrays)."""
    g = (np.sqrt(5.0) - 1.0) / 2.0
    x1 = hi - g * (hi - lo)
    x2 = lo + g * (hi - lo)
    f1, f2 = fun(x1), fun(x2)
    best = np.minimum(np.minimum(f1, f2), np.minimum(fun(lo), fun(hi)))
    for _ in range(GOLD):
        left = f1 <= f2
        hi = np.where(left, x2, hi)
        lo = np.where(left, lo, x1)
        x2n = np.where(left, x1, lo + g * (hi - lo))
        x1n = np.where(left, hi - g * (hi - lo), x2)
        fnew = fun(np.where(left, x1n, x2n))
        f1, f2 = np.where(left, fnew, f2), np.where(left, f1, fnew)
        x1, x2 = x1n, x2n
        best = np.minimum(best, fnew)
    return best


def exact_min(pr):
    """min over t in [0,1], (al, be) in the simplex of pr.f, for every pair."""
    n = len(pr.r)
    zeros, ones = np.zeros(n), np.ones(n)

    def over_t(t):
        def over_al(al):
            return golden(lambda be: pr.f(t, al, be), zeros, 1.0 - al)

        return golden(over_al, zeros, ones)

    return golden(over_t, zeros, ones)


def coarse(pr, nt=9, ns=12):
    """Sampled minimum (an upper bound) and a lower bound (less the Lipschitz
    slack of the grid) for every pair."""
    n = len(pr.r)
    best = np.full(n, np.inf)
    for t in np.linspace(0.0, 1.0, nt):
        for i in range(ns + 1):
            for j in range(ns + 1 - i):
                al = np.full(n, i / ns)
                be = np.full(n, j / ns)
                best = np.minimum(best, pr.f(np.full(n, t), al, be))
    ht = 1.0 / (nt - 1)
    hs = 1.0 / ns
    slack = (
        0.5 * ht * np.linalg.norm(pr.d, axis=1)
        + hs * (np.linalg.norm(pr.e1, axis=1) + np.linalg.norm(pr.e2, axis=1))
    )
    return best, best - slack


def swept_aabb(a, b, u, r, lo, hi):
    """Box of the cylinder (or point) swept from tip a to tip b."""
    ext = 0.5 * (hi - lo) * np.abs(u) + r * np.sqrt(np.maximum(0.0, 1.0 - u * u))
    c0 = a + 0.5 * (lo + hi) * u
    c1 = b + 0.5 * (lo + hi) * u
    return np.minimum(c0, c1) - ext, np.maximum(c0, c1) + ext


def clearances(jobs):
    """For each job (mesh, cases, size): the exact distance from each case's swept
    shape to the mesh, capped at CAP*size (negative: the depth of the deepest
    triangle point inside the swept shape). All jobs share one minimisation."""
    outs = []
    cols = [[] for _ in range(9)]
    owner = []  # (job, case) of each pair
    for ji, (mesh, cases, size) in enumerate(jobs):
        cap = CAP * size
        outs.append(np.full(len(cases), cap))
        tris = mesh.triangles
        tlo, thi = tris.min(axis=1), tris.max(axis=1)
        for ci, (a, b, u, r, lo, hi) in enumerate(cases):
            blo, bhi = swept_aabb(a, b, u, r, lo, hi)
            gap = np.maximum(0.0, np.maximum(tlo - bhi, blo - thi))
            near = np.nonzero(np.linalg.norm(gap, axis=1) <= cap)[0]
            if len(near) == 0:
                continue
            k = len(near)
            p0 = tris[near, 0]
            for col, val in zip(cols, (
                np.tile(a, (k, 1)), np.tile(b - a, (k, 1)), np.tile(u, (k, 1)),
                np.full(k, r), np.full(k, lo), np.full(k, hi),
                p0, tris[near, 1] - p0, tris[near, 2] - p0,
            )):
                col.append(val)
            owner.extend([(ji, ci, cap)] * k)
    if not owner:
        return outs
    pr = Pairs(*(np.concatenate(c) for c in cols))
    key = np.array([hash((j, c)) for j, c, _ in owner])
    _, group = np.unique(key, return_inverse=True)
    caps = np.array([c for _, _, c in owner])
    ub, lb = coarse(pr)
    group_ub = np.full(group.max() + 1, np.inf)
    np.minimum.at(group_ub, group, ub)
    # Refine only the pairs that can be their case's nearest and lie within the
    # cap, in cases that are not deep hits already.
    refine = (lb <= np.minimum(group_ub[group], caps)) & (group_ub[group] > -caps)
    best = ub.copy()
    if refine.any():
        sub = Pairs(*(x[refine] for x in (
            pr.a, pr.d, pr.u, pr.r, pr.lo, pr.hi, pr.p0, pr.e1, pr.e2)))
        best[refine] = np.minimum(ub[refine], exact_min(sub))
    for (ji, ci, _), v in zip(owner, best):
        outs[ji][ci] = min(outs[ji][ci], v)
    return outs


def boundary_distance(mesh, pts):
    """Distance from points to the mesh's boundary edges (inf when closed)."""
    edges = mesh.edges_sorted
    groups = trimesh.grouping.group_rows(edges, require_count=1)
    if len(groups) == 0:
        return np.full(len(pts), np.inf)
    e = edges[groups]
    p, q = mesh.vertices[e[:, 0]], mesh.vertices[e[:, 1]]
    out = np.empty(len(pts))
    for i, x in enumerate(pts):
        dq = q - p
        t = np.clip(np.einsum("ij,ij->i", x - p, dq) / np.einsum("ij,ij->i", dq, dq), 0, 1)
        out[i] = np.min(np.linalg.norm(p + t[:, None] * dq - x, axis=1))
    return out


def side(mesh, pts):
    """Signed distance to the surface: the sign from the nearest face's normal."""
    closest, dist, tri = trimesh.proximity.closest_point(mesh, pts)
    s = np.einsum("ij,ij->i", pts - closest, mesh.face_normals[tri])
    return np.where(s >= 0.0, dist, -dist)


def segments(mesh, cases, size):
    n = len(cases)
    A = np.array([c[0] for c in cases])
    B = np.array([c[1] for c in cases])
    D = B - A
    L = np.linalg.norm(D, axis=1)
    verdict = np.zeros(n, dtype=bool)
    t_hit = np.full(n, np.nan)
    moving = L > 0
    if moving.any():
        idx = np.nonzero(moving)[0]
        dirs = D[idx] / L[idx, None]
        locs, iray, _ = mesh.ray.intersects_location(A[idx], dirs, multiple_hits=True)
        for loc, k in zip(locs, iray):
            c = idx[k]
            s = np.dot(loc - A[c], dirs[k])
            if -1e-12 * size <= s <= L[c] * (1 + 1e-12):
                tt = max(0.0, s / L[c])
                if not verdict[c] or tt < t_hit[c]:
                    t_hit[c] = tt
                verdict[c] = True
    watertight = mesh.is_watertight
    if watertight:
        inside = mesh.contains(A)
        t_hit[inside] = 0.0
        verdict |= inside
    margin = np.zeros(n)
    clear = np.nonzero(~verdict)[0]
    job = (
        mesh,
        [(A[c], B[c], np.array([0.0, 0.0, 1.0]), 0.0, 0.0, 0.0) for c in clear],
        size,
    )

    def finish(dist):
        margin[clear] = dist

    ts = np.linspace(0.0, 1.0, 401)
    for c in np.nonzero(verdict)[0]:
        pts = A[c] + ts[:, None] * D[c]
        if watertight:
            depth = np.max(trimesh.proximity.signed_distance(mesh, pts))
        else:
            s = side(mesh, pts)
            s0 = s[0] if s[0] != 0 else -s[-1]
            far = s * np.sign(s0) < 0
            depth = np.max(np.abs(s[far])) if far.any() else 0.0
            depth = min(depth, boundary_distance(mesh, [A[c] + t_hit[c] * D[c]])[0])
        margin[c] = -max(depth, 0.0)
    return verdict, margin, t_hit, job, finish


def heads(mesh, cases, size):
    n = len(cases)
    geo = []
    for a, b, u, r, ln, so in cases:
        u = u / np.linalg.norm(u)
        geo.append((a, b, u, r, so, ln))
    verdict = np.zeros(n, dtype=bool)
    margin = np.zeros(n)
    inside = np.zeros(n, dtype=bool)
    if mesh.is_watertight:
        centres = np.array([a + 0.5 * (so + ln) * u for a, _, u, _, so, ln in geo])
        inside = mesh.contains(centres)

    def finish(dist):
        verdict[:] = (dist <= 0.0) | inside
        # Inside and clear of the surface: a hit by as much as the clearance.
        margin[:] = np.where(inside, np.where(dist > 0, -dist, -size), dist)

    return verdict, margin, np.full(n, np.nan), (mesh, geo, size), finish


def main(argv):
    cases_path, out_path, *mesh_paths = argv
    meshes = [trimesh.load(p, force="mesh") for p in mesh_paths]
    seg_cases, head_cases = [], []
    for line in open(cases_path):
        w = line.split()
        if not w:
            continue
        m = int(w[1])
        x = [float(v) for v in w[2:]]
        a, b = np.array(x[0:3]), np.array(x[3:6])
        if w[0] == "S":
            seg_cases.append((m, a, b))
        else:
            head_cases.append((m, a, b, np.array(x[6:9]), x[9], x[10], x[11]))
    results = {}
    pending = []
    for mi, mesh in enumerate(meshes):
        size = float(np.linalg.norm(mesh.bounds[1] - mesh.bounds[0]))
        si = [i for i, c in enumerate(seg_cases) if c[0] == mi]
        if si:
            got = segments(mesh, [seg_cases[i][1:] for i in si], size)
            pending.append(("S", si, got))
        hi = [i for i, c in enumerate(head_cases) if c[0] == mi]
        if hi:
            got = heads(mesh, [head_cases[i][1:] for i in hi], size)
            pending.append(("H", hi, got))
    # One minimisation for every clear case of every mesh.
    dists = clearances([got[3] for _, _, got in pending])
    for (kind, ids, (v, mg, t, _, finish)), dist in zip(pending, dists):
        finish(dist)
        for k, i in enumerate(ids):
            results[(kind, i)] = (v[k], mg[k], t[k])
    with open(out_path, "w") as out:
        si = hi = 0
        for line in open(cases_path):
            w = line.split()
            if not w:
                continue
            if w[0] == "S":
                v, mg, t = results[("S", si)]
                si += 1
            else:
                v, mg, t = results[("H", hi)]
                hi += 1
            out.write(f"{int(v)} {float(mg)!r} {float(t)!r}\n")


if __name__ == "__main__":
    main(sys.argv[1:])
