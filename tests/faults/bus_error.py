#!/usr/bin/env python3
"""Puts a kernel-format CAN error frame on a (virtual) interface.

  bus_error.py IFACE busoff|restarted EVENTS_FILE [MODE]

On vcan every other raw socket with an error filter (the bridge's) receives
it as if the controller had reported it. The moment of sending is written to
EVENTS_FILE as {"mode": MODE (default "bus_<kind>"), "t": time.time()}.
"""
import json
import socket
import struct
import sys
import time

CAN_ERR_FLAG = 0x20000000
CLASSES = {"busoff": 0x00000040, "restarted": 0x00000100}  # CAN_ERR_BUSOFF, CAN_ERR_RESTARTED

iface, kind, events_file = sys.argv[1], sys.argv[2], sys.argv[3]
mode = sys.argv[4] if len(sys.argv) > 4 else "bus_" + kind
s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
s.bind((iface,))
frame = struct.pack("=IB3x8s", CAN_ERR_FLAG | CLASSES[kind], 8, bytes(8))
t = time.time()
s.send(frame)
with open(events_file, "a") as f:
    f.write(json.dumps({"mode": mode, "t": t}) + "\n")
