#!/usr/bin/python3
"""The kinova driver's side of `--arm ros1:NS`, played by rospy (Debian's
python3-rospy): subscribes with rospy.AnyMsg (the raw bytes, without the
kinova_msgs package) to NS/in/cartesian_velocity or, with --fingers,
NS/in/cartesian_velocity_with_finger_velocity, as node NS (the name the
driver's node has), and prints one JSON line per message: the receive time
(CLOCK_MONOTONIC, ns) and the float32 fields. The first line is the
publisher's connection header with the md5sum genmsg computes from
kinova-ros's .msg text (kinova_msgs/msg/*.msg, Kinovarobotics/kinova-ros)."""
import argparse, json, struct, sys, time, threading

import genmsg, genmsg.gentools, genmsg.msg_loader
import rospy

POSE_VELOCITY = """float32 twist_linear_x
float32 twist_linear_y
float32 twist_linear_z
float32 twist_angular_x
float32 twist_angular_y
float32 twist_angular_z
"""
WITH_FINGER_VELOCITY = POSE_VELOCITY + """float32 finger1
float32 finger2
float32 finger3
"""

def genmsg_md5(name, text):
    context = genmsg.MsgContext.create_default()
    spec = genmsg.msg_loader.load_msg_from_string(context, text, name)
    genmsg.msg_loader.load_depends(context, spec, {})
    return genmsg.gentools.compute_md5(context, spec)

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ns", required=True)
    ap.add_argument("--fingers", action="store_true")
    args = ap.parse_args()
    ns = "/" + args.ns.strip("/")
    if args.fingers:
        topic, name, text, fmt = ns + "/in/cartesian_velocity_with_finger_velocity", "kinova_msgs/PoseVelocityWithFingerVelocity", WITH_FINGER_VELOCITY, "<9f"
    else:
        topic, name, text, fmt = ns + "/in/cartesian_velocity", "kinova_msgs/PoseVelocity", POSE_VELOCITY, "<6f"
    expected = genmsg_md5(name, text)
    lock = threading.Lock()
    first = [True]
    out = sys.stdout

    def received(msg):
        t = time.monotonic_ns()
        with lock:
            if first[0]:
                first[0] = False
                header = dict(msg._connection_header)
                header.pop("message_definition", None)
                out.write(json.dumps({"header": header, "genmsg_md5": expected, "genmsg_type": name}) + "\n")
            out.write(json.dumps({"t_ns": t, "len": len(msg._buff), "v": list(struct.unpack(fmt, msg._buff)) if len(msg._buff) == struct.calcsize(fmt) else None}) + "\n")
            out.flush()

    rospy.init_node(ns.lstrip("/").split("/")[-1] if ns.count("/") == 1 else ns.lstrip("/").replace("/", "_"), disable_signals=True)
    rospy.Subscriber(topic, rospy.AnyMsg, received, queue_size=1000, tcp_nodelay=True)
    out.write(json.dumps({"ready": topic, "node": rospy.get_name()}) + "\n")
    out.flush()
    try:
        while not rospy.is_shutdown():
            time.sleep(0.1)
    except KeyboardInterrupt:
        pass

if __name__ == "__main__":
    main()
