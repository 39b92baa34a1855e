"""hexsim.calibrate on (N, 3) arrays, hexsim.wmm.field and hexsim.gap.diagnose against the CLI."""
import json
import os

import numpy as np
import pytest

import hexsim

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def sphere_samples(n, radius_uT, rng):
    u = rng.normal(size=(n, 3))
    return radius_uT * u / np.linalg.norm(u, axis=1, keepdims=True)


def test_given_a_known_offset_and_soft_iron_when_fitting_an_ellipsoid_then_both_are_recovered():
    rng = np.random.default_rng(7)
    offset_uT = np.array([12.0, -7.5, 30.0])
    K = np.array([[1.08, 0.03, -0.02], [0.03, 0.95, 0.04], [-0.02, 0.04, 1.0]])
    K /= np.cbrt(np.linalg.det(K))                          # det K = 1, as the library's model
    raw = sphere_samples(600, 50.0, rng) @ K.T + offset_uT + rng.normal(scale=0.2, size=(600, 3))
    fit = hexsim.calibrate(raw, method="ellipsoid")
    assert fit["method_used"] == "ellipsoid" and fit["accepted"]
    assert np.abs(fit["offset_uT"] - offset_uT).max() < 0.3   # noise 0.2 µT over 600 samples
    corrected = (raw - fit["offset_uT"]) @ fit["A"].T
    spread = np.std(np.linalg.norm(corrected, axis=1)) / np.mean(np.linalg.norm(corrected, axis=1))
    assert spread < 0.01                                      # 0.2/50 = 0.4 % of noise, not the 8 % soft iron
    assert fit["report"]["schema"].startswith("hexsim.calib/")
    assert "COMPASS_OFS_X" in fit["ardupilot_parm"]


def test_given_a_pure_offset_when_fitting_a_sphere_then_offset_and_radius_are_recovered():
    rng = np.random.default_rng(3)
    raw = sphere_samples(200, 48.0, rng) + [-20.0, 5.0, 11.0]
    fit = hexsim.calibrate(raw, method="sphere")
    assert np.allclose(fit["offset_uT"], [-20.0, 5.0, 11.0], atol=1e-6)
    assert fit["radius_uT"] == pytest.approx(48.0, abs=1e-6)


def test_given_bad_samples_when_calibrating_then_bad_input_errors():
    with pytest.raises(hexsim.BadInputError, match=r"\(N, 3\)"):
        hexsim.calibrate(np.zeros((10, 2)))
    with pytest.raises(hexsim.BadInputError, match="method"):
        hexsim.calibrate(sphere_samples(100, 50.0, np.random.default_rng(1)), method="magic")
    with pytest.raises(hexsim.BadInputError):
        hexsim.calibrate(np.ones((5, 3)) * 50.0, method="ellipsoid")   # too few samples


def test_given_a_place_and_date_when_asking_the_wmm_then_the_clis_json(cli):
    done = cli("field", 43.88, 125.35, 200, "2016-07-01", "--json")
    assert done.returncode == 0, done.stderr
    expected = json.loads(done.stdout)
    got = hexsim.wmm.field(43.88, 125.35, 200, "2016-07-01")
    assert {k: got[k] for k in expected} == expected
    assert np.allclose(got["B_N_uT"] * 1000.0, [got["north_nT"], got["east_nT"], got["down_nT"]])
    with pytest.raises(hexsim.BadInputError):
        hexsim.wmm.field(0.0, 0.0, 0.0, "1990-01-01")             # before WMM2015


def test_given_a_simulated_log_when_diagnosing_then_the_clis_gap_json(cli, tmp_path):
    assert cli("run", "square", "--estimator", "truth", "--seed", 2, "--duration", 30, "--out", tmp_path).returncode == 0
    log = str(tmp_path / "log.csv")
    done = cli("gap", "diagnose", "--real", log, "--sim", "default_hex", "--out", tmp_path / "gap")
    assert done.returncode == 0, done.stderr
    expected = json.loads((tmp_path / "gap" / "gap.json").read_text())
    got = hexsim.gap.diagnose(log, "default_hex")
    assert got.pop("summary_text").strip() in done.stdout
    assert got.pop("import_notes") == []
    assert got == expected


def test_given_a_dataflash_bin_when_diagnosing_then_it_is_imported_as_the_cli_does(cli, tmp_path):
    # The shared real log as it is: Python reads .bin/.ulg through the CLI's importer, not CSV only.
    log = os.path.join(ROOT, "data", "real", "ardupilot_copter_log171.bin")
    done = cli("gap", "diagnose", "--real", log, "--sim", "quad_x", "--out", tmp_path / "gap")
    assert done.returncode == 0, done.stderr
    expected = json.loads((tmp_path / "gap" / "gap.json").read_text())
    got = hexsim.gap.diagnose(log, "quad_x")
    assert got.pop("summary_text").strip() in done.stdout
    notes = got.pop("import_notes")
    assert notes and all(f"log: {line}" in done.stdout for line in notes)
    assert got == expected
    assert {c["channel"] for c in got["channels"]} >= {"mag", "mag2"}


def test_given_a_missing_log_when_diagnosing_then_the_clis_message(cli, tmp_path):
    done = cli("gap", "diagnose", "--real", tmp_path / "none.csv", "--sim", "default_hex", "--out", tmp_path / "g")
    with pytest.raises(hexsim.BadInputError) as e:
        hexsim.gap.diagnose(str(tmp_path / "none.csv"), "default_hex")
    assert done.returncode == 2 and done.stderr.strip() == "hexsim: " + str(e.value)
