"""The Python package against the ``rotorid`` command line on the same
input: every function, numpy dtypes and shapes, errors, and the results
equal to the command line's JSON to the last bit (`read_measurements`
gives each speed as the rpm that converts back to the file's speed
exactly).

The command line is ``$ROTORID_BIN`` (``.ci/run`` points it at the binary
its test step built); without it the comparisons are skipped, except under
``CI=true`` where they fail.
"""

from __future__ import annotations

import json
import math
import os
import pathlib
import subprocess
import threading
import time

import numpy as np
import pytest

import rotorid

REPO = pathlib.Path(__file__).resolve().parents[3]
STEPPED = REPO / "tests" / "data" / "ross" / "stepped_hollow.toml"
THREE = REPO / "tests" / "data" / "rotors" / "three_bearing.toml"
THREE_ROSS = REPO / "tests" / "data" / "ross" / "cases" / "three_bearing.ross.toml"
SPEEDS = np.arange(50.0, 15001.0, 50.0)


def cli_bin() -> str:
    path = os.environ.get("ROTORID_BIN")
    if path and os.path.exists(path):
        return path
    if os.environ.get("CI") == "true":
        pytest.fail("ROTORID_BIN must name the rotorid binary under CI")
    pytest.skip("ROTORID_BIN not set: no command line to compare with")


def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([cli_bin(), *args], capture_output=True, text=True, check=False)


def assert_close(a, b, path="$"):
    """Equal structure and equal numbers, to the last bit."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and sorted(a) == sorted(b), path
        for k in a:
            assert_close(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_close(x, y, f"{path}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert a == b, f"{path}: {a} != {b}"
    else:
        assert a == b, f"{path}: {a!r} != {b!r}"


@pytest.fixture(scope="module")
def sweep(tmp_path_factory) -> pathlib.Path:
    """The paper rotor at G6.3 with 0.5 % noise and a 0.5 um probe floor,
    written by ``rotorid simulate``."""
    out = tmp_path_factory.mktemp("sweep") / "sweep.csv"
    r = cli(
        "simulate", "--model", "paper", "--out", str(out), "--noise", "0.005",
        "--noise-floor", "5e-7", "--balance-grade", "6.3", "--seed", "3",
    )
    assert r.returncode == 0, r.stderr
    return out


def test_model():
    m = rotorid.Model.paper()
    assert m.label == "paper"
    assert m.n_bearings == 2
    assert m.bearing_nodes == [1, 27]
    assert m.planes == [5, 11, 21]
    assert m.channels == ["b1_y", "b1_z", "b2_y", "b2_z"]
    s = rotorid.Model.load(STEPPED)
    assert s.label == "stepped_hollow" and s.n_bearings == 2
    assert rotorid.Model.load(str(STEPPED)).bearing_nodes == s.bearing_nodes


def test_simulate_dtype_shape_and_cli(sweep):
    m = rotorid.Model.paper()
    q = m.simulate(SPEEDS, noise=0.005, noise_floor=5e-7, balance_grade=6.3, seed=3)
    assert q.dtype == np.complex128 and q.shape == (300, 4)
    speeds, phasors, std = rotorid.read_measurements(sweep)
    assert speeds.dtype == np.float64 and speeds.shape == (300,)
    assert phasors.dtype == np.complex128 and phasors.shape == (300, 4)
    assert std is None
    np.testing.assert_allclose(speeds, SPEEDS, rtol=1e-14)
    np.testing.assert_allclose(phasors, q, rtol=1e-12, atol=0)
    # A list is taken as well as an array.
    q2 = m.simulate(list(SPEEDS[:3]))
    assert q2.shape == (3, 4)


def test_identify_equals_cli_json(sweep, tmp_path):
    out = tmp_path / "id.json"
    r = cli("identify", "--model", "paper", "--measurements", str(sweep), "--json", str(out))
    assert r.returncode == 0, r.stderr
    expected = json.loads(out.read_text())
    m = rotorid.Model.paper()
    speeds, phasors, _ = rotorid.read_measurements(sweep)
    ident = rotorid.identify(m, speeds, phasors)
    assert_close(ident.to_dict(), expected)
    # The arrays are the JSON's numbers.
    assert ident.k.shape == (2, 4) and ident.k.dtype == np.float64
    assert ident.c.shape == (2, 4)
    for b, bearing in enumerate(expected["bearings"]):
        for j, name in enumerate(["yy", "yz", "zy", "zz"]):
            assert math.isclose(ident.k[b, j], bearing["k"][name], rel_tol=1e-12)
    k_std, c_std = ident.std
    assert k_std.shape == (2, 4) and np.all(k_std > 0) and np.all(c_std > 0)
    assert ident.unbalance.dtype == np.complex128 and ident.unbalance.shape == (3,)
    for a, u in zip(ident.unbalance, expected["unbalance"]):
        assert math.isclose(abs(a), u["me"], rel_tol=1e-12)
    assert ident.planes == [5, 11, 21]
    assert ident.noise["source"] == "estimated" and len(ident.noise["floor_m"]) == 4
    assert ident.warnings == expected["warnings"]
    k, c = ident.bearings_at(np.array([1000.0, 5000.0]))
    assert k.shape == (2, 2, 4) and c.shape == (2, 2, 4)
    np.testing.assert_array_equal(k[1], ident.k)


def test_identify_options_and_std_columns(sweep, tmp_path):
    """The per-sample standard deviations and non-default options reach
    the library as the command line's do."""
    speeds, phasors, _ = rotorid.read_measurements(sweep)
    std = 5e-7 + 0.005 * np.abs(phasors)
    with_std = tmp_path / "std.csv"
    lines = ["speed_rpm," + ",".join(f"{c}_re,{c}_im,{c}_std" for c in rotorid.Model.paper().channels)]
    for s, row, sd in zip(speeds, phasors, std):
        cells = [repr(float(s))]
        for z, d in zip(row, sd):
            cells += [repr(float(z.real)), repr(float(z.imag)), repr(float(d))]
        lines.append(",".join(cells))
    with_std.write_text("\n".join(lines) + "\n")
    out = tmp_path / "id.json"
    r = cli(
        "identify", "--model", "paper", "--measurements", str(with_std), "--json", str(out),
        "--order", "2", "--runout", "none",
    )
    assert r.returncode == 0, r.stderr
    s2, q2, std2 = rotorid.read_measurements(with_std)
    np.testing.assert_array_equal(std2, std)
    ident = rotorid.identify(rotorid.Model.paper(), s2, q2, std2, order=2, runout="none")
    assert ident.noise["source"] == "file"
    assert_close(ident.to_dict(), json.loads(out.read_text()))


def test_diagnose_equals_cli_json(sweep, tmp_path):
    out = tmp_path / "d.json"
    r = cli("diagnose", "--model", "paper", "--measurements", str(sweep), "--json", str(out))
    assert r.returncode == 0, r.stderr
    expected = json.loads(out.read_text())
    speeds, phasors, _ = rotorid.read_measurements(sweep)
    d = rotorid.diagnose(rotorid.Model.paper(), speeds, phasors)
    assert_close(d.to_dict(), expected)
    assert d.effect == expected["effect"] == "none"
    assert d.gain == expected["gain"]
    assert isinstance(d.hypotheses, list) and d.hypotheses
    assert isinstance(d.observability, list)


def test_campbell_equals_cli_json(tmp_path):
    out = tmp_path / "c.json"
    r = cli("campbell", "--model", str(STEPPED), "--rpm-max", "12000", "--json", str(out))
    assert r.returncode == 0, r.stderr
    c = rotorid.campbell(rotorid.Model.load(STEPPED), rpm_max=12000.0)
    assert_close(c, json.loads(out.read_text()))
    assert c["critical_speeds"]


def signals_csv(path: pathlib.Path) -> None:
    """A run-down from 3000 to 2400 rpm in 4 s sampled at 6400 Hz: the
    paper rotor's bearing responses at G6.3 (turned to each instant's
    speed), a probe gap, a 2X, white noise, and a keyphasor pulse whose
    rising edge crosses mid-level as the mark passes (SPEC section 8)."""
    m = rotorid.Model.paper()
    fs, t_end = 6400.0, 4.0
    grid = np.linspace(2300.0, 3100.0, 81)
    q = m.simulate(grid, balance_grade=6.3)
    t = np.arange(int(fs * t_end)) / fs
    w0, w1 = 3000.0 * np.pi / 30, 2400.0 * np.pi / 30
    alpha = (w1 - w0) / t_end
    theta = 0.3 + w0 * t + 0.5 * alpha * t * t
    rpm = (w0 + alpha * t) * 30 / np.pi
    rng = np.random.default_rng(5)
    cols = []
    for c in range(4):
        y = np.interp(rpm, grid, q[:, c].real) + 1j * np.interp(rpm, grid, q[:, c].imag)
        sig = (y * np.exp(1j * theta)).real + 0.3 * np.abs(y) * np.cos(2 * theta + c)
        cols.append(sig - 1e-3 + 2e-6 * rng.standard_normal(t.size))
    u = (theta + np.pi) % (2 * np.pi) - np.pi
    kp = np.where(u >= np.pi / 2, 0.0, np.clip(0.5 + u / 0.2, 0.0, 1.0))
    lines = ["time_s,kp,b1_y,b1_z,b2_y,b2_z"]
    for i in range(t.size):
        lines.append(",".join(repr(float(v)) for v in (t[i], kp[i], cols[0][i], cols[1][i], cols[2][i], cols[3][i])))
    path.write_text("\n".join(lines) + "\n")


def test_vectors_equal_the_cli(tmp_path):
    signals = tmp_path / "run.csv"
    signals_csv(signals)
    out = tmp_path / "v.csv"
    r = cli("vectors", "--signals", str(signals), "--out", str(out))
    assert r.returncode == 0, r.stderr
    speeds, q, std, info = rotorid.vectors(signals)
    assert q.dtype == np.complex128 and q.shape == (len(speeds), 4) and std.shape == q.shape
    assert info["channels"] == ["b1_y", "b1_z", "b2_y", "b2_z"]
    assert info["accepted"] > 8 * len(speeds) - 1 and sum(info["rejected"].values()) >= 2
    assert -160.0 < info["sweep_rate_rpm_per_s"] < -140.0
    s2, q2, std2 = rotorid.read_measurements(out)
    np.testing.assert_allclose(speeds, s2, rtol=1e-14)
    np.testing.assert_array_equal(q, q2)
    np.testing.assert_array_equal(std, std2)
    # A run-down: speeds as recorded.
    assert np.all(np.diff(speeds) < 0)
    with pytest.raises(rotorid.RotorIdError, match="revolutions must be in"):
        rotorid.vectors(signals, revolutions=1)


def test_errors(tmp_path):
    m = rotorid.Model.paper()
    q = m.simulate(SPEEDS[:20], balance_grade=6.3)
    with pytest.raises(rotorid.RotorIdError, match="3 columns, the model's 2 bearings need 4"):
        rotorid.identify(m, SPEEDS[:20], q[:, :3])
    with pytest.raises(rotorid.RotorIdError, match="rows for 19 speeds"):
        rotorid.identify(m, SPEEDS[:19], q)
    bad = q.copy()
    bad[4, 2] = np.nan
    with pytest.raises(rotorid.RotorIdError, match=r"sample 5 \(250 rpm\): b2_y is not finite"):
        rotorid.identify(m, SPEEDS[:20], bad)
    with pytest.raises(ValueError, match="--lambda must be in"):
        rotorid.identify(m, SPEEDS[:20], q, lam=2.0)
    with pytest.raises(rotorid.RotorIdError, match="formulation"):
        rotorid.identify(m, SPEEDS[:20], q, formulation="complex")
    with pytest.raises(rotorid.RotorIdError, match="at least 8"):
        rotorid.diagnose(m, SPEEDS[:5], q[:5])
    with pytest.raises(rotorid.RotorIdError, match="not found"):
        rotorid.Model.load(tmp_path / "missing.toml")
    bad_csv = tmp_path / "bad.csv"
    bad_csv.write_text("speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,b2_y_re,b2_y_im,b2_z_re,b2_z_im\n10,1,2\n")
    with pytest.raises(rotorid.RotorIdError, match="line 2"):
        rotorid.read_measurements(bad_csv)
    with pytest.raises(rotorid.RotorIdError, match="noise must be finite"):
        m.simulate(SPEEDS[:3], noise=-1.0)


def test_identify_releases_the_gil():
    """Another Python thread runs while the library identifies: the main
    thread's longest pause during the call is a small part of it (holding
    the GIL, it would be the whole call)."""
    m = rotorid.Model.paper()
    q = m.simulate(SPEEDS, noise=0.005, noise_floor=5e-7, balance_grade=6.3)
    span = {}

    def work():
        span["t0"] = time.perf_counter()
        span["id"] = rotorid.identify(m, SPEEDS, q)
        span["t1"] = time.perf_counter()

    worker = threading.Thread(target=work)
    ticks = []
    worker.start()
    while worker.is_alive():
        ticks.append(time.perf_counter())
    worker.join()
    inside = [t for t in ticks if span["t0"] <= t <= span["t1"]]
    edges = [span["t0"], *inside, span["t1"]]
    longest = max(b - a for a, b in zip(edges, edges[1:]))
    assert longest < 0.5 * (span["t1"] - span["t0"]), (longest, span["t1"] - span["t0"])


def test_to_ross_round_trip(sweep):
    ross = pytest.importorskip("ross", reason="ROSS is not installed")
    speeds, phasors, _ = rotorid.read_measurements(sweep)
    ident = rotorid.identify(rotorid.Model.paper(), speeds, phasors)
    rotor = ident.to_ross()
    assert isinstance(rotor, ross.Rotor)
    back = rotorid.Model.from_ross(rotor)
    assert back.bearing_nodes == [1, 27]


def test_three_bearing_rotor_to_ross_and_back():
    """A rotor on three bearings, two of them away from the shaft's ends:
    identified from a realistic sweep (G6.3, 0.5 % + 0.5 um), handed to
    ROSS and read back with its bearings where they were; and rotorid's
    committed export of its model loads in ROSS with its three bearings."""
    ross = pytest.importorskip("ross", reason="ROSS is not installed")
    model = rotorid.Model.load(str(THREE))
    assert model.bearing_nodes == [1, 21, 33]
    speeds = np.arange(40.0, 12001.0, 40.0)
    q = model.simulate(speeds, noise=0.005, noise_floor=0.5e-6, balance_grade=6.3)
    ident = rotorid.identify(model, speeds, q)
    rotor = ident.to_ross()
    assert isinstance(rotor, ross.Rotor)
    assert sorted(b.n for b in rotor.bearing_elements) == [0, 20, 32]
    assert rotorid.Model.from_ross(rotor).bearing_nodes == [1, 21, 33]
    saved = ross.Rotor.load(str(THREE_ROSS))
    assert sorted(b.n for b in saved.bearing_elements) == [0, 20, 32]
    assert rotorid.Model.from_ross(saved).bearing_nodes == [1, 21, 33]
