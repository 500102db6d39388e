#!/usr/bin/env python3
"""The ROS 2 peer of sipnpuff's tests: Eclipse Cyclone DDS (the DDS under
rmw_cyclonedds), an implementation independent of sipnpuff's rustdds.

Subscribes to the command topic as a ROS 2 node would (DDS topic
`rt/<topic>`, type `<pkg>::msg::dds_::<Type>_`, rclcpp's default QoS:
reliable, volatile, keep-last 10) and writes every message, with its
receive time (CLOCK_MONOTONIC, ns), as one JSON line to --out. Floats are
written as their IEEE bits too, so a test compares them exactly.
Optionally publishes a PoseStamped on `rt/<pose_topic>` at 100 Hz: a
fixed pose, or (--follow) the pose an arm executing each command for its
10 ms cycle would have, as a JACO2 driver's tool pose; --pose-silent-after
stops it (the driver's pose gone quiet), --pose-jump-after moves it (the
arm pushed).

Prints `ready` on stdout once its reader (and pose writer) exist. SIGTERM
and SIGINT end it cleanly: the participant is deleted (Cyclone tells the
other side it leaves); SIGKILL of course does not.
"""

import argparse
import json
import os
import signal
import struct
import sys
import threading
import time
import types
from dataclasses import dataclass

from cyclonedds.core import Listener, Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
import cyclonedds.idl.annotations as annotate
from cyclonedds.idl.types import float32, float64, int32, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


def msg(package, name, **fields):
    """The DDS type of ROS 2's `package/msg/name`: a final IDL struct with
    `fields` (name: IDL type) in order."""
    typename = f"{package}::msg::dds_::{name}_"
    cls = types.new_class(
        f"{name}_", (IdlStruct,), {"typename": typename}, lambda ns: ns.update(__annotations__=fields)
    )
    return dataclass(annotate.final(cls))


XYZ = {"x": float64, "y": float64, "z": float64}
# kinova_msgs' velocities: float32 fields, linear then angular.
TWIST_FIELDS = [f"twist_{part}_{axis}" for part in ("linear", "angular") for axis in "xyz"]
FINGER_FIELDS = ["finger1", "finger2", "finger3"]

Time_ = msg("builtin_interfaces", "Time", sec=int32, nanosec=uint32)
Header_ = msg("std_msgs", "Header", stamp=Time_, frame_id=str)
Vector3_ = msg("geometry_msgs", "Vector3", **XYZ)
Twist_ = msg("geometry_msgs", "Twist", linear=Vector3_, angular=Vector3_)
TwistStamped_ = msg("geometry_msgs", "TwistStamped", header=Header_, twist=Twist_)
PoseVelocity_ = msg("kinova_msgs", "PoseVelocity", **dict.fromkeys(TWIST_FIELDS, float32))
PoseVelocityWithFingerVelocity_ = msg(
    "kinova_msgs",
    "PoseVelocityWithFingerVelocity",
    **dict.fromkeys(TWIST_FIELDS + FINGER_FIELDS, float32),
)
Point_ = msg("geometry_msgs", "Point", **XYZ)
Quaternion_ = msg("geometry_msgs", "Quaternion", **XYZ, w=float64)
Pose_ = msg("geometry_msgs", "Pose", position=Point_, orientation=Quaternion_)
PoseStamped_ = msg("geometry_msgs", "PoseStamped", header=Header_, pose=Pose_)

TYPES = {
    "twist_stamped": TwistStamped_,
    "pose_velocity": PoseVelocity_,
    "pose_velocity_with_finger_velocity": PoseVelocityWithFingerVelocity_,
}


def f64_bits(v):
    return struct.unpack("<Q", struct.pack("<d", v))[0]


def f32_bits(v):
    return struct.unpack("<I", struct.pack("<f", v))[0]


def record(sample, kind):
    """The message's values (floats as floats and as bits)."""
    if kind == "twist_stamped":
        t = sample.twist
        values = [t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z]
        return {
            "sec": sample.header.stamp.sec,
            "nanosec": sample.header.stamp.nanosec,
            "frame_id": sample.header.frame_id,
            "values": values,
            "bits": [f64_bits(v) for v in values],
        }
    names = TWIST_FIELDS
    if kind == "pose_velocity_with_finger_velocity":
        names = TWIST_FIELDS + FINGER_FIELDS
    values = [getattr(sample, n) for n in names]
    return {"values": values, "bits": [f32_bits(v) for v in values]}


def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def quat_exp(w, dt):
    """The rotation by the vector w·dt (rad), as (x, y, z, w)."""
    import math

    angle = math.sqrt(sum(c * c for c in w)) * dt
    if angle == 0.0:
        return (0.0, 0.0, 0.0, 1.0)
    s = math.sin(angle / 2) / (angle / dt)
    return (w[0] * s, w[1] * s, w[2] * s, math.cos(angle / 2))


class Arm:
    """The pose of an arm executing each command for one 10 ms cycle."""

    def __init__(self, pose):
        self.lock = threading.Lock()
        self.position = list(pose[:3])
        self.orientation = tuple(pose[3:])

    def execute(self, values):
        v, w = values[0:3], values[3:6]
        with self.lock:
            for i in range(3):
                self.position[i] += v[i] * 0.01
            self.orientation = quat_mul(quat_exp(w, 0.01), self.orientation)

    def push(self, dx):
        with self.lock:
            self.position[0] += dx

    def pose(self):
        with self.lock:
            return list(self.position) + list(self.orientation)


def dds_topic(name):
    return "rt/" + name.lstrip("/")


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--topic", required=True, help="the ROS 2 command topic")
    parser.add_argument("--message", default="twist_stamped", choices=sorted(TYPES))
    parser.add_argument("--out", required=True, help="JSON lines, one per message")
    parser.add_argument("--domain", type=int, default=0)
    parser.add_argument("--pose-topic", help="publish a PoseStamped here at 100 Hz")
    parser.add_argument(
        "--pose",
        type=float,
        nargs=7,
        default=[0.3, -0.2, 0.45, 0.0, 0.0, 0.0, 1.0],
        metavar=("X", "Y", "Z", "QX", "QY", "QZ", "QW"),
    )
    parser.add_argument(
        "--follow", action="store_true", help="the pose follows the commands received"
    )
    parser.add_argument(
        "--pose-silent-after", type=float, metavar="S", help="stop publishing the pose after S s"
    )
    parser.add_argument(
        "--pose-jump-after",
        type=float,
        nargs=2,
        metavar=("S", "DX"),
        help="after S s, move the pose by DX m along x",
    )
    args = parser.parse_args()
    arm = Arm(args.pose)

    stop = threading.Event()

    def on_signal(signum, _frame):
        stop.set()

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)

    out = open(args.out, "w", buffering=1)
    lock = threading.Lock()
    kind = args.message

    dp = DomainParticipant(args.domain)
    # rclcpp's default (rmw_qos_profile_default): reliable, volatile, keep-last 10.
    qos = Qos(
        Policy.Reliability.Reliable(duration(seconds=1)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(10),
    )
    topic = Topic(dp, dds_topic(args.topic), TYPES[kind], qos=qos)

    class OnData(Listener):
        def on_data_available(self, reader):
            now = time.monotonic_ns()
            for sample in reader.take(N=64):
                if type(sample).__name__ == "InvalidSample":
                    continue  # a writer's unregister or dispose: no data
                line = {"t_ns": now}
                line.update(record(sample, kind))
                if args.follow:
                    arm.execute(line["values"])
                with lock:
                    out.write(json.dumps(line) + "\n")

    reader = DataReader(dp, topic, qos=qos, listener=OnData())

    pose_writer = None
    if args.pose_topic:
        pose_topic = Topic(dp, dds_topic(args.pose_topic), PoseStamped_, qos=qos)
        pose_writer = DataWriter(dp, pose_topic, qos=qos)

    print("ready", flush=True)

    started = time.monotonic()
    next_t = started
    jumped = False
    while not stop.is_set():
        since = time.monotonic() - started
        if args.pose_jump_after and not jumped and since >= args.pose_jump_after[0]:
            arm.push(args.pose_jump_after[1])
            jumped = True
        silent = args.pose_silent_after is not None and since >= args.pose_silent_after
        if pose_writer is not None and not silent:
            x, y, z, qx, qy, qz, qw = arm.pose()
            ns = time.time_ns()
            pose_writer.write(
                PoseStamped_(
                    header=Header_(
                        stamp=Time_(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000),
                        frame_id="base_link",
                    ),
                    pose=Pose_(
                        position=Point_(x=x, y=y, z=z),
                        orientation=Quaternion_(x=qx, y=qy, z=qz, w=qw),
                    ),
                )
            )
        next_t += 0.01
        stop.wait(max(0.0, next_t - time.monotonic()))

    # A clean end: delete the entities (the participant's goodbye).
    dp.__del__()  # deletes the reader and writer with it
    with lock:
        out.close()
    os._exit(0)


if __name__ == "__main__":
    sys.exit(main())
