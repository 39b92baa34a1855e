#!/usr/bin/env python3
"""Writes the ULog fuzz seeds (fuzz/corpus/ulog/): small synthetic PX4 logs generated here, not cut
from any third-party file. Same layout as logs/test/support/ulog_writer.h: attitude, two raw
magnetometers (sensor_mag 0, 1), a calibrated one (vehicle_magnetometer), battery, motors, a nested
type, a parameter, an info string and a text message; the third also the PX4 state the importer reads
beside the sensors (actuator_armed, vehicle_status, throttle, CAL_MAG_COMP_TYP and CAL_MAGn_* with a
rotation beyond 25 and the release that fixes its meaning)."""
import math
import os
import struct

here = os.path.dirname(os.path.abspath(__file__))
out = os.path.join(here, "corpus", "ulog")


def msg(kind, payload):
    return struct.pack("<HB", len(payload), ord(kind)) + payload


def param(name, fmt, value):
    key = (b"int32_t " if fmt == "<i" else b"float ") + name
    return msg("P", bytes([len(key)]) + key + struct.pack(fmt, value))


def log(raw_mags, records, state=False):
    b = b"ULog\x01\x12\x35\x01" + struct.pack("<Q", 1000000)
    key = b"char[8] ver_sw"
    b += msg("I", bytes([len(key)]) + key + b"v1.14.0\x00")
    key = b"float CA_ROTOR_COUNT"
    b += msg("P", bytes([len(key)]) + key + struct.pack("<f", 4.0))
    if state:
        key = b"uint32_t ver_sw_release"
        b += msg("I", bytes([len(key)]) + key + struct.pack("<I", 0x010E0000))
        b += param(b"CAL_MAG_COMP_TYP", "<i", 1) + param(b"CAL_MAG0_ID", "<i", 7) + param(b"CAL_MAG0_ROT", "<i", 38)
        b += param(b"CAL_MAG0_XCOMP", "<f", 0.05) + param(b"CAL_MAG0_ZCOMP", "<f", -0.1)
    for f in (b"vehicle_attitude:uint64_t timestamp;float[4] q;uint8_t[4] _padding0;",
              b"vec3:float x;float y;float z;",
              b"sensor_mag:uint64_t timestamp;uint32_t device_id;float x;float y;float z;float temperature;",
              b"vehicle_magnetometer:uint64_t timestamp;float[3] magnetometer_ga;",
              b"battery_status:uint64_t timestamp;float voltage_v;float current_a;",
              b"actuator_motors:uint64_t timestamp;float[12] control;",
              b"sensor_combined:uint64_t timestamp;float[3] gyro_rad;vec3 accel;"):
        b += msg("F", f)
    topics = ["vehicle_attitude", "sensor_mag" if raw_mags else "vehicle_magnetometer", "battery_status",
              "actuator_motors", "sensor_combined"]
    if state:
        for f in (b"actuator_armed:uint64_t timestamp;bool armed;bool prearmed;uint8_t[6] _padding0;",
                  b"vehicle_status:uint64_t timestamp;uint8_t nav_state;uint8_t arming_state;",
                  b"actuator_controls_0:uint64_t timestamp;float[8] control;"):
            b += msg("F", f)
        topics += ["actuator_armed", "vehicle_status", "actuator_controls_0"]
    for i, t in enumerate(topics):
        b += msg("A", struct.pack("<BH", 0, i) + t.encode())
    for k in range(records):
        t = 2000000 + 20000 * k
        yaw = 0.5 * math.pi * k * 0.02
        b += msg("D", struct.pack("<HQ4f4x", 0, t, math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)))
        bx, by = 0.2 * math.cos(yaw), -0.2 * math.sin(yaw)
        if raw_mags:
            b += msg("D", struct.pack("<HQI4f", 1, t + 1000, 7, bx, by, 0.4, 30.0))
        else:
            b += msg("D", struct.pack("<HQ3f", 1, t + 1000, bx, by, 0.4))
        b += msg("D", struct.pack("<HQ2f", 2, t, 16.0, 12.5))
        b += msg("D", struct.pack("<HQ12f", 3, t, *([0.45] * 4 + [0.0] * 8)))
        b += msg("D", struct.pack("<HQ6f", 4, t, 0, 0, 1.57, 0, 0, -9.81))
        if state:
            armed = 1 if k >= records // 3 else 0
            b += msg("D", struct.pack("<HQ2B6x", 5, t, armed, 0))
            b += msg("D", struct.pack("<HQ2B", 6, t, 3, 2 if armed else 1))
            b += msg("D", struct.pack("<HQ8f", 7, t, 0, 0, 0, 0.3 + 0.01 * k, 0, 0, 0, 0))
    b += msg("L", struct.pack("<BQ", 6, 2500000) + b"armed")
    return b


os.makedirs(out, exist_ok=True)
for name, raw, n, state in (("raw_mags.ulg", True, 12, False), ("calibrated_mag.ulg", False, 6, False),
                            ("px4_state.ulg", True, 9, True)):
    with open(os.path.join(out, name), "wb") as f:
        f.write(log(raw, n, state))
