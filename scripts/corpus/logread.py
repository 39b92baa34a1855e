"""Minimal, self-contained readers for ArduPilot DataFlash (.bin) and PX4 ULog (.ulg).

Independent of hexsim's importer on purpose: the corpus reference must not share its code.
Only the standard library; values come back as Python lists per field.

DataFlash scaling (the unit check is the point of this reader):
  * the format char decides first: c/C/e/E are hundredths (x0.01), L is 1e-7 degrees,
    f/d are already physical;
  * where the log has FMTU/MULT, an integer field takes the multiplier its FMTU names;
  * logs without FMTU (ArduCopter <= 3.5) use LEGACY_SCALE below, and only for integer
    fields (never for a float field).
"""

import struct

DF_HEAD = b"\xa3\x95"
DF_FMT_ID = 128

# format char -> (struct code, scale by char)
DF_TYPES = {
    "a": ("32h", None), "b": ("b", 1.0), "B": ("B", 1.0), "h": ("h", 1.0), "H": ("H", 1.0),
    "i": ("i", 1.0), "I": ("I", 1.0), "f": ("f", 1.0), "d": ("d", 1.0),
    "n": ("4s", None), "N": ("16s", None), "Z": ("64s", None),
    "c": ("h", 0.01), "C": ("H", 0.01), "e": ("i", 0.01), "E": ("I", 0.01),
    "L": ("i", 1e-7), "M": ("B", 1.0), "q": ("q", 1.0), "Q": ("Q", 1.0),
}
INT_CHARS = set("bBhHiIqQ")

# Integer fields of logs without FMTU/MULT whose logged unit is not the SI one
# (ArduCopter 3.2-3.5 LogStructure: centivolts, centiamps, PWM/1000 throttle).
LEGACY_SCALE = {
    ("CURR", "Volt"): 0.01, ("CURR", "Curr"): 0.01, ("CURR", "Vcc"): 0.001,
    ("CURR", "ThrOut"): 0.001, ("CURR", "Throttle"): 0.001,
    ("CTUN", "ThrOut"): 0.001, ("CTUN", "ThO"): 0.001, ("CTUN", "ThrIn"): 0.001,
}
# compass fields are milligauss integers in every ArduCopter version; legacy logs -> gauss
for _m in ("MAG", "MAG2", "MAG3"):
    for _f in ("MagX", "MagY", "MagZ", "OfsX", "OfsY", "OfsZ", "MOfsX", "MOfsY", "MOfsZ"):
        LEGACY_SCALE[(_m, _f)] = 0.001


def _cstr(b):
    return b.split(b"\x00", 1)[0].decode("latin-1")


class DataFlash:
    """msgs[name][field] -> list of values (scaled); params dict; texts list of (t_s, str)."""

    def __init__(self, path):
        with open(path, "rb") as fh:
            self.raw = fh.read()
        self.fmts = {}        # id -> (name, struct, cols, chars)
        self.msgs = {}
        self.params = {}
        self.texts = []
        self.units = {}       # (name, col) -> multiplier from FMTU/MULT
        self.bad_bytes = 0
        self.tscale = {}      # id -> seconds per tick of the leading time column
        self.untimed_t = {}   # name -> time of the last timed message before each record
        self._parse()

    def _define(self, body):
        typ, length, name, fmt, cols = struct.unpack("<BB4s16s64s", body)
        name, fmt = _cstr(name), _cstr(fmt)
        cols = _cstr(cols).split(",")
        codes = []
        for ch in fmt:
            if ch not in DF_TYPES:
                return
            codes.append(DF_TYPES[ch][0])
        st = struct.Struct("<" + "".join(codes))
        if st.size + 3 != length:
            return
        self.fmts[typ] = (name, st, cols, fmt, length)
        if cols and cols[0] in ("TimeUS", "TimeMS"):
            self.tscale[typ] = 1e-6 if cols[0] == "TimeUS" else 1e-3

    def _parse(self):
        raw, n, i = self.raw, len(self.raw), 0
        store, untimed, last_t = {}, {}, None
        while i + 3 <= n:
            if raw[i] != 0xA3 or raw[i + 1] != 0x95:
                i += 1
                self.bad_bytes += 1
                continue
            mid = raw[i + 2]
            if mid == DF_FMT_ID:
                if i + 89 > n:
                    break
                self._define(raw[i + 3:i + 89])
                i += 89
                continue
            f = self.fmts.get(mid)
            if f is None:
                i += 1
                self.bad_bytes += 1
                continue
            name, st, cols, fmt, length = f
            if i + length > n:
                break
            row = st.unpack_from(raw, i + 3)
            store.setdefault(mid, []).append(row)
            if mid in self.tscale:
                last_t = row[0] * self.tscale[mid]
            else:
                untimed.setdefault(name, []).append(last_t)
            i += length
        first_t = min((rows[0][0] * self.tscale[m] for m, rows in store.items()
                       if m in self.tscale and rows), default=0.0)
        for name, ts in untimed.items():   # records before any timed one take the first time
            self.untimed_t[name] = [first_t if x is None else x for x in ts]
        mults, fmtu = {}, {}
        for mid, rows in store.items():
            name = self.fmts[mid][0]
            if name == "MULT":
                cols = self.fmts[mid][2]
                for r in rows:
                    d = dict(zip(cols, r))
                    mults[d["Id"]] = d["Mult"]
            if name == "FMTU":
                cols = self.fmts[mid][2]
                for r in rows:
                    d = dict(zip(cols, r))
                    fmtu[d["FmtType"]] = _cstr(d["MultIds"])
        for mid, rows in store.items():
            name, st, cols, fmt, length = self.fmts[mid]
            vals = {}
            expanded = [c for c in fmt]
            for k, col in enumerate(cols):
                if k >= len(expanded):
                    break
                ch = expanded[k]
                seq = [r[k] for r in rows]
                scale = DF_TYPES[ch][1]
                if scale is None or col in ("TimeUS", "TimeMS"):
                    vals[col] = [_cstr(v) if isinstance(v, bytes) else v for v in seq]
                    continue
                if ch in INT_CHARS:
                    if mid in fmtu and k < len(fmtu[mid]):
                        m = mults.get(ord(fmtu[mid][k]) if isinstance(fmtu[mid][k], str) else fmtu[mid][k])
                        if m is not None and m not in (0.0,) and fmtu[mid][k] not in ("-", "?"):
                            scale = float(m)
                            self.units[(name, col)] = scale
                    elif not fmtu:
                        scale = LEGACY_SCALE.get((name, col), 1.0)
                vals[col] = [v * scale for v in seq] if scale != 1.0 else list(seq)
            # instance-numbered messages (MAG with I, BAT with Instance) stay one table
            self.msgs.setdefault(name, {})
            for col, seq in vals.items():
                self.msgs[name].setdefault(col, []).extend(seq)
        if "PARM" in self.msgs:
            p = self.msgs["PARM"]
            for k, v in zip(p["Name"], p["Value"]):
                self.params[k] = v
        if "MSG" in self.msgs:
            tcol = "TimeUS" if "TimeUS" in self.msgs["MSG"] else "TimeMS"
            for t, s in zip(self.msgs["MSG"].get(tcol, [0] * len(self.msgs["MSG"]["Message"])),
                            self.msgs["MSG"]["Message"]):
                self.texts.append((t, s))

    def time_s(self, name):
        m = self.msgs[name]
        if name in self.untimed_t:
            return list(self.untimed_t[name])
        if "TimeUS" in m:
            return [t * 1e-6 for t in m["TimeUS"]]
        return [t * 1e-3 for t in m["TimeMS"]]


# ---------------------------------------------------------------- ULog
UL_TYPES = {
    "int8_t": ("b", 1), "uint8_t": ("B", 1), "int16_t": ("h", 2), "uint16_t": ("H", 2),
    "int32_t": ("i", 4), "uint32_t": ("I", 4), "int64_t": ("q", 8), "uint64_t": ("Q", 8),
    "float": ("f", 4), "double": ("d", 8), "bool": ("?", 1), "char": ("c", 1),
}


# ULog message types (format spec: B F I M P Q A R D L C S O) and the sync marker written
# after a dropout; a message larger than UL_MAX_MSG is corruption (PX4's largest topic is ~2 kB;
# pyulog uses 10000 too)
UL_MSG_TYPES = set(b"BFIMPQARDLCSO")
UL_SYNC = bytes([0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12])
UL_MAX_MSG = 10000


class ULog:
    """topics[(name, multi_id)][field] -> list; params; info; truncated flag."""

    def __init__(self, path):
        with open(path, "rb") as fh:
            self.raw = fh.read()
        if self.raw[:4] != b"ULog" or len(self.raw) < 16:
            raise ValueError("not a ULog file")
        self.start_us = struct.unpack_from("<Q", self.raw, 8)[0]   # the logger's start time
        self.formats = {}
        self.subs = {}
        self.params = {}
        self.info = {}
        self.texts = []
        self.topics = {}
        self.truncated = False
        self.damaged_bytes = 0
        self._rows = {}
        self._parse()

    def _layout(self, fmt_name, prefix=""):
        """Flattened (field_name, struct_code, count) list of a format."""
        out = []
        for decl in self.formats[fmt_name]:
            typ, fname = decl
            count = 1
            if "[" in typ:
                typ, n = typ[:-1].split("[")
                count = int(n)
            if typ in UL_TYPES:
                code = UL_TYPES[typ][0]
                if fname.startswith("_padding"):
                    out.append((None, "%dx" % (UL_TYPES[typ][1] * count), 0))
                elif typ == "char":
                    out.append((prefix + fname, "%ds" % count, -1))
                else:
                    out.append((prefix + fname, code * count, count))
            else:
                for j in range(count):
                    sub = prefix + fname + ("[%d]." % j if count > 1 else ".")
                    out.extend(self._layout(typ, sub))
        return out

    def _parse(self):
        raw, n = self.raw, len(self.raw)
        i = 16
        # flag bits message may follow; all messages share the header (size, type)
        while i + 3 <= n:
            size, typ = struct.unpack_from("<HB", raw, i)
            body_start, body_end = i + 3, i + 3 + size
            t = chr(typ)
            ok = typ in UL_MSG_TYPES and 0 < size <= UL_MAX_MSG
            if ok and body_end > n:
                self.truncated = True
                break
            if ok:
                try:
                    ok = self._message(t, raw[body_start:body_end])
                except (ValueError, KeyError, IndexError, struct.error, UnicodeError):
                    ok = False
            if ok:
                i = body_end
                continue
            if ok is None:                 # well-framed but unusable (data of no subscription)
                self.damaged_bytes += body_end - i
                i = body_end
                continue
            # a corrupt message (unknown type, impossible size, unreadable body): resume at the
            # next sync marker, as PX4's logger writes one after a dropout (pyulog does the same);
            # the sync message's own 3-byte header precedes its magic
            nxt = raw.find(UL_SYNC, i + 4)
            resume = n if nxt < 0 else nxt - 3
            self.damaged_bytes += resume - i
            i = resume
        for mid, rows in self._rows.items():
            name, multi, lay, st = self.subs[mid]
            cols = {}
            k = 0
            for fname, code, count in lay:
                if fname is None:
                    continue
                if count == -1:
                    cols[fname] = [r[k] for r in rows]
                    k += 1
                elif count == 1:
                    cols[fname] = [r[k] for r in rows]
                    k += 1
                else:
                    for j in range(count):
                        cols["%s[%d]" % (fname, j)] = [r[k + j] for r in rows]
                    k += count
            self.topics[(name, multi)] = cols
        self._rows = {}

    def _message(self, t, body):
        """Decode one message into the tables: True; False where its body cannot be this type's
        (a corrupt stream: a field without a type, a name not UTF-8); None for data of no
        subscription (skipped alone: its framing is intact)."""
        if t == "F":
            s = body.decode("utf-8")
            name, fields = s.split(":", 1)
            decl = []
            for f in fields.split(";"):
                if f.strip():
                    a, b = f.strip().split(" ", 1)
                    decl.append((a, b))
            self.formats[name] = decl
        elif t == "A":
            multi, mid = struct.unpack_from("<BH", body, 0)
            name = body[3:].decode("latin-1")
            if name not in self.formats:
                return False
            lay = self._layout(name)
            while lay and lay[-1][0] is None:   # trailing padding is not logged
                lay.pop()
            st = struct.Struct("<" + "".join(c for _, c, _ in lay))
            self.subs[mid] = (name, multi, lay, st)
        elif t == "D":
            mid = struct.unpack_from("<H", body, 0)[0]
            if mid not in self.subs:
                return None
            st = self.subs[mid][3]
            if len(body) - 2 >= st.size:
                self._rows.setdefault(mid, []).append(st.unpack_from(body, 2))
        elif t in ("I", "P", "M", "Q"):
            off = 1 if t in ("M", "Q") else 0
            klen = body[off]
            key = body[off + 1:off + 1 + klen].decode("latin-1")
            val = body[off + 1 + klen:]
            typ_s, kname = key.split(" ", 1)
            if typ_s == "float":
                v = struct.unpack("<f", val[:4])[0]
            elif typ_s in ("int32_t", "uint32_t", "int64_t", "uint64_t"):
                code = {"int32_t": "<i", "uint32_t": "<I", "int64_t": "<q",
                        "uint64_t": "<Q"}[typ_s]
                v = struct.unpack(code, val[:struct.calcsize(code)])[0]
            elif typ_s.startswith("char"):
                v = val.decode("latin-1", "replace")
            else:
                v = val
            if t == "P" or (t == "Q" and kname not in self.params):
                self.params[kname] = v
            elif t in ("I", "M"):
                self.info[kname] = v
        elif t == "L":
            ts = struct.unpack_from("<BQ", body, 0)
            self.texts.append((ts[1] * 1e-6, body[9:].decode("latin-1", "replace")))
        return True

    def topic(self, name, multi=0):
        return self.topics.get((name, multi))


def open_log(path):
    with open(path, "rb") as fh:
        magic = fh.read(4)
    if magic[:2] == DF_HEAD:
        return DataFlash(path)
    if magic == b"ULog":
        return ULog(path)
    raise ValueError("%s: neither DataFlash nor ULog (magic %r)" % (path, magic))
