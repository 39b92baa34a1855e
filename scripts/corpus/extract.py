"""Standard flight series from a DataFlash or ULog log (own readers, numpy only).

Everything in SI: seconds, micro-tesla, volts, amperes; attitude as body->NED rotations.
"""

import numpy as np

import logread

FRAME_MOTORS = {"QUAD": 4, "HEXA": 6, "OCTA": 8, "OCTA_QUAD": 8, "Y6": 6, "TRI": 3}
FRAME_CLASS_MOTORS = {1: 4, 2: 6, 3: 8, 4: 8, 5: 6, 7: 3, 10: 1, 12: 4, 14: 4}
# flight = armed and normalised mean motor output above this (ArduCopter spins armed motors
# at 0.0-0.15 of the PWM range and hovers at 0.3-0.7)
FLIGHT_OUTPUT_MIN = 0.25
EDGE_S = 2.0          # seconds cut at each end of a flight segment (take-off, landing)
MIN_SEGMENT_S = 5.0   # shorter airborne segments are not flight
# a segment in which the barometer's height spans less than this (5th..95th percentile) never left
# the ground: motors run props-off or tied down (a barometer on the ground reads within +-0.1 m)
MIN_CLIMB_M = 0.5


def euler_to_r(roll, pitch, yaw):
    """Body->NED rotation matrices (N, 3, 3) from ZYX Euler angles in radians."""
    cr, sr, cp, sp, cy, sy = (np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch),
                              np.cos(yaw), np.sin(yaw))
    r = np.empty((len(roll), 3, 3))
    r[:, 0, 0] = cp * cy
    r[:, 0, 1] = sr * sp * cy - cr * sy
    r[:, 0, 2] = cr * sp * cy + sr * sy
    r[:, 1, 0] = cp * sy
    r[:, 1, 1] = sr * sp * sy + cr * cy
    r[:, 1, 2] = cr * sp * sy - sr * cy
    r[:, 2, 0] = -sp
    r[:, 2, 1] = sr * cp
    r[:, 2, 2] = cr * cp
    return r


def quat_to_r(w, x, y, z):
    n = np.sqrt(w * w + x * x + y * y + z * z)
    n[n == 0] = 1
    w, x, y, z = w / n, x / n, y / n, z / n
    r = np.empty((len(w), 3, 3))
    r[:, 0, 0] = 1 - 2 * (y * y + z * z)
    r[:, 0, 1] = 2 * (x * y - w * z)
    r[:, 0, 2] = 2 * (x * z + w * y)
    r[:, 1, 0] = 2 * (x * y + w * z)
    r[:, 1, 1] = 1 - 2 * (x * x + z * z)
    r[:, 1, 2] = 2 * (y * z - w * x)
    r[:, 2, 0] = 2 * (x * z - w * y)
    r[:, 2, 1] = 2 * (y * z + w * x)
    r[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def segments(t, mask):
    """[start, end) time pairs where mask holds for at least MIN_SEGMENT_S, edges cut."""
    out = []
    i, n = 0, len(t)
    while i < n:
        if not mask[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and mask[j + 1]:
            j += 1
        if t[j] - t[i] >= MIN_SEGMENT_S + 2 * EDGE_S:
            out.append((t[i] + EDGE_S, t[j] - EDGE_S))
        i = j + 1
    return out


def climbed(segs, t_h, h):
    """The segments over which the height series (t_h, h) spans MIN_CLIMB_M or more; all of them
    where no height is logged (fewer than ten samples in a segment keep it too)."""
    if t_h is None or not len(t_h):
        return segs
    out = []
    for a, b in segs:
        m = (t_h >= a) & (t_h <= b) & np.isfinite(h)
        if m.sum() < 10 or np.percentile(h[m], 95) - np.percentile(h[m], 5) >= MIN_CLIMB_M:
            out.append((a, b))
    return out


def in_segments(t, segs):
    m = np.zeros(len(t), bool)
    for a, b in segs:
        m |= (t >= a) & (t <= b)
    return m


class Flight:
    """Fields: kind, version, vehicle, motors, duration_s, compasses [dict], att_t, att_r,
    cur_t, cur_a, volt_v, cells, thr_t, thr, segs (flight windows), params."""


def _df_version(log):
    for _, s in log.texts:
        for key in ("ArduCopter", "APM:Copter"):
            if key in s:
                return s.strip()
    return "ArduPilot (version not logged)"


def _df_frame(log):
    for _, s in log.texts:
        if s.startswith("Frame:"):
            name = s.split(":", 1)[1].strip().split()[0].upper()
            # ArduCopter 4.x prints class/type ("QUAD/X", "HEXA/H"): the class names the motors
            return name, FRAME_MOTORS.get(name.split("/")[0])
    fc = log.params.get("FRAME_CLASS")
    if fc is not None:
        return "FRAME_CLASS %d" % fc, FRAME_CLASS_MOTORS.get(int(fc))
    return None, None


def _df_outputs(log, motors):
    rc = log.msgs.get("RCOU")
    if rc is None:
        return _df_ctun_throttle(log)
    t = np.array(log.time_s("RCOU"))
    chans = []
    for k in range(1, 15):
        for name in ("C%d" % k, "Chan%d" % k, "Ch%d" % k):
            if name in rc:
                v = np.array(rc[name], float)
                chans.append(v)
                break
    lo = log.params.get("MOT_PWM_MIN") or log.params.get("RC3_MIN") or 1100.0
    hi = log.params.get("MOT_PWM_MAX") or log.params.get("RC3_MAX") or 1900.0
    if lo <= 0 or hi <= lo:
        lo, hi = 1100.0, 1900.0
    good = [c for c in chans if np.mean((c > 800) & (c < 2200)) > 0.9]
    if motors:
        good = good[:motors]
    if not good:
        return t, None
    out = (np.vstack(good).mean(axis=0) - lo) / (hi - lo)
    return t, out


def _df_ctun_throttle(log):
    """The throttle output 0..1 of CTUN (ThrOut, or ThO from 3.4 on) where the log has no RCOU
    (LOG_BITMASK without RC outputs: ArduCopter 3.1 logs); None where CTUN has none either."""
    ct = log.msgs.get("CTUN")
    if ct is None:
        return None, None
    for name in ("ThO", "ThrOut"):
        if name in ct:
            v = np.array(ct[name], float)
            if np.nanmax(v) > 2.0:   # an unscaled 0..1000 integer (a log whose FMTU omits it)
                v = v / 1000.0
            return np.array(log.time_s("CTUN")), v
    return None, None


def _df_armed(log, t):
    ev = log.msgs.get("EV")
    if ev is None:
        return np.ones(len(t), bool)
    et = np.array(log.time_s("EV"))
    ids = np.array(ev["Id"])
    armed = np.zeros(len(t), bool)
    state, last = None, 0.0
    events = [(a, b) for a, b in zip(et, ids) if b in (10, 11)]
    if not events:
        return np.ones(len(t), bool)
    if events[0][1] == 11:   # first event a disarm: armed from the start
        state = True
    for a, b in events:
        if state:
            armed |= (t >= last) & (t < a)
        state, last = (b == 10), a
    if state:
        armed |= t >= last
    return armed


def read_dataflash(path):
    log = logread.DataFlash(path)
    f = Flight()
    f.kind, f.params, f.damaged_bytes = "DataFlash", log.params, log.bad_bytes
    f.version = _df_version(log)
    f.frame, f.motors = _df_frame(log)
    tt = [np.array(log.time_s(m)) for m in ("ATT", "IMU", "MAG") if m in log.msgs]
    f.t0 = min(x[0] for x in tt if len(x)) if tt else 0.0
    f.duration_s = max(x[-1] for x in tt if len(x)) - f.t0 if tt else 0.0
    a = log.msgs["ATT"]
    f.att_t = np.array(log.time_s("ATT"))
    d2r = np.pi / 180
    f.att_r = euler_to_r(np.array(a["Roll"]) * d2r, np.array(a["Pitch"]) * d2r,
                         np.array(a["Yaw"]) * d2r)
    f.compasses = []
    names = [m for m in ("MAG", "MAG2", "MAG3") if m in log.msgs]
    for idx, m in enumerate(names):
        mm = log.msgs[m]
        t = np.array(log.time_s(m))
        xyz = np.vstack([mm["MagX"], mm["MagY"], mm["MagZ"]]).T * 100.0  # gauss -> uT
        # undo the autopilot's own motor compensation (COMPASS_MOTCT 1/2) for the absolute k: the
        # offset it added is logged as MOfsX/Y/Z (ArduCopter <= 3.x) or MOX/Y/Z (4.x)
        for mo in (("MOfsX", "MOfsY", "MOfsZ"), ("MOX", "MOY", "MOZ")):
            if mo[0] in mm:
                xyz -= np.vstack([mm[a] for a in mo]).T * 100.0
                break
        if "I" in mm:   # one MAG table with instances (ArduPilot 4.x)
            ids = np.array(mm["I"])
            for k in sorted(set(ids.tolist())):
                sel = ids == k
                f.compasses.append(_df_compass(log, "MAG[%d]" % k, k, t[sel], xyz[sel]))
            break
        f.compasses.append(_df_compass(log, m, idx, t, xyz))
    f.cur_t = f.cur_a = f.volt_v = None
    for m in ("CURR", "BAT", "BATT"):
        if m in log.msgs and "Curr" in log.msgs[m]:
            c = log.msgs[m]
            t = np.array(log.time_s(m))
            sel = np.ones(len(t), bool)
            for inst in ("Instance", "Inst"):   # the first battery monitor (3.x, 4.x names)
                if inst in c:
                    sel = np.array(c[inst]) == 0
                    break
            sel &= np.isfinite(np.array(c["Curr"], float))  # 4.x logs NaN: no current sensor
            if sel.any():
                f.cur_t, f.cur_a = t[sel], np.array(c["Curr"], float)[sel]
                f.volt_v = np.array(c["Volt"], float)[sel]
            break
    vmax = log.params.get("MOT_BAT_VOLT_MAX")
    f.cells = int(round(vmax / 4.2)) if vmax else None
    f.thr_t, f.thr = _df_outputs(log, f.motors)
    if f.motors is None and f.thr is not None:
        f.motors = None
    if f.thr is not None:
        flying = _df_armed(log, f.thr_t) & (f.thr > FLIGHT_OUTPUT_MIN)
        f.segs = segments(f.thr_t, flying)
        if "BARO" in log.msgs and "Alt" in log.msgs["BARO"]:
            b = log.msgs["BARO"]
            sel = np.ones(len(b["Alt"]), bool)
            if "I" in b:
                sel = np.array(b["I"]) == 0
            f.segs = climbed(f.segs, np.array(log.time_s("BARO"))[sel], np.array(b["Alt"], float)[sel])
    else:
        f.segs = []
    return f


def _df_compass(log, name, idx, t, xyz):
    suffix = "" if idx == 0 else str(idx + 1)
    ext = log.params.get("COMPASS_EXTERNAL" if idx == 0 else "COMPASS_EXTERN%d" % (idx + 1))
    use = log.params.get("COMPASS_USE" + suffix)
    motct = log.params.get("COMPASS_MOTCT")
    mot = [log.params.get("COMPASS_MOT%s_%s" % (suffix, a)) for a in "XYZ"]
    return {"name": name, "t": t, "xyz": xyz,
            "external": None if ext is None else bool(ext),
            "use": use, "motct": motct, "mot": mot}


def read_ulog(path):
    log = logread.ULog(path)
    f = Flight()
    f.kind, f.params, f.damaged_bytes = "ULog", log.params, 0
    f.truncated = log.truncated
    ver = log.info.get("ver_sw_release")
    if isinstance(ver, int) or isinstance(ver, float):
        v = int(ver)
        f.version = "PX4 %d.%d.%d" % ((v >> 24) & 0xFF, (v >> 16) & 0xFF, (v >> 8) & 0xFF)
    else:
        f.version = "PX4 " + str(log.info.get("ver_sw", "?"))[:8]
    f.hw = log.info.get("ver_hw", "?")
    ac = log.params.get("SYS_AUTOSTART")
    f.frame = "SYS_AUTOSTART %s" % ac
    f.motors = None
    t_all = [np.array(v["timestamp"]) * 1e-6 for v in log.topics.values() if "timestamp" in v
             and len(v["timestamp"])]
    if not t_all:
        raise ValueError("no timestamped topic in the log")
    f.t0, end = ulog_span(log.start_us * 1e-6, t_all)
    f.duration_s = end - f.t0
    va = log.topic("vehicle_attitude")
    if va is None:
        raise ValueError("no vehicle_attitude topic (not a PX4 flight log)")
    f.att_t = np.array(va["timestamp"]) * 1e-6
    f.att_r = quat_to_r(*(np.array(va["q[%d]" % k]) for k in range(4)))
    f.compasses = _ulog_compasses(log)
    bs = log.topic("battery_status")
    f.cur_t = f.cur_a = f.volt_v = None
    f.cells = None
    if bs is not None:
        cur = np.array(bs["current_a"], float)
        measured = cur >= 0.0     # PX4 writes current_a -1 where no current is measured
        if measured.any():
            f.cur_t = (np.array(bs["timestamp"]) * 1e-6)[measured]
            f.cur_a = cur[measured]
            f.volt_v = np.array(bs.get("voltage_v", bs.get("voltage_filtered_v")), float)[measured]
        if "cell_count" in bs:
            f.cells = int(np.median(bs["cell_count"])) or None
    if f.cells is None and log.params.get("BAT_N_CELLS"):
        f.cells = int(log.params["BAT_N_CELLS"])
    f.thr_t = f.thr = None
    best = []
    for multi in range(4):     # the instance driving the motors: most PWM-range channels
        ao = log.topic("actuator_outputs", multi)
        if ao is None:
            continue
        n = int(np.median(ao["noutputs"]))
        chans = [np.array(ao["output[%d]" % k], float) for k in range(min(n, 8))]
        good = [c for c in chans if np.mean((c > 800) & (c < 2200)) > 0.9 and np.ptp(c) > 50]
        if len(good) > len(best):
            best, best_ao = good, ao
    rotors = log.params.get("CA_ROTOR_COUNT") or log.params.get("MOT_COUNT")
    if best:
        good, ao = best[:int(rotors)] if rotors else best, best_ao
        if good:
            f.motors = len(good)
            f.thr_t = np.array(ao["timestamp"]) * 1e-6
            f.thr = (np.vstack(good).mean(axis=0) - 1000.0) / 1000.0
    ld = log.topic("vehicle_land_detected")
    if ld is not None:
        t = np.array(ld["timestamp"]) * 1e-6
        air = np.array(ld["landed"]) == 0
        # hold each state until the next message, sampled at 10 Hz
        grid = np.arange(t[0], f.t0 + f.duration_s, 0.1)
        idx = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, len(t) - 1)
        f.segs = segments(grid, air[idx])
    elif f.thr is not None:
        f.segs = segments(f.thr_t, f.thr > FLIGHT_OUTPUT_MIN)
        air = log.topic("vehicle_air_data")
        if air is not None and "baro_alt_meter" in air:
            f.segs = climbed(f.segs, np.array(air["timestamp"]) * 1e-6, np.array(air["baro_alt_meter"], float))
    else:
        f.segs = []
    return f


# PX4 enum Rotation, first 16 entries: (roll, yaw) in degrees (pitch 0)
PX4_ROTATIONS = {k: (0, 45 * k) for k in range(8)}
PX4_ROTATIONS.update({8 + k: (180, 45 * k) for k in range(8)})


def _ulog_external(log, dev, multi):
    """External flag of a magnetometer device: its CAL_MAGn slot's ROT (-1 = internal)."""
    slot = [n for n in range(4) if log.params.get("CAL_MAG%d_ID" % n) == dev]
    n = slot[0] if slot else multi
    rot = log.params.get("CAL_MAG%d_ROT" % n)
    return (None if rot is None else rot >= 0), rot


def _ulog_compasses(log):
    """Body-frame compass series. vehicle_magnetometer (PX4's own rotated, calibrated stream)
    where logged, and sensor_mag (turned into the body frame by CAL_MAGn_ROT) for each device
    vehicle_magnetometer does not carry: PX4 publishes vehicle_magnetometer for the selected or
    the calibrated compasses only, and logs every driver's sensor_mag (PX4 1.16: the external one
    as vehicle_magnetometer, the internal one only as sensor_mag)."""
    out = []
    for multi in range(4):
        vm = log.topic("vehicle_magnetometer", multi)
        if vm is None:
            continue
        dev = vm.get("device_id", [None])[0]    # PX4 <= 1.11 logs no device_id here
        ext, _ = _ulog_external(log, dev, multi)
        xyz = np.vstack([vm["magnetometer_ga[%d]" % k] for k in range(3)]).T * 100.0
        out.append({"name": "vehicle_magnetometer[%d]" % multi,
                    "t": np.array(vm["timestamp"]) * 1e-6, "xyz": xyz, "external": ext,
                    "device_id": dev, "use": None, "motct": None, "mot": [None] * 3})
    covered = {c["device_id"] for c in out}
    if None in covered:          # PX4 <= 1.11: no device_id to tell which sensor_mag is covered
        return out
    for multi in range(4):
        sm = log.topic("sensor_mag", multi)
        if sm is None:
            continue
        dev = sm.get("device_id", [None])[0]
        if out and (dev is None or dev in covered):
            continue
        xyz = np.vstack([sm["x"], sm["y"], sm["z"]]).T * 100.0  # gauss -> uT
        ext, rot = _ulog_external(log, dev, multi)
        if "is_external" in sm:
            ext = bool(sm["is_external"][0])
        if ext and rot in PX4_ROTATIONS:
            roll, yaw = (np.radians(a) for a in PX4_ROTATIONS[rot])
            r = euler_to_r(np.array([roll]), np.array([0.0]), np.array([yaw]))[0]
            xyz = xyz @ r.T
        out.append({"name": "sensor_mag[%d]" % multi, "t": np.array(sm["timestamp"]) * 1e-6,
                    "xyz": xyz, "external": ext, "device_id": dev, "use": None,
                    "motct": None, "mot": [None] * 3})
    if out:
        return out
    return _ulog_combined_mag(log)


def _ulog_combined_mag(log):
    """PX4 <= 1.6 logs the compass only inside sensor_combined (magnetometer_ga, body frame,
    its own time as magnetometer_timestamp_relative): one sample per new compass time."""
    sc = log.topic("sensor_combined")
    if sc is None or "magnetometer_ga[0]" not in sc:
        return []
    t = np.array(sc["timestamp"], float)
    rel = np.array(sc.get("magnetometer_timestamp_relative", np.zeros(len(t))), float)
    ok = rel != RELATIVE_TIMESTAMP_INVALID
    tm = (t + rel)[ok] * 1e-6
    xyz = np.vstack([np.array(sc["magnetometer_ga[%d]" % k])[ok] for k in range(3)]).T * 100.0
    first = np.concatenate([[True], np.diff(tm) > 0])
    return [{"name": "sensor_combined.magnetometer", "t": tm[first], "xyz": xyz[first],
             "external": None, "device_id": None, "use": None, "motct": None, "mot": [None] * 3}]


RELATIVE_TIMESTAMP_INVALID = 0x7FFFFFFF   # PX4 sensor_combined: that sensor had no new sample


def ulog_span(header_s, stamps):
    """(start, end) of a ULog in seconds since boot. The start is the logger's start (the file
    header's timestamp): topics published before it carry earlier stamps (a transponder_report
    stamped 0, a parameter_update from boot: 2400 s before a 30-s log of flugdrohne log_41). Where
    the header is not a time inside the data (0), the earliest non-zero stamp stands for it."""
    end = max(float(x.max()) for x in stamps)
    if 0.0 < header_s <= end:
        return header_s, end
    firsts = [float(x[x > 0].min()) for x in stamps if (x > 0).any()]
    return (min(firsts) if firsts else 0.0), end


def read(path):
    with open(path, "rb") as fh:
        magic = fh.read(4)
    if magic == b"ULog":
        return read_ulog(path)
    return read_dataflash(path)
