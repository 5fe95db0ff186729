#!/usr/bin/env python3
"""What ovo_ros published, from a bag `rosbag record` wrote: the odometry as a TUM trajectory and
a JSON summary of the TF, the path and the diagnostics (tests/ros/ros_node_test.sh reads it).

  read_outputs.py RECORDED.bag OUT_TUM OUT_JSON [--odom /ovo/odometry]
"""
import argparse
import json
import math

import rosbag


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bag")
    ap.add_argument("tum")
    ap.add_argument("summary")
    ap.add_argument("--odom", default="/ovo/odometry")
    ap.add_argument("--path", default="/ovo/path")
    args = ap.parse_args()

    odometry = 0
    non_finite = 0
    odom_frames = set()
    tf_odom_base = 0
    path_poses = 0
    diagnostics = []
    static = {}
    with rosbag.Bag(args.bag) as bag, open(args.tum, "w") as tum:
        for topic, msg, _ in bag.read_messages():
            if topic == args.odom:
                p, q = msg.pose.pose.position, msg.pose.pose.orientation
                values = [p.x, p.y, p.z, q.x, q.y, q.z, q.w, msg.twist.twist.linear.x,
                          msg.twist.twist.angular.z]
                if not all(math.isfinite(v) for v in values):
                    non_finite += 1
                    continue
                odometry += 1
                odom_frames.add((msg.header.frame_id, msg.child_frame_id))
                tum.write("%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n" %
                          (msg.header.stamp.to_sec(), p.x, p.y, p.z, q.x, q.y, q.z, q.w))
            elif topic == "/tf_static":
                for t in msg.transforms:
                    v = t.transform.translation
                    static["%s->%s" % (t.header.frame_id, t.child_frame_id)] = [v.x, v.y, v.z]
            elif topic == "/tf":
                tf_odom_base += sum(1 for t in msg.transforms
                                    if t.header.frame_id == "odom" and t.child_frame_id == "base_link")
            elif topic == args.path:
                path_poses = len(msg.poses)
            elif topic == "/diagnostics":
                for s in msg.status:
                    if s.name != "ovo: odometry":
                        continue
                    diagnostics.append({"level": int(s.level), "message": s.message,
                                        "values": {kv.key: kv.value for kv in s.values}})
    last = diagnostics[-1]["values"] if diagnostics else {}
    summary = {
        "odometry": odometry,
        "non_finite": non_finite,
        "odometry_frames": sorted("%s->%s" % f for f in odom_frames),
        "tf_odom_base_link": tf_odom_base,
        "tf_static": static,
        "path_poses": path_poses,
        "diagnostics": len(diagnostics),
        "warnings": [d["message"] for d in diagnostics if d["level"] == 1],
        "errors": [d["message"] for d in diagnostics if d["level"] >= 2],
        "frames_dropped": int(last.get("frames_dropped", "0")),
        "frames_processed": int(last.get("frames_processed", "0")),
        "tracking_losses": int(last.get("tracking_losses", "0")),
        "tracking": last.get("tracking") == "true",
    }
    with open(args.summary, "w") as f:
        json.dump(summary, f, indent=1)


if __name__ == "__main__":
    main()
