"""Helpers of the firmware FMU tests (test_firmware_fmu, test_firmware_fmu_can; no tests
here): a wheel model that closes the loop around the micro, and the frames a host sends
(the three default config frames, a micro_cmd) from the Python codec."""

from __future__ import annotations

import math

from navkit import protocol

__all__ = ["MM_PER_COUNT", "TRACK_MM", "LSB_PER_DPS", "Wheels", "config_frames", "cmd"]

MM_PER_COUNT = math.pi * 100.0 / 2000.0  # spec default geometry: mm of travel per encoder count
TRACK_MM = 300.0                         # wheel track, mm
LSB_PER_DPS = 131.0                      # gyro scale, LSB per deg/s


class Wheels:
    """A differential-drive robot: each wheel's speed (mm/s) follows duty * top_speed
    (first-order lag of `tau` s), encoders integrate it, the gyro reads the yaw rate (CCW
    positive) plus `gyro_bias` LSB."""

    def __init__(self, top_speed=1.0 / 0.0018, tau=0.03, gyro_bias=0):
        self.top, self.tau, self.bias = top_speed, tau, gyro_bias
        self.v = [0.0, 0.0]
        self.enc = [0.0, 0.0]
        self.dist = 0.0
        self.yaw_cw = 0.0

    def drive(self, micro):
        """Set the micro's sensor inputs (encoders, gyro) from the model's state."""
        w_cw = (self.v[0] - self.v[1]) / TRACK_MM * 180.0 / math.pi
        micro.set(enc_left=math.floor(self.enc[0]), enc_right=math.floor(self.enc[1]),
                  gyro_raw=round(-w_cw * LSB_PER_DPS) + self.bias)

    def advance(self, micro, h: float):
        """Advance the model `h` s under the micro's motor duties."""
        duties = (micro.get("motor_left_duty"), micro.get("motor_right_duty"))
        for i, d in enumerate(duties):
            self.v[i] += (d * self.top - self.v[i]) * h / (self.tau + h)
            self.enc[i] += self.v[i] * h / MM_PER_COUNT
        self.dist += 0.5 * (self.v[0] + self.v[1]) * h
        self.yaw_cw += (self.v[0] - self.v[1]) / TRACK_MM * 180.0 / math.pi * h


def config_frames(hash_override=None) -> bytes:
    """The three config frames with the spec's defaults (time tags 1..3); `hash_override`
    replaces their spec_hash."""
    frames = b""
    for tag, name in enumerate(("micro_cfg_geometry", "micro_cfg_motion", "micro_cfg_io"), 1):
        fields = protocol.defaults(name)
        if hash_override is not None:
            fields["spec_hash"] = hash_override
        frames += protocol.encode_frame(name, fields, time_tag=tag)
    return frames


def cmd(tag, **fields) -> bytes:
    """A micro_cmd frame of `fields` (the rest 0) with time tag `tag`."""
    return protocol.encode_frame("micro_cmd", fields, time_tag=tag)
