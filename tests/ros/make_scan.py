#!/usr/bin/python3
"""Prints a sensor_msgs/LaserScan as a YAML mapping for `rostopic pub -s`.

    make_scan.py left    obstacle 0.6 m away, 35-55 deg to the left
    make_scan.py ahead   wall 0.3 m dead ahead (inside r + d_safe = 0.378 m)
    make_scan.py open    nothing in range
    make_scan.py open270 FRAME   nothing in range, 271 beams over 270 deg from -135 deg, from FRAME
360 beams over a full turn from -pi; `stamp: now` is refreshed per message by -s.
"""
import math
import sys

kind = sys.argv[1]
if kind == "open270":
    n = 271
    print(
        "{header: {stamp: now, frame_id: %s}, angle_min: %r, angle_max: %r, angle_increment: %r, "
        "time_increment: 0.0, scan_time: 0.1, range_min: 0.05, range_max: 10.0, ranges: [%s], intensities: []}"
        % (sys.argv[2], -0.75 * math.pi, 0.75 * math.pi, 1.5 * math.pi / (n - 1), ", ".join([".inf"] * n))
    )
    sys.exit(0)
n = 360
ranges = [float("inf")] * n
if kind == "left":
    for i in range(180 + 35, 180 + 56):
        ranges[i] = 0.6
elif kind == "ahead":
    for i in range(180 - 10, 180 + 11):
        ranges[i] = 0.3
elif kind != "open":
    sys.exit("usage: make_scan.py left|ahead|open")
values = ", ".join(".inf" if math.isinf(r) else repr(r) for r in ranges)
print(
    "{header: {stamp: now, frame_id: laser}, angle_min: %r, angle_max: %r, angle_increment: %r, "
    "time_increment: 0.0, scan_time: 0.1, range_min: 0.12, range_max: 3.5, ranges: [%s], intensities: []}"
    % (-math.pi, math.pi - 2 * math.pi / n, 2 * math.pi / n, values)
)
