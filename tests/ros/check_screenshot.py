#!/usr/bin/python3
"""Checks an rviz screenshot (PPM P6 from xwdtopnm) is not blank and shows
the safety markers: prints JSON and exits 1 if it looks empty.

    check_screenshot.py SHOT.ppm
"""
import json
import sys


def read_ppm(path):
    data = open(path, "rb").read()
    parts, pos = [], 0
    while len(parts) < 4:  # magic, width, height, maxval (skip comments)
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos) + 1
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        parts.append(data[pos:end])
        pos = end
    pos += 1
    assert parts[0] == b"P6", parts[0]
    w, h = int(parts[1]), int(parts[2])
    return w, h, data[pos:pos + 3 * w * h]


w, h, px = read_ppm(sys.argv[1])
colors = {}
for i in range(0, len(px), 3):
    c = px[i:i + 3]
    colors[c] = colors.get(c, 0) + 1
n = sum(colors.values())
mean = sum(sum(c) * k for c, k in colors.items()) / (3 * n)
var = sum(((sum(c) / 3 - mean) ** 2) * k for c, k in colors.items()) / n
# The d_safe circle (red) and the d_act circle (yellow) of ~markers.
red = sum(k for c, k in colors.items() if c[0] > 180 and c[1] < 80 and c[2] < 80)
yellow = sum(k for c, k in colors.items() if c[0] > 180 and c[1] > 140 and c[2] < 80)
result = {"width": w, "height": h, "distinct_colours": len(colors), "std": round(var ** 0.5, 1),
          "red_pixels": red, "yellow_pixels": yellow}
print(json.dumps(result))
ok = len(colors) > 20 and var ** 0.5 > 5 and red > 0 and yellow > 0
sys.exit(0 if ok else 1)
