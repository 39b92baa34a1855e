"""hexsim.Simulation: the CLI's run reproduced, the act modes, state and sensors, errors."""
import math

import numpy as np
import pytest

import hexsim
import pd_hover

G = 9.80665


def tilt_deg(q):
    # Angle between body z and NED down: cos = 1 − 2(x² + y²).
    return math.degrees(math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (q[1] ** 2 + q[2] ** 2)))))


def test_given_the_cli_seed_when_run_from_python_then_log_csv_is_byte_identical(cli, tmp_path):
    args = ["run", "square", "--seed", 3, "--duration", 20, "--set", "vehicle.mass_kg=2.6"]
    done = cli(*args, "--out", tmp_path / "cli")
    assert done.returncode == 0, done.stderr
    sim = hexsim.Simulation(mission="square", seed=3, duration=20, set={"vehicle.mass_kg": 2.6})
    result = sim.run()
    sim.write(str(tmp_path / "py"))
    assert (tmp_path / "cli" / "log.csv").read_bytes() == (tmp_path / "py" / "log.csv").read_bytes()
    header = (tmp_path / "cli" / "log.csv").read_text().splitlines()[0].split(",")
    assert list(result["log"]) == header
    assert len(result["log"]["t_s"]) == 20 * 100 + 1  # 100 Hz log, both ends
    assert result["status"] == "not_completed" and result["summary"]["seed"] == 3


def test_given_a_python_pd_at_1khz_in_wind_when_hovering_then_altitude_holds_within_0p2_m_for_10_s():
    # The windy world: 5 m/s mean wind and 0.8 m/s turbulence (in still air the PD holds to < 1 mm).
    sim = hexsim.Simulation(mission="square", world="windy", estimator="truth", seed=5, duration=30)
    pd = pd_hover.PDController(sim.hover_thrust_N / G)
    target = (0.0, 0.0, -5.0)
    heights = []
    x = sim.state_vector().tolist()
    while x[0] < 18.0:
        sim.act("attitude", pd(x, target))
        assert sim.step()
        x = sim.state_vector().tolist()
        if x[0] >= 8.0:  # take-off and settling first, then 10 s of hover
            heights.append(-x[3])
    assert len(heights) >= 10000
    assert max(abs(h - 5.0) for h in heights) < 0.2


def test_given_equal_motor_commands_above_hover_when_flown_then_the_vehicle_climbs_level():
    sim = hexsim.Simulation(mission="square", estimator="truth", duration=10)
    sim.act("motors", [0.75] * sim.rotors)
    sim.step(2000)
    s = sim.state()
    assert np.allclose(s["motor_command"], 0.75)
    assert s["p_N_m"][2] < -1.0 and s["v_N_mps"][2] < -0.5          # climbing (NED: up is negative D)
    assert tilt_deg(s["q_NB"]) < 2.0                                 # equal thrust: no roll or pitch torque
    assert np.all(s["motor_omega_radps"] > 0) and s["battery_A"] > 1.0
    assert abs(s["battery_A"] - s["motor_A"].sum()) < 2.0            # the motors draw the battery current


def test_given_a_yaw_rate_setpoint_when_flying_rates_then_the_body_turns_at_that_rate():
    sim = hexsim.Simulation(mission="square", estimator="truth", duration=10)
    sim.act("rates", [0.0, 0.0, 0.5, 1.1 * sim.hover_thrust_N])
    sim.step(3000)
    s = sim.state()
    assert s["w_B_radps"][2] == pytest.approx(0.5, abs=0.05)
    assert abs(s["w_B_radps"][0]) < 0.05 and abs(s["w_B_radps"][1]) < 0.05
    assert s["p_N_m"][2] < -0.5


def test_given_a_position_setpoint_when_the_builtin_cascade_flies_then_it_arrives():
    sim = hexsim.Simulation(mission="square", estimator="truth", duration=20)
    sim.act("position", [3.0, -2.0, -4.0, 0.5])
    sim.step(15000)
    s = sim.state()
    assert np.linalg.norm(s["p_N_m"] - [3.0, -2.0, -4.0]) < 0.3
    assert sim.act_mode == "position"


def test_given_a_run_when_reading_state_sensors_and_log_then_numpy_arrays_in_the_library_units():
    sim = hexsim.Simulation(mission="square", vehicle="paper_hex", world="changchun", estimator="truth", duration=3)
    sim.step(1500)
    s, r = sim.state(), sim.sensors()
    assert s["t_s"] == pytest.approx(1.5)
    assert s["q_NB"].shape == (4,) and abs(np.linalg.norm(s["q_NB"]) - 1.0) < 1e-9
    assert s["motor_omega_radps"].shape == (sim.rotors,) == (6,)
    assert r["accel_mps2"].shape == (3,) and abs(np.linalg.norm(r["accel_mps2"]) - G) < 2.0
    assert 20.0 < np.linalg.norm(r["mag_uT"]) < 120.0               # Earth field plus the vehicle's own
    assert {"gyro_radps", "gps_p_N_m", "baro_alt_m", "mag_t_s"} <= set(r)
    log = sim.log()
    assert log["t_s"].dtype == np.float64 and len(log["t_s"]) == 150  # t = 0 … 1.49 s at 100 Hz
    assert np.array_equal(sim.state_vector()[1:4], s["p_N_m"])
    assert hexsim.STATE_VECTOR_FIELDS[7] == "q_w"


def test_given_a_bad_parameter_when_creating_then_bad_input_error_with_the_clis_line(cli, tmp_path):
    done = cli("run", "square", "--set", "vehicle.mass_kg=-1", "--out", tmp_path / "x")
    assert done.returncode == 2
    with pytest.raises(hexsim.BadInputError) as e:
        hexsim.Simulation(mission="square", set={"vehicle.mass_kg": -1})
    assert done.stderr.strip() == "hexsim: " + str(e.value)
    assert "mass_kg: must be > 0" in str(e.value)
    assert isinstance(e.value, ValueError) and isinstance(e.value, hexsim.Error)


def test_given_bad_calls_when_acting_or_naming_then_clear_errors():
    with pytest.raises(hexsim.BadInputError, match="no_such_mission"):
        hexsim.Simulation(mission="no_such_mission")
    with pytest.raises(hexsim.BadInputError, match="sim.estimator"):
        hexsim.Simulation(estimator="kalman")
    sim = hexsim.Simulation(estimator="truth", duration=1)
    with pytest.raises(hexsim.BadInputError, match=r"motor 2: command 1.5 outside \[0, 1\]"):
        sim.act("motors", [0.5, 1.5, 0.5, 0.5, 0.5, 0.5])
    with pytest.raises(hexsim.BadInputError, match="expected 5 values"):
        sim.act("attitude", [1, 0, 0])
    with pytest.raises(hexsim.BadInputError, match="expected builtin, position"):
        sim.act("thrust", [1])
    with pytest.raises(hexsim.BadInputError, match="not a finite number"):
        sim.act("rates", [0, 0, float("nan"), 10])
    with pytest.raises(hexsim.BadInputError, match="not finished"):
        sim.result()
    assert sim.act_mode == "builtin"  # a refused action changes nothing
