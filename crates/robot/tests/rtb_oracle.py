"""The Robotics Toolbox for Python's Puma 560 (models.DH.Puma560, classic DH) as an
independent oracle for lampost-robot's forward and closed-form inverse kinematics.

Usage: rtb_oracle.py CASES OUT CONFIGS
CASES: one line of six joint values (radians) per case. CONFIGS: comma-separated
configuration letters (e.g. lun,lunf...). OUT: per case, one line
`fk r11 r12 r13 r21 r22 r23 r31 r32 r33 tx ty tz` (metres), then per configuration one
line `ik CONFIG OK q1 .. q6` (OK 1 when ikine_a reached the pose; q NaN otherwise).
"""
import sys

import numpy as np
import roboticstoolbox as rtb

cases = np.loadtxt(sys.argv[1], ndmin=2)
configs = sys.argv[3].split(",")
robot = rtb.models.DH.Puma560()
with open(sys.argv[2], "w") as out:
    for q in cases:
        T = robot.fkine(q)
        A = T.A
        out.write("fk " + " ".join(repr(float(x)) for x in list(A[:3, :3].ravel()) + list(A[:3, 3])) + "\n")
        for c in configs:
            sol = robot.ikine_a(T, config=c)
            qs = sol.q if sol.success else np.full(6, np.nan)
            out.write(f"ik {c} {int(bool(sol.success))} " + " ".join(repr(float(x)) for x in qs) + "\n")
