#!/usr/bin/python3
"""Publishes identity transforms on /tf_static, as a robot's URDF would for
its sensor frames: `static_tf.py PARENT CHILD [CHILD...]`. The ROS checks'
scans come from frames this names (oldbf_node places each scan by tf)."""
import sys

import geometry_msgs.msg
import rospy
import tf2_ros

rospy.init_node("static_tf", anonymous=True, disable_signals=False)
parent, children = sys.argv[1], sys.argv[2:]
broadcaster = tf2_ros.StaticTransformBroadcaster()
transforms = []
for child in children:
    t = geometry_msgs.msg.TransformStamped()
    t.header.stamp = rospy.Time.now()
    t.header.frame_id = parent
    t.child_frame_id = child
    t.transform.rotation.w = 1.0
    transforms.append(t)
broadcaster.sendTransform(transforms)
print("static_tf: %s -> %s" % (parent, " ".join(children)), flush=True)
rospy.spin()
