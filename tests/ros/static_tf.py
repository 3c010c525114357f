#!/usr/bin/python3
"""Publishes transforms on /tf_static, as a robot's URDF would for its sensor
frames: `static_tf.py PARENT CHILD[@X,Y,YAW_DEG] ...` (identity without @).
The ROS checks' scans come from frames this names (oldbf_node places each
scan by tf)."""
import math
import sys

import geometry_msgs.msg
import rospy
import tf2_ros

rospy.init_node("static_tf", anonymous=True, disable_signals=False)
parent, children = sys.argv[1], sys.argv[2:]
broadcaster = tf2_ros.StaticTransformBroadcaster()
transforms = []
for spec in children:
    child, _, pose = spec.partition("@")
    x, y, yaw_deg = (float(v) for v in pose.split(",")) if pose else (0.0, 0.0, 0.0)
    t = geometry_msgs.msg.TransformStamped()
    t.header.stamp = rospy.Time.now()
    t.header.frame_id = parent
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y = x, y
    t.transform.rotation.z = math.sin(math.radians(yaw_deg) / 2)
    t.transform.rotation.w = math.cos(math.radians(yaw_deg) / 2)
    transforms.append(t)
broadcaster.sendTransform(transforms)
print("static_tf: %s -> %s" % (parent, " ".join(children)), flush=True)
rospy.spin()
