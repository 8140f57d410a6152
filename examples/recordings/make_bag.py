"""Write the example ROS 1 bag from PSINS' real laser-gyro recording (``../noise``).

    python make_bag.py ../noise/lasergyro.imu.xz -o lasergyro.bag [--seconds 300]

Each 10 ms sample becomes a ``sensor_msgs/Imu`` message on ``/imu`` (frame ``imu``), written by
rosbags' own ROS 1 writer with bz2 chunks: angular velocity [rad/s] and linear acceleration
[m/s^2] are PSINS' increments over the 10 ms interval, as ``inertest noise`` reads them from the
PSINS file (:func:`inertest.io.imu_recording.read_psins`); header stamps are 10 ms apart from
2014-03-21 09:31:51 UTC (the file's own date; PSINS stores no absolute time). Needs
``pip install 'inertest[ros]'``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

#: 2014-03-21 09:31:51 UTC [ns] (the recording's date in its header; no clock time is stored).
T0_NS = 1_395_394_311_000_000_000


def main() -> None:
    """Write the example bag."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    from inertest.io.imu_recording import read_psins

    ap = argparse.ArgumentParser()
    ap.add_argument("psins")
    ap.add_argument("-o", "--output", type=Path, required=True)
    ap.add_argument("--seconds", type=float, default=300.0)
    args = ap.parse_args()
    rec = read_psins(args.psins)
    n = min(rec.gyro.shape[0], round(args.seconds * 100))
    ts = get_typestore(Stores.ROS1_NOETIC)
    t = ts.types
    cov = np.zeros(9)
    w = Writer(args.output)
    w.set_compression(Writer.CompressionFormat.BZ2)
    with w:
        conn = w.add_connection("/imu", "sensor_msgs/msg/Imu", typestore=ts)
        for i in range(n):
            ns = T0_NS + i * 10_000_000
            stamp = t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            g, a = rec.gyro[i], rec.accel[i]
            v3 = t["geometry_msgs/msg/Vector3"]
            msg = t["sensor_msgs/msg/Imu"](
                header=t["std_msgs/msg/Header"](seq=i, stamp=stamp, frame_id="imu"),
                orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
                orientation_covariance=np.r_[-1.0, np.zeros(8)],  # REP 145: no orientation
                angular_velocity=v3(x=g[0], y=g[1], z=g[2]), angular_velocity_covariance=cov,
                linear_acceleration=v3(x=a[0], y=a[1], z=a[2]),
                linear_acceleration_covariance=cov)
            w.write(conn, ns, ts.serialize_ros1(msg, "sensor_msgs/msg/Imu"))
    print(f"wrote {n} messages to {args.output}")


if __name__ == "__main__":
    main()
