"""Independent slicer for crates/plan/tests/slice_oracle.rs: trimesh on the same mesh
file at the same plane heights.

- loops: the closed curves of trimesh's `section_multiplane` (its own chaining of the
  segments into paths);
- area: from trimesh's `mesh_multiplane` segments, each oriented by its face's normal
  (along normal x face normal) and summed as 1/2 n.(p0 x p1): the signed area of the
  section, outer loops minus holes, independent of any chaining. (trimesh's own polygon
  areas go through shapely, which repairs self-touching loops, e.g. CGAL's cow, and so
  measures another polygon.)

argv: jobs.json out.json. jobs: [{"file": path, "normal": [x, y, z], "heights": [...]}].
Writes, per job, per height: [closed loops, signed area]."""
import json
import sys

import numpy as np
import trimesh


def main():
    jobs = json.load(open(sys.argv[1]))
    out = []
    for job in jobs:
        mesh = trimesh.load(job["file"], process=False)
        normal = np.asarray(job["normal"], dtype=np.float64)
        heights = np.asarray(job["heights"], dtype=np.float64)
        origin = np.zeros(3)
        paths = mesh.section_multiplane(
            plane_origin=origin, plane_normal=normal, heights=heights
        )
        lines, to_3d, faces = trimesh.intersections.mesh_multiplane(
            mesh, plane_origin=origin, plane_normal=normal, heights=heights
        )
        fn = mesh.face_normals
        layers = []
        for p, l2, t, f in zip(paths, lines, to_3d, faces):
            loops = 0 if p is None else sum(1 for e in p.entities if e.closed)
            if len(l2) == 0:
                layers.append([loops, 0.0])
                continue
            pts = trimesh.transform_points(
                np.column_stack([l2.reshape(-1, 2), np.zeros(len(l2) * 2)]), t
            ).reshape(-1, 2, 3)
            along = np.cross(normal, fn[f])
            flip = np.einsum("ij,ij->i", pts[:, 1] - pts[:, 0], along) < 0
            pts[flip] = pts[flip][:, ::-1]
            area = 0.5 * np.einsum("ij,j->i", np.cross(pts[:, 0], pts[:, 1]), normal).sum()
            layers.append([loops, float(area)])
        out.append(layers)
    json.dump(out, open(sys.argv[2], "w"))


main()
