#!/bin/sh
# The ROS 1 peers of tests/live/arm_ros1.rs: Debian's own ROS 1 (Noetic-era
# packages from bookworm's main archive): a real rosmaster/roscore, rospy
# (whose rospy.AnyMsg subscriber receives the raw kinova_msgs bytes without
# the kinova_msgs package) and geometry_msgs' Python classes (the tool-pose
# publisher), all for Debian's /usr/bin/python3.
# Idempotent (nothing to do when they are there); run as root on a fresh
# Debian machine.
set -eu
export DEBIAN_FRONTEND=noninteractive
installed() {
    command -v rosmaster >/dev/null && /usr/bin/python3 -c 'import rospy, genmsg, geometry_msgs.msg' 2>/dev/null
}
if installed; then
    echo "ROS 1 peers already installed"
    exit 0
fi
apt-get update
apt-get install -y --no-install-recommends ros-core python3-rospy python3-geometry-msgs
command -v rosmaster >/dev/null
installed
echo "ROS 1 peers installed: $(command -v rosmaster), rospy $(/usr/bin/python3 -c 'import rospy, os; print(os.path.dirname(rospy.__file__))')"
