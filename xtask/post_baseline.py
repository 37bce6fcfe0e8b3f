"""The baseline for `cargo xtask bench post`: the same 3+2 transform a user would script
with numpy, line by line: read each block, pick out its words, turn the point by the table
rotation about the pivot, write the block back. Arcs get what they need to stay correct:
with the table untilted (B = 0) an arc stays an arc and its centre offset I, J turns with
the table; tilted, the arc is no longer in the machine's XY plane, so it is written as
chords to the same tolerance `lampost post` uses (0.01 mm). Travel is rebuilt as the post
rebuilds it, so the output keeps the same safety rules: off the end of a run straight up to
the safe height (the cell's 150 mm clearance, above this program's work), across there,
straight down to 2.5 mm above the next start, and in at the feed (a straight feed of no
length after travel is travel); a lift and M2 at the end.
The cell's process codes frame each run as the post frames it: laser on at 1000 W and
powder on (M71 S1000, M73) once the head is down, both off (M72, M74) before the lift, so
`lampost verify` can hold the output to the same process rules. (It keeps no limits and
does no verification, so it still does less than `lampost post`.)

Usage: python3 post_baseline.py IN OUT B_DEG C_DEG H
"""
import math
import re
import sys

import numpy as np

TOLERANCE = 0.01  # mm, chord tolerance
SAFE = 150.0  # mm, the NRC cell's clearance_z (the bench's work is far below it)
LIFT = 2.5  # mm, the approach lift
ON = "M71 S1000\nM73\n"  # the NRC cell's laser on (at --power 1000) and powder on
OFF = "M72\nM74\n"  # laser off, powder off


def main():
    src, dst, b, c, h = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
    br, cr = np.radians(b), np.radians(c)
    ry = np.array([[np.cos(br), 0, np.sin(br)], [0, 1, 0], [-np.sin(br), 0, np.cos(br)]])
    rz = np.array([[np.cos(cr), -np.sin(cr), 0], [np.sin(cr), np.cos(cr), 0], [0, 0, 1]])
    m = ry @ rz
    pivot = np.array([0.0, 0.0, -h])
    tilted = b != 0.0
    word = re.compile(r"([XYZIJ])(-?\d*\.?\d+)")
    gword = re.compile(r"G0*([0-3])(?![\d.])")
    feedword = re.compile(r"F(\d*\.?\d+)")
    endword = re.compile(r"M0*(2|30)(?![\d.])")
    pos = np.zeros(3)
    motion = 0
    in_run = False
    ended = False
    feed = "300"
    with open(src) as f, open(dst, "w") as out:
        for line in f:
            found = word.findall(line)
            if not found:
                if endword.search(line):
                    # The program end: lift first.
                    if in_run:
                        out.write(OFF + "G0 Z%.3f\n" % SAFE)
                        in_run = False
                    ended = True
                if line.strip() != "%":
                    out.write(line)
                continue
            g = gword.search(line)
            if g:
                motion = int(g.group(1))
            fw = feedword.search(line)
            if fw:
                feed = fw.group(1)
            arc = motion >= 2
            start = pos.copy()
            if arc:
                ij = np.zeros(2)
            for letter, value in found:
                if letter in "IJ":
                    ij["IJ".index(letter)] = float(value)
                else:
                    pos["XYZ".index(letter)] = float(value)
            if motion == 0:
                # Travel: only its ends matter. Lift off the end of a run.
                if in_run:
                    out.write(OFF + "G0 Z%.3f\n" % SAFE)
                    in_run = False
                continue
            if not in_run and motion == 1 and np.array_equal(pos, start):
                # A straight feed of no length after travel moves nothing and burns
                # nothing: travel, as the post reads it.
                continue
            if not in_run:
                # Over the start at the safe height, down to just above it, in at the feed.
                s0 = m @ (start - pivot) + pivot
                out.write("G0 X%.3f Y%.3f\n" % (-s0[0], -s0[1]))
                out.write("G0 Z%.3f\n" % min(s0[2] + LIFT, SAFE))
                out.write("G1 Z%.3f F%s\n" % (s0[2], feed))
                out.write(ON)
                in_run = True
            if arc and tilted:
                # Chords: the arc in its own plane, then turned like every point.
                centre = start[:2] + ij
                r = math.hypot(start[0] - centre[0], start[1] - centre[1])
                a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
                a1 = math.atan2(pos[1] - centre[1], pos[0] - centre[0])
                sweep = a1 - a0
                if motion == 3 and sweep <= 0:
                    sweep += 2 * math.pi
                elif motion == 2 and sweep >= 0:
                    sweep -= 2 * math.pi
                n = max(1, math.ceil(abs(sweep) / (2 * math.acos(1 - min(TOLERANCE / r, 1.0)))))
                t = np.arange(1, n + 1) / n
                ang = a0 + sweep * t
                pts = np.column_stack(
                    [centre[0] + r * np.cos(ang), centre[1] + r * np.sin(ang), start[2] + (pos[2] - start[2]) * t]
                )
                q = (pts - pivot) @ m.T + pivot
                rows = ["G1 X%.3f Y%.3f Z%.3f" % (-x, -y, z) for x, y, z in q]
                fw = feedword.search(line)
                if fw:
                    rows[0] += " F" + fw.group(1)
                out.write("\n".join(rows) + "\n")
                continue
            q = m @ (pos - pivot) + pivot
            rest = word.sub("", line).strip()
            if arc:
                # Untilted, the arc stays an arc; its centre offset turns with the table
                # (and flips with X and Y, which move the table).
                ij = m[:2, :2] @ ij
                out.write("%s X%.3f Y%.3f Z%.3f I%.3f J%.3f\n" % (rest, -q[0], -q[1], q[2], -ij[0], -ij[1]))
            else:
                out.write("%s X%.3f Y%.3f Z%.3f\n" % (rest, -q[0], -q[1], q[2]))
        if not ended:
            if in_run:
                out.write(OFF)
            out.write("G0 Z%.3f\nM2\n" % SAFE)

if __name__ == "__main__":
    main()
