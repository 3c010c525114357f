#!/usr/bin/python3
"""Checks an rviz screenshot (PPM P6 from xwdtopnm) is not blank, shows the
safety markers, follows the robot and shows the label: prints JSON and exits
1 otherwise.

* markers: the d_safe circle (red) and the d_act circle (yellow);
* robot-centred: the d_act circle's centre (the median of the yellow pixels:
  the TF display's red axes also mark the odometry origin) is within 10 % of
  the 3-D view's size from the view's centre (the view is the box of pixels in rviz's
  background colour, 40 40 48, from config/oldbf.rviz), late in a run whose
  robot has driven metres away from where it started;
* label: pixels of the label's colour (LABEL_RGB in ros/markers.rs, light
  blue) above the robot, inside the view.

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
    w, h, maxval = int(parts[1]), int(parts[2]), int(parts[3])
    if maxval < 256:
        return w, h, data[pos:pos + 3 * w * h]
    # Two bytes a sample, most significant first (xwdtopnm writes maxval 65535): keep the high byte.
    return w, h, data[pos:pos + 6 * w * h:2]


w, h, px = read_ppm(sys.argv[1])
colors = {}
BACKGROUND = bytes([40, 40, 48])
LABEL = (140, 230, 255)  # 255 * (0.55, 0.9, 1.0)
view = [w, h, -1, -1]  # x0, y0, x1, y1 of background pixels
yellow_xs, yellow_ys = [], []
label_px = []
for i in range(0, len(px), 3):
    c = px[i:i + 3]
    colors[c] = colors.get(c, 0) + 1
    x, y = (i // 3) % w, (i // 3) // w
    if c == BACKGROUND:
        view = [min(view[0], x), min(view[1], y), max(view[2], x), max(view[3], y)]
    elif c[0] > 180 and c[1] > 140 and c[2] < 80:
        yellow_xs.append(x)
        yellow_ys.append(y)
    elif all(abs(c[k] - LABEL[k]) <= 12 for k in range(3)):
        label_px.append((x, y))
n = sum(colors.values())
mean = sum(sum(c) * k for c, k in colors.items()) / (3 * n)
var = sum(((sum(c) / 3 - mean) ** 2) * k for c, k in colors.items()) / n
# The d_safe circle (red) and the d_act circle (yellow) of ~markers.
red = sum(k for c, k in colors.items() if c[0] > 180 and c[1] < 80 and c[2] < 80)
yellow = sum(k for c, k in colors.items() if c[0] > 180 and c[1] > 140 and c[2] < 80)
vw, vh = view[2] - view[0], view[3] - view[1]
centre = ((view[0] + view[2]) / 2, (view[1] + view[3]) / 2)
robot = (sorted(yellow_xs)[len(yellow_xs) // 2], sorted(yellow_ys)[len(yellow_ys) // 2]) if yellow_xs else None
off = [round((robot[k] - centre[k]) / (vw if k == 0 else vh), 3) for k in range(2)] if robot and vw > 0 else None
label_above = [p for p in label_px if robot and p[1] < robot[1] and view[0] <= p[0] <= view[2] and view[1] <= p[1]]
result = {"width": w, "height": h, "distinct_colours": len(colors), "std": round(var ** 0.5, 1),
          "red_pixels": red, "yellow_pixels": yellow, "view": view,
          "robot_offset_from_view_centre": off, "label_pixels_above_robot": len(label_above)}
print(json.dumps(result))
ok = (len(colors) > 20 and var ** 0.5 > 5 and red > 0 and yellow > 0 and off is not None
      and abs(off[0]) <= 0.1 and abs(off[1]) <= 0.1 and len(label_above) >= 50)
sys.exit(0 if ok else 1)
