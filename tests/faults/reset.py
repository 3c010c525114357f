#!/usr/bin/env python3
"""Calls the bridge's ~reset (std_srvs/Trigger) with nothing but the
standard library: master lookup over XML-RPC, then one TCPROS call. rospy
and rosservice take tens of seconds to import under QEMU TCG, which would
blur the faults' recovery timing.

  reset.py SERVICE EVENTS_FILE MODE

Appends {"mode": MODE, "t": ...} (realtime, when the call was made) and
{"mode": MODE + "_done", ...} to EVENTS_FILE; exits 1 if the call failed.
"""
import json
import os
import socket
import struct
import sys
import time
import xmlrpc.client

TRIGGER_MD5 = "937c9679a518e3a18d831e57125ea522"  # std_srvs/Trigger
CALLER = "/fault_reset"


def field(k, v):
    b = f"{k}={v}".encode()
    return struct.pack("<I", len(b)) + b


def recv_exact(s, n):
    out = b""
    while len(out) < n:
        chunk = s.recv(n - len(out))
        if not chunk:
            raise ConnectionError("connection closed")
        out += chunk
    return out


def main():
    service, events, mode = sys.argv[1], sys.argv[2], sys.argv[3]
    master = xmlrpc.client.ServerProxy(os.environ.get("ROS_MASTER_URI", "http://localhost:11311/"))
    code, msg, uri = master.lookupService(CALLER, service)
    if code != 1:
        print(f"reset: lookupService({service}): {msg}", file=sys.stderr)
        return 1
    host, port = uri[len("rosrpc://"):].rstrip("/").rsplit(":", 1)
    s = socket.create_connection((host, int(port)), timeout=10)
    hdr = field("callerid", CALLER) + field("service", service) + field("md5sum", TRIGGER_MD5) + field("persistent", "0")
    t = time.time()
    with open(events, "a") as f:
        f.write(json.dumps({"mode": mode, "t": t}) + "\n")
    s.sendall(struct.pack("<I", len(hdr)) + hdr + struct.pack("<I", 0))
    (hlen,) = struct.unpack("<I", recv_exact(s, 4))
    recv_exact(s, hlen)  # the server's header
    ok = recv_exact(s, 1)[0]
    (blen,) = struct.unpack("<I", recv_exact(s, 4))
    body = recv_exact(s, blen)
    t_done = time.time()
    with open(events, "a") as f:
        f.write(json.dumps({"mode": mode + "_done", "t": t_done}) + "\n")
    success = ok == 1 and blen >= 1 and body[0] == 1
    text = body[5:].decode(errors="replace") if blen >= 5 else body.decode(errors="replace")
    print(f"reset: ok={ok} success={success} message={text!r} ({t_done - t:.3f} s)")
    return 0 if success else 1


if __name__ == "__main__":
    sys.exit(main())
