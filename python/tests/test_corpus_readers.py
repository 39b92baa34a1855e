"""The corpus scripts' own readers (scripts/corpus/logread.py, extract.py) on small logs written
here: damaged ULog streams, PX4 and ArduPilot "not measured" currents, old layouts. No real log."""
import math
import os
import struct
import sys

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "scripts", "corpus"))

import extract  # noqa: E402
import logread  # noqa: E402

SYNC = bytes([0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12])


class ULogBytes:
    """A minimal ULog writer: header, formats, parameters, subscriptions, data."""

    def __init__(self, start_us=0):
        self.b = b"ULog\x01\x12\x35\x01" + struct.pack("<Q", start_us)
        self.ids = {}

    def msg(self, typ, body):
        self.b += struct.pack("<HB", len(body), ord(typ)) + body
        return self

    def fmt(self, text):
        return self.msg("F", text.encode())

    def param(self, name, value):
        key = ("float %s" % name).encode()
        return self.msg("P", bytes([len(key)]) + key + struct.pack("<f", value))

    def sub(self, name, multi=0):
        mid = len(self.ids)
        self.ids[(name, multi)] = mid
        return self.msg("A", struct.pack("<BH", multi, mid) + name.encode())

    def data(self, name, payload, multi=0):
        return self.msg("D", struct.pack("<H", self.ids[(name, multi)]) + payload)

    def sync(self):
        return self.msg("S", SYNC)


def attitude_log(start_us, t0_us, n, extra=None):
    w = ULogBytes(start_us)
    w.fmt("vehicle_attitude:uint64_t timestamp;float[4] q;")
    w.fmt("battery_status:uint64_t timestamp;float voltage_v;float current_a;")
    w.fmt("vehicle_magnetometer:uint64_t timestamp;float[3] magnetometer_ga;")
    w.fmt("transponder_report:uint64_t timestamp;uint32_t icao;")
    for t in ("vehicle_attitude", "battery_status", "vehicle_magnetometer", "transponder_report"):
        w.sub(t)
    w.data("transponder_report", struct.pack("<QI", 0, 1))   # PX4 publishes some topics stamped 0
    for k in range(n):
        t = t0_us + 100000 * k
        w.data("vehicle_attitude", struct.pack("<Q4f", t, 1, 0, 0, 0))
        w.data("battery_status", struct.pack("<Qff", t, 15.9, extra if extra is not None else 12.0))
        w.data("vehicle_magnetometer", struct.pack("<Q3f", t, 0.2, 0.01 * k, 0.4))
    return w


def write(tmp_path, name, data):
    p = tmp_path / name
    p.write_bytes(data)
    return str(p)


def test_ulog_garbage_then_sync_is_skipped_and_the_rest_is_read(tmp_path):
    # Given: 2 s of data, a format message that is not one (no type before a field name, not
    # UTF-8: a real PX4 1.17 log's damage), a sync message, 2 more seconds
    w = attitude_log(1_000_000, 1_000_000, 20)
    head = w.b
    w.sync()
    for k in range(20):
        w.data("vehicle_attitude", struct.pack("<Q4f", 3_000_000 + 100000 * k, 1, 0, 0, 0))
    garbage = struct.pack("<HB", 12, ord("F")) + b"p\x7f?\x9e:\x1cb\x9e\x0e?\xc1\x33"
    path = write(tmp_path, "damaged.ulg", head + garbage + w.b[len(head):])
    # When
    log = logread.ULog(path)
    # Then: before, a ValueError; now every record on both sides of the damage
    assert len(log.topic("vehicle_attitude")["timestamp"]) == 40
    assert log.damaged_bytes == len(garbage)
    assert not log.truncated


def test_ulog_duration_runs_from_the_logger_start_not_from_boot(tmp_path):
    # Given: logging starts 2400 s after boot; a topic stamped 0 (PX4's transponder_report)
    path = write(tmp_path, "late.ulg", attitude_log(2_400_000_000, 2_400_000_000, 300).b)
    # When
    f = extract.read(path)
    # Then: 30 s, not 2430 s
    assert f.duration_s == pytest.approx(29.9, abs=0.01)
    assert f.t0 == pytest.approx(2400.0)


def test_ulog_current_minus_one_is_not_measured(tmp_path):
    # PX4's battery_status.current_a is -1 "if unknown": no current, never -1 A
    f = extract.read(write(tmp_path, "volts.ulg", attitude_log(1_000_000, 1_000_000, 30, extra=-1.0).b))
    assert f.cur_a is None


def test_ulog_magnetometer_without_device_id_is_read(tmp_path):
    # PX4 <= 1.11 logs vehicle_magnetometer without device_id (before: KeyError 'device_id')
    f = extract.read(write(tmp_path, "old.ulg", attitude_log(1_000_000, 1_000_000, 30).b))
    assert len(f.compasses) == 1
    assert f.compasses[0]["device_id"] is None
    assert f.compasses[0]["xyz"][0] == pytest.approx([20.0, 0.0, 40.0], abs=1e-4)


def test_ulog_without_attitude_says_so(tmp_path):
    w = ULogBytes(0)
    w.fmt("Vehicle:uint64_t timestamp;float soc;")
    w.sub("Vehicle")
    w.data("Vehicle", struct.pack("<Qf", 1_000_000, 0.5))
    with pytest.raises(ValueError, match="no vehicle_attitude"):
        extract.read(write(tmp_path, "other.ulog", w.b))


def test_ulog_px4_1_6_compass_inside_sensor_combined(tmp_path):
    # PX4 <= 1.6 logs the compass only in sensor_combined, with its own relative time
    w = ULogBytes(1_000_000)
    w.fmt("vehicle_attitude:uint64_t timestamp;float[4] q;")
    w.fmt("sensor_combined:uint64_t timestamp;int32_t magnetometer_timestamp_relative;"
          "float[3] magnetometer_ga;")
    w.sub("vehicle_attitude")
    w.sub("sensor_combined")
    for k in range(40):
        t = 1_000_000 + 10_000 * k
        w.data("vehicle_attitude", struct.pack("<Q4f", t, 1, 0, 0, 0))
        # a new compass sample every 4th record (40 ms), the same one held in between
        rel = -(10_000 * (k % 4))
        w.data("sensor_combined", struct.pack("<Qi3f", t, rel, 0.2, 0.01 * (k // 4), 0.4))
    f = extract.read(write(tmp_path, "px4_16.ulg", w.b))
    assert [c["name"] for c in f.compasses] == ["sensor_combined.magnetometer"]
    assert len(f.compasses[0]["t"]) == 10


class DataFlashBytes:
    """A minimal DataFlash writer (FMT 128 then messages)."""

    def __init__(self):
        self.b = b""
        self.fmts = {}

    def fmt(self, typ, name, form, cols):
        codes = "".join(logread.DF_TYPES[c][0] for c in form)
        length = struct.calcsize("<" + codes) + 3
        self.fmts[typ] = "<" + codes
        self.b += b"\xa3\x95\x80" + struct.pack("<BB4s16s64s", typ, length, name.encode(), form.encode(),
                                                 cols.encode())
        return self

    def msg(self, typ, *values):
        self.b += b"\xa3\x95" + bytes([typ]) + struct.pack(self.fmts[typ], *values)
        return self


AP_NOT_AVAILABLE = struct.unpack("<f", struct.pack("<I", 0x7FC04152))[0]   # AP_Logger::quiet_nanf()


def hover_dataflash(frame_text, with_rcou=True, amps=12.0):
    w = DataFlashBytes()
    w.fmt(129, "MSG", "QZ", "TimeUS,Message")
    w.fmt(130, "ATT", "QccccCCCC", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw")
    w.fmt(131, "RCOU", "QHHHH", "TimeUS,C1,C2,C3,C4")
    w.fmt(132, "BAT", "QBfff", "TimeUS,Inst,Volt,Curr,CurrTot")
    w.fmt(133, "CTUN", "Qf", "TimeUS,ThO")
    w.msg(129, 1000, frame_text.encode())
    for k in range(300):
        t = 1_000_000 + 100_000 * k
        w.msg(130, t, 0, 100, 0, -50, 0, 9000, 0, 0)
        if with_rcou:
            w.msg(131, t, 1500, 1500, 1500, 1500)
        w.msg(132, t, 0, 50.4, amps, 0.0)
        w.msg(133, t, 0.5)
    return w.b


def test_dataflash_frame_with_a_layout_names_its_motors(tmp_path):
    # ArduCopter 4.x prints "Frame: QUAD/X": four motors (before: unknown)
    f = extract.read(write(tmp_path, "quadx.bin", hover_dataflash("Frame: QUAD/X")))
    assert f.motors == 4


def test_dataflash_current_not_available_is_no_current(tmp_path):
    # ArduPilot logs a monitor's missing current as its quiet NaN: no current, not a NaN median
    f = extract.read(write(tmp_path, "nan.bin", hover_dataflash("Frame: QUAD/X", amps=AP_NOT_AVAILABLE)))
    assert f.cur_a is None


def test_dataflash_without_rcou_flies_on_ctun(tmp_path):
    # ArduCopter 3.1 logs without RCOU: the flight comes from CTUN's throttle output
    f = extract.read(write(tmp_path, "ctun.bin", hover_dataflash("Frame: QUAD", with_rcou=False)))
    assert f.thr is not None
    assert sum(b - a for a, b in f.segs) == pytest.approx(29.9 - 4.0, abs=0.2)
    assert math.isfinite(float(np.median(f.thr)))


def test_ulog_internal_compass_only_in_sensor_mag_is_read(tmp_path):
    # PX4 1.16 (a public quad): vehicle_magnetometer carries the external compass only; the internal
    # one is logged as sensor_mag alone. Both are compasses of the log (before: only the first).
    w = ULogBytes(1_000_000)
    w.fmt("vehicle_attitude:uint64_t timestamp;float[4] q;")
    w.fmt("vehicle_magnetometer:uint64_t timestamp;uint32_t device_id;float[3] magnetometer_ga;")
    w.fmt("sensor_mag:uint64_t timestamp;uint32_t device_id;float x;float y;float z;")
    for t in ("vehicle_attitude", "vehicle_magnetometer"):
        w.sub(t)
    w.sub("sensor_mag", 0)
    w.sub("sensor_mag", 1)
    for k in range(30):
        t = 1_000_000 + 100_000 * k
        w.data("vehicle_attitude", struct.pack("<Q4f", t, 1, 0, 0, 0))
        w.data("vehicle_magnetometer", struct.pack("<QI3f", t, 10, 0.2, 0.0, 0.4))
        w.data("sensor_mag", struct.pack("<QI3f", t, 10, 0.2, 0.0, 0.4), multi=0)
        w.data("sensor_mag", struct.pack("<QI3f", t, 20, 0.1, 0.1, 0.5), multi=1)
    f = extract.read(write(tmp_path, "two.ulg", w.b))
    assert [c["name"] for c in f.compasses] == ["vehicle_magnetometer[0]", "sensor_mag[1]"]
    assert [c["device_id"] for c in f.compasses] == [10, 20]


def test_dataflash_4x_motor_compensation_is_taken_back_out(tmp_path):
    # ArduCopter 4.x logs the compensation it added as MOX/MOY/MOZ (3.x: MOfsX..): the reference
    # takes it back out for the absolute field (before: a 4.5.7 log with COMPASS_MOTCT 2 read
    # the compensated residual, 1.4 mG/A where the firmware's own COMPASS_MOT3 was 5.9)
    w = DataFlashBytes()
    w.fmt(129, "MSG", "QZ", "TimeUS,Message")
    w.fmt(130, "ATT", "QccccCCCC", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw")
    w.fmt(134, "MAG", "QBfffffffff", "TimeUS,I,MagX,MagY,MagZ,OfsX,OfsY,OfsZ,MOX,MOY,MOZ")
    w.msg(129, 1000, b"Frame: QUAD/X")
    for k in range(10):
        t = 1_000_000 + 100_000 * k
        w.msg(130, t, 0, 0, 0, 0, 0, 0, 0, 0)
        w.msg(134, t, 0, 0.25, 0.0, 0.40, 0, 0, 0, 0.05, 0.0, -0.01)
    f = extract.read(write(tmp_path, "mox.bin", w.b))
    assert f.compasses[0]["xyz"][0] == pytest.approx([20.0, 0.0, 41.0], abs=1e-4)


def test_index_reads_the_sources_gathered_beside_the_logs(tmp_path):
    # gather.py writes CORPUS/sources.json; index.py listed the script folder's sources instead
    # (a second corpus was indexed with the first one's 22 logs, all "unreadable")
    import json
    import index
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / "quadx.bin").write_bytes(hover_dataflash("Frame: QUAD/X"))
    (tmp_path / "c" / "sources.json").write_text(json.dumps([
        {"file": "quadx.bin", "repo": "example/repo", "path": "quadx.bin", "commit": "0" * 40,
         "licence": "test"}]))
    index.main(str(tmp_path / "c"))
    text = (tmp_path / "c" / "README.md").read_text()
    assert "`quadx.bin`" in text and "QUAD/X, 4" in text
    assert "Sources: 1 logs from 1 repositories." in text


def test_dataflash_motors_run_without_a_climb_are_no_flight(tmp_path):
    # 30 s armed at output 0.5 with the barometer flat (a props-off run: ArduCopter 4.7.0-dev log
    # 00000002, 2.6 A at 51 V) is no flight window; the same with a 5-m climb is one
    def log(climb):
        w = DataFlashBytes()
        w.fmt(129, "MSG", "QZ", "TimeUS,Message")
        w.fmt(130, "ATT", "QccccCCCC", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw")
        w.fmt(131, "RCOU", "QHHHH", "TimeUS,C1,C2,C3,C4")
        w.fmt(135, "BARO", "QBf", "TimeUS,I,Alt")
        w.msg(129, 1000, b"Frame: QUAD/X")
        for k in range(300):
            t = 1_000_000 + 100_000 * k
            w.msg(130, t, 0, 100, 0, -50, 0, 9000, 0, 0)
            w.msg(131, t, 1500, 1500, 1500, 1500)
            w.msg(135, t, 0, 0.05 * math.sin(0.7 * k) + climb * min(1.0, k / 100.0))
        return w.b
    assert extract.read(write(tmp_path, "ground.bin", log(0.0))).segs == []
    assert len(extract.read(write(tmp_path, "flown.bin", log(5.0))).segs) == 1
