#!/usr/bin/python3
"""The kinova driver's tool pose, played by rospy with Debian's
python3-geometry-msgs: publishes geometry_msgs/PoseStamped on
NS/out/tool_pose at 10 Hz (the driver's default status_interval_seconds,
0.1 s), frame_id `<robot>_link_base` as kinova_arm.cpp's publishToolPosition
sets it."""
import argparse, json, sys, time

import rospy
from geometry_msgs.msg import PoseStamped

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ns", required=True)
    ap.add_argument("--pose", nargs=7, type=float, required=True, metavar=("X", "Y", "Z", "QX", "QY", "QZ", "QW"))
    ap.add_argument("--rate", type=float, default=10.0)
    args = ap.parse_args()
    ns = "/" + args.ns.strip("/")
    robot = ns.rsplit("/", 1)[-1]
    if robot.endswith("_driver"):
        robot = robot[: -len("_driver")]
    rospy.init_node(robot + "_pose_publisher", disable_signals=True)
    pub = rospy.Publisher(ns + "/out/tool_pose", PoseStamped, queue_size=2, tcp_nodelay=True)
    print(json.dumps({"ready": ns + "/out/tool_pose"}), flush=True)
    msg = PoseStamped()
    msg.header.frame_id = robot + "_link_base"
    p, q = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z, q.x, q.y, q.z, q.w = args.pose
    period = 1.0 / args.rate
    try:
        while not rospy.is_shutdown():
            msg.header.stamp = rospy.Time.now()
            msg.header.seq += 1
            pub.publish(msg)
            time.sleep(period)
    except KeyboardInterrupt:
        pass

if __name__ == "__main__":
    main()
