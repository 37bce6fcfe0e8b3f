"""The baseline for `cargo xtask bench post`: the same 3+2 transform a user would script
with numpy, line by line: read each block, pick out X Y Z, turn the point by the table
rotation about the pivot, write the block back. (It ignores arcs' centres, modal state and
limits, so it does less than `lampost post`.)

Usage: python3 post_baseline.py IN OUT B_DEG C_DEG H
"""
import re
import sys

import numpy as np


def main():
    src, dst, b, c, h = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
    br, cr = np.radians(b), np.radians(c)
    ry = np.array([[np.cos(br), 0, np.sin(br)], [0, 1, 0], [-np.sin(br), 0, np.cos(br)]])
    rz = np.array([[np.cos(cr), -np.sin(cr), 0], [np.sin(cr), np.cos(cr), 0], [0, 0, 1]])
    m = ry @ rz
    pivot = np.array([0.0, 0.0, -h])
    word = re.compile(r"([XYZ])(-?\d*\.?\d+)")
    pos = np.zeros(3)
    with open(src) as f, open(dst, "w") as out:
        for line in f:
            found = word.findall(line)
            if not found:
                out.write(line)
                continue
            for letter, value in found:
                pos["XYZ".index(letter)] = float(value)
            q = m @ (pos - pivot) + pivot
            rest = word.sub("", line).strip()
            out.write("%s X%.3f Y%.3f Z%.3f\n" % (rest, -q[0], -q[1], q[2]))


if __name__ == "__main__":
    main()
