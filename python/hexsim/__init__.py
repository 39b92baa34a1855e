"""hexsim from Python: fly, sense, calibrate and diagnose with numpy arrays.

Thin over hexsim's C++ libraries (the extension module ``_hexsim``), with the same names, units
and frames (NED earth frame, FRD body frame, ``q_NB`` as w, x, y, z, units in every name):

    sim = hexsim.Simulation(mission="square", vehicle="default_hex", seed=1, set={"vehicle.mass_kg": 2.5})
    sim.act("attitude", [1, 0, 0, 0, sim.hover_thrust_N])   # or builtin | position | rates | motors
    sim.step(1000)                                          # 1 s of 1 kHz physics
    sim.state(), sim.sensors(), sim.log()                   # dicts of numpy arrays
    hexsim.wmm.field(43.88, 125.35, 200, "2016-07-01")      # hexsim.field/1 keys
    hexsim.calibrate(xyz)                                   # an (N, 3) array -> offset_uT, A, report
    hexsim.gap.diagnose("log.bin", "quad_x")                # gap.json as a dict (.csv, .bin or .ulg)

Errors raise hexsim.BadInputError (a ValueError), NumericalError or CheckFailedError, all
hexsim.Error, carrying the one-line message the CLI prints after "hexsim: ".
The Gymnasium environments (hexsim.env): HoverEnv, WaypointEnv, CompassWaypointEnv and VectorEnv.
"""
import os as _os
import types as _types


def _find_data_dir():
    # worlds/ for an installed package: bundled by `pip install .` (hexsim/data), or PREFIX/share/hexsim
    # for `cmake --install` (PREFIX/lib/python3/dist-packages/hexsim); a build tree uses the sources.
    here = _os.path.dirname(_os.path.abspath(__file__))
    for candidate in (_os.path.join(here, "data"),
                      _os.path.join(here, "..", "..", "..", "..", "share", "hexsim")):
        if _os.path.isdir(_os.path.join(candidate, "worlds")):
            return _os.path.normpath(candidate)
    return None


if not _os.environ.get("HEXSIM_DATA_DIR") and _find_data_dir():
    _os.environ["HEXSIM_DATA_DIR"] = _find_data_dir()

from ._hexsim import (  # noqa: E402
    Simulation, Error, BadInputError, NumericalError, CheckFailedError, calibrate, __version__)
from ._hexsim import wmm_field as _wmm_field, gap_diagnose as _gap_diagnose  # noqa: E402

#: The layout of Simulation.state_vector().
STATE_VECTOR_FIELDS = ("t_s", "p_N_m", "p_E_m", "p_D_m", "v_N_mps", "v_E_mps", "v_D_mps",
                       "q_w", "q_x", "q_y", "q_z", "w_x_radps", "w_y_radps", "w_z_radps")

wmm = _types.SimpleNamespace(field=_wmm_field)
wmm.__doc__ = "World Magnetic Model: field(lat_deg, lon_deg, alt_m, date, model='', allow_extrapolation=False)"
gap = _types.SimpleNamespace(diagnose=_gap_diagnose)
gap.__doc__ = ("Sim-to-real gap: diagnose(log, vehicle, seed=1, from_s=0, to_s=0, meta=None) -> gap.json dict "
               "(log: a FlightLog CSV, .bin or .ulg path, or {column: array}; plus summary_text and import_notes)")

__all__ = ["Simulation", "Error", "BadInputError", "NumericalError", "CheckFailedError", "calibrate", "wmm",
           "gap", "STATE_VECTOR_FIELDS", "__version__"]

from .env import HoverEnv, WaypointEnv, CompassWaypointEnv, VectorEnv  # noqa: E402  (registers the gym ids)

__all__ += ["HoverEnv", "WaypointEnv", "CompassWaypointEnv", "VectorEnv"]
