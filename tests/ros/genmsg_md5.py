#!/usr/bin/python3
"""Prints the md5sum ROS computes for a message or service type, with ROS's
own genmsg library, from the definitions installed in /usr/share/<pkg>/
(plus extra package dirs given as PKG:DIR). Used where `rosmsg md5` has no
Python class to load (e.g. nav_msgs without python3-nav-msgs).

    genmsg_md5.py msg|srv TYPE [PKG:MSGDIR ...]
"""
import glob
import os
import sys

import genmsg
import genmsg.msg_loader

kind, name = sys.argv[1], sys.argv[2]
search = {}
for d in glob.glob("/usr/share/*/msg"):
    search.setdefault(os.path.basename(os.path.dirname(d)), []).append(d)
for extra in sys.argv[3:]:
    pkg, d = extra.split(":", 1)
    search.setdefault(pkg, []).append(d)
ctx = genmsg.MsgContext.create_default()
if kind == "msg":
    spec = genmsg.msg_loader.load_msg_by_type(ctx, name, search)
    genmsg.msg_loader.load_depends(ctx, spec, search)
else:
    pkg = name.split("/")[0]
    path = "/usr/share/%s/srv/%s.srv" % (pkg, name.split("/")[1])
    spec = genmsg.msg_loader.load_srv_from_file(ctx, path, name)
    genmsg.msg_loader.load_depends(ctx, spec, search)
print(genmsg.compute_md5(ctx, spec))
