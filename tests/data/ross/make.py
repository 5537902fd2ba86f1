"""Build the ROSS reference fixtures in this folder.

Rotors are built with ROSS's own API, saved with ``Rotor.save`` (TOML, as
ROSS writes it) and loaded back with ``Rotor.load``; the results are computed
by ROSS on the loaded rotor and written as ``<name>.results.json``.

Usage (from this folder, with the ROSS venv's python):

    python make.py
        writes every fixture and result file.

    python make.py --check-export FILE.toml --out RESULT.json [--speeds-rpm 0 5000]
        loads a rotor file (e.g. one written by rotorid's ROSS writer) in ROSS
        and writes its natural frequencies and log decrements.

    python make.py --probe-tables-only
        writes only the probe tables (ROSS's amplitude and phase per probe,
        ``rotor_example.probes_*.csv``); the full run writes them too.

All numbers are SI: rad/s, m, kg, N/m, N*s/m. Speeds are given in rad/s in
the JSON files; the rpm they came from is stated next to them.
"""

import os
import sys

# ROSS assembles the rotor matrices by iterating over a set of elements
# hashed by their tag strings, so the summation order (and the last bits of
# every result) depends on Python's string-hash seed. Fix the seed (this
# needs a fresh interpreter) and use one BLAS thread, so re-runs give the
# same files bit for bit.
if os.environ.get("PYTHONHASHSEED") != "0":
    os.environ["PYTHONHASHSEED"] = "0"
    os.execv(sys.executable, [sys.executable] + sys.argv)
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import math
import warnings
from pathlib import Path

import numpy as np

import ross as rs
from ross.materials import Material, steel
from ross.units import Q_

ROSS_VERSION = "3.1.0"
assert rs.__version__ == ROSS_VERSION, (
    f"these fixtures are made with ROSS {ROSS_VERSION}, found {rs.__version__}"
)

HERE = Path(__file__).resolve().parent

RPM = math.pi / 30.0  # rad/s per rpm
MODAL_SPEEDS_RPM = [0.0, 1000.0, 3000.0, 6000.0]
MODAL_NUM_MODES = 24  # run_modal returns num_modes // 2 = 12 modes
N_RESPONSE_SPEEDS = 60
COEFFICIENTS = [
    "kxx", "kxy", "kyx", "kyy", "kzz",
    "cxx", "cxy", "cyx", "cyy", "czz",
    "mxx", "mxy", "myx", "myy", "mzz",
]  # fmt: skip


# ---------------------------------------------------------------------------
# JSON helpers


def clean(value):
    """Turn numpy values into plain JSON values (NaN/inf become null)."""
    if isinstance(value, dict):
        return {str(k): clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return clean(value.tolist())
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        value = float(value)
        return value if math.isfinite(value) else None
    if isinstance(value, (np.str_, str)):
        return str(value)
    if value is None:
        return None
    raise TypeError(f"cannot write {type(value)} to JSON")


def write_json(path, data):
    """Write JSON with each array of plain values on one line.

    Floats are written with Python's repr (json's default), which round-trips.
    """
    path.write_text(_dump(clean(data), 0) + "\n")


def _dump(obj, level):
    pad = " " * (level + 1)
    if isinstance(obj, dict):
        if not obj:
            return "{}"
        items = [f"{pad}{json.dumps(k)}: {_dump(v, level + 1)}" for k, v in obj.items()]
        return "{\n" + ",\n".join(items) + "\n" + " " * level + "}"
    if isinstance(obj, list):
        if all(not isinstance(v, (dict, list)) for v in obj):
            return "[" + ", ".join(json.dumps(v, allow_nan=False) for v in obj) + "]"
        items = [pad + _dump(v, level + 1) for v in obj]
        return "[\n" + ",\n".join(items) + "\n" + " " * level + "]"
    return json.dumps(obj, allow_nan=False)


# ---------------------------------------------------------------------------
# Rotors


def stepped_hollow_rotor():
    """Fixture 3: stepped hollow shaft, 2 disks, 2 cross-coupled bearings."""
    # (number of elements, length, inner diameter, outer diameter)
    sections = [
        (2, 0.10, 0.020, 0.060),
        (3, 0.15, 0.030, 0.090),
        (2, 0.12, 0.040, 0.120),
        (3, 0.15, 0.030, 0.090),
        (2, 0.10, 0.020, 0.060),
    ]
    shaft = [
        rs.ShaftElement(L=L, idl=i_d, odl=o_d, material=steel)
        for count, L, i_d, o_d in sections
        for _ in range(count)
    ]
    disks = [
        rs.DiskElement.from_geometry(n=4, material=steel, width=0.05, i_d=0.09, o_d=0.35),
        rs.DiskElement.from_geometry(n=8, material=steel, width=0.06, i_d=0.09, o_d=0.30),
    ]
    bearings = [
        rs.BearingElement(
            n=0, kxx=2.0e7, kyy=3.0e7, kxy=5.0e6, kyx=-4.0e6,
            cxx=2.0e3, cyy=2.5e3, cxy=150.0, cyx=-100.0,
        ),
        rs.BearingElement(
            n=12, kxx=2.5e7, kyy=3.5e7, kxy=-3.0e6, kyx=6.0e6,
            cxx=1.8e3, cyy=2.2e3, cxy=-80.0, cyx=120.0,
        ),
    ]  # fmt: skip
    return rs.Rotor(shaft, disks, bearings)


# Fixture 4 tables: 5 points, 1500..7500 rpm, nonlinear in speed.
TABLE_RPM = [1500.0, 3000.0, 4500.0, 6000.0, 7500.0]


def table_rotor():
    """Fixture 4: the shaft of rotor_example on two speed-dependent bearings.

    Bearing 0 is tabulated on ``speed`` (the rotor-speed axis, which is what
    ROSS 2's ``frequency`` argument became in ROSS 3). Bearing 1 is
    tabulated on ``frequency`` (the whirl-frequency axis of ROSS 3). Every
    run_* analysis used here is synchronous, so both are evaluated at the
    rotor speed.
    """
    w = np.array(TABLE_RPM) * RPM
    shaft = [
        rs.ShaftElement(0.25, 0.0, 0.05, material=steel, shear_effects=True,
                        rotary_inertia=True, gyroscopic=True)
        for _ in range(6)
    ]  # fmt: skip
    disks = [
        rs.DiskElement.from_geometry(n=2, material=steel, width=0.07, i_d=0.05, o_d=0.28),
        rs.DiskElement.from_geometry(n=4, material=steel, width=0.07, i_d=0.05, o_d=0.28),
    ]
    bearing0 = rs.BearingElement(
        n=0,
        kxx=[1.0e6, 1.3e6, 1.8e6, 2.6e6, 3.9e6],
        kyy=[0.8e6, 1.0e6, 1.4e6, 2.1e6, 3.2e6],
        kxy=[0.5e5, 1.5e5, 3.2e5, 5.6e5, 9.0e5],
        kyx=[-0.4e5, -1.2e5, -2.9e5, -5.2e5, -8.1e5],
        cxx=[900.0, 650.0, 520.0, 450.0, 420.0],
        cyy=[1100.0, 800.0, 640.0, 560.0, 520.0],
        # not monotonic: PCHIP keeps the peak at a table point
        cxy=[40.0, 95.0, 120.0, 90.0, 60.0],
        cyx=[-30.0, -70.0, -85.0, -80.0, -40.0],
        speed=w,
    )
    bearing1 = rs.BearingElement(
        n=6,
        kxx=[1.2e6, 1.5e6, 2.1e6, 3.0e6, 4.4e6],
        kyy=[0.9e6, 1.1e6, 1.6e6, 2.4e6, 3.6e6],
        kxy=[0.3e5, 1.0e5, 2.5e5, 4.4e5, 7.5e5],
        kyx=[-0.6e5, -1.4e5, -3.0e5, -5.5e5, -8.8e5],
        cxx=[1000.0, 700.0, 560.0, 480.0, 450.0],
        cyy=[1200.0, 860.0, 690.0, 600.0, 560.0],
        cxy=[20.0, 60.0, 75.0, 75.0, 50.0],
        cyx=[-25.0, -50.0, -90.0, -60.0, -35.0],
        frequency=w,
    )
    return rs.Rotor(shaft, disks, [bearing0, bearing1])


def support_mass_rotor():
    """Fixture 5: bearings on pedestal point masses, pedestals on ground."""
    shaft = [
        rs.ShaftElement(0.25, 0.0, 0.05, material=steel, shear_effects=True,
                        rotary_inertia=True, gyroscopic=True)
        for _ in range(6)
    ]  # fmt: skip
    disks = [
        rs.DiskElement.from_geometry(n=2, material=steel, width=0.07, i_d=0.05, o_d=0.28),
        rs.DiskElement.from_geometry(n=4, material=steel, width=0.07, i_d=0.05, o_d=0.28),
    ]
    bearings = [
        # shaft to pedestal
        rs.BearingElement(n=0, n_link=7, kxx=1.0e7, kyy=0.8e7, kxy=1.0e6,
                          kyx=-1.0e6, cxx=500.0, cyy=600.0),
        rs.BearingElement(n=6, n_link=8, kxx=1.2e7, kyy=0.9e7, cxx=550.0,
                          cyy=650.0),
        # pedestal to ground
        rs.BearingElement(n=7, kxx=2.0e6, kyy=3.0e6, cxx=2000.0, cyy=2500.0),
        rs.BearingElement(n=8, kxx=2.2e6, kyy=3.3e6, cxx=2100.0, cyy=2600.0),
    ]  # fmt: skip
    point_masses = [
        rs.PointMass(n=7, mx=15.0, my=20.0, mz=20.0),
        rs.PointMass(n=8, m=18.0),
    ]
    return rs.Rotor(shaft, disks, bearings, point_masses)


def coaxial_rotor():
    """Fixture 6: a steel shaft with an aluminium sleeve as a coaxial layer.

    ROSS models coaxial layers as several ShaftElements with the same node
    number ``n`` (the compressor example does this). Each layer adds its own
    matrices between the same two nodes.
    """
    aluminium = Material(name="Aluminium", rho=2700.0, E=70e9, G_s=26e9)
    shaft = [
        rs.ShaftElement(L=0.2, idl=0.0, odl=0.06, material=steel, n=i)
        for i in range(8)
    ]
    # sleeve over elements 2..5 (nodes 2..6), bore equal to the shaft diameter
    sleeve = [
        rs.ShaftElement(L=0.2, idl=0.06, odl=0.10, material=aluminium, n=i)
        for i in range(2, 6)
    ]
    disks = [
        rs.DiskElement.from_geometry(n=3, material=steel, width=0.06, i_d=0.10, o_d=0.32),
        rs.DiskElement.from_geometry(n=5, material=steel, width=0.06, i_d=0.10, o_d=0.32),
    ]
    bearings = [
        rs.BearingElement(n=0, kxx=1.5e7, kyy=1.2e7, cxx=1.0e3, cyy=1.2e3),
        rs.BearingElement(n=8, kxx=1.5e7, kyy=1.2e7, cxx=1.0e3, cyy=1.2e3),
    ]
    return rs.Rotor(shaft + sleeve, disks, bearings)


# Fixture 7: ROSS's compressor example, balanced to grade G2.5 at 11000 rpm
# (the top of its bearing tables, 4000..11000 rpm).
COMPRESSOR_GRADE_MM_S = 2.5
COMPRESSOR_SERVICE_RPM = 11000.0
COMPRESSOR_MODAL_SPEEDS_RPM = [0.0, 4000.0, 8000.0, 11000.0]
# run_critical_speed's Newton iteration converged far below its default
# rtol = 0.005, for a comparison at 0.1 %.
COMPRESSOR_CRITICAL_RTOL = 1e-8


def compressor_no_seals():
    """Fixture 7: ROSS's compressor example with its seals removed.

    ``rs.compressor_example()`` reads ``ross/data/compressor_example.toml``
    (shipped in the ROSS wheel): 91 shaft elements on 55 elements' nodes
    (coaxial layers with the same ``n``, one material with E = G = 6894.75
    Pa that adds mass only), 7 disks, 2 bearings with 8-point speed tables
    (PCHIP) and 12 ``SealElement``s. The rotor is rebuilt with
    ``rs.Rotor(shaft_elements, disk_elements, bearings, point_mass_elements)``
    where ``bearings`` are the bearing elements that are not SealElements
    (SealElement is a subclass of BearingElement); the bearings are kept as
    ROSS has them.
    """
    full = rs.compressor_example()
    bearings = [b for b in full.bearing_elements if not isinstance(b, rs.SealElement)]
    assert len(bearings) == 2 and len(full.bearing_elements) == 14
    return rs.Rotor(
        full.shaft_elements, full.disk_elements, bearings, full.point_mass_elements
    )


def compressor_unbalance(rotor):
    """G2.5 at 11000 rpm (ISO 21940-11: ``m e = G / Omega * mass``), 2/3 of
    it on the first impeller (node 20, phase 0), 1/3 on the last (node 35,
    phase pi/2)."""
    total = COMPRESSOR_GRADE_MM_S * 1e-3 / (COMPRESSOR_SERVICE_RPM * RPM) * rotor.m
    return [(20, 2.0 * total / 3.0, 0.0), (35, total / 3.0, math.pi / 2)]


def magnetic_bearing_rotor():
    """Refused kind: rotor_example's shaft on two magnetic bearings."""
    base = rs.rotor_example()
    amb = dict(g0=1e-3, i0=1.0, ag=1e-4, nw=200, kp_pid=1e5, kd_pid=-1e-5,
               ki_pid=2e-1, k_amp=1.0, k_sense=1.0)  # fmt: skip
    bearings = [rs.MagneticBearingElement(n=n, **amb) for n in (0, 6)]
    return rs.Rotor(base.shaft_elements, base.disk_elements, bearings)


def seal_rotor():
    """Refused kind: rotor_example with a speed-dependent seal at node 3."""
    base = rs.rotor_example()
    w = np.array(TABLE_RPM) * RPM
    seal = rs.SealElement(
        n=3,
        kxx=[1.0e5, 1.1e5, 1.3e5, 1.6e5, 2.0e5],
        kxy=[1.0e4, 2.0e4, 3.1e4, 4.3e4, 5.6e4],
        kyx=[-1.0e4, -2.0e4, -3.1e4, -4.3e4, -5.6e4],
        cxx=[50.0, 52.0, 55.0, 59.0, 64.0],
        speed=w,
        seal_leakage=0.12,
    )
    return rs.Rotor(base.shaft_elements, base.disk_elements,
                    base.bearing_elements + [seal])  # fmt: skip


def tapered_rotor():
    """Refused kind: rotor_example with one tapered (and tapered-bore) element."""
    base = rs.rotor_example()
    shaft = list(base.shaft_elements)
    shaft[1] = rs.ShaftElement(0.25, idl=0.0, odl=0.05, idr=0.01, odr=0.07,
                               material=steel, shear_effects=True,
                               rotary_inertia=True, gyroscopic=True)  # fmt: skip
    for i, sh in enumerate(shaft):
        sh.n = i
    return rs.Rotor(shaft, base.disk_elements, base.bearing_elements)


# name, builder, description, unbalance list [(node, kg m, rad)] or None
LOADABLE = [
    ("rotor_example", rs.rotor_example,
     "rs.rotor_example(): 6 solid elements, 2 disks, 2 constant bearings",
     [(2, 1.0e-4, 0.0), (4, 0.5e-4, math.pi / 2)]),
    ("rotor_example_with_damping", rs.rotor_example_with_damping,
     "rs.rotor_example_with_damping(): 33 elements, rotor-level alpha/beta",
     [(12, 1.0e-5, 0.0), (24, 0.5e-5, math.pi / 2)]),
    ("stepped_hollow", stepped_hollow_rotor,
     "stepped hollow shaft, 2 disks, 2 constant cross-coupled bearings",
     [(4, 2.0e-4, 0.0), (8, 1.0e-4, math.pi / 2)]),
    ("bearing_tables", table_rotor,
     "rotor_example shaft on 2 speed-dependent bearing tables (PCHIP)",
     [(2, 1.0e-4, 0.0), (4, 0.5e-4, math.pi / 2)]),
    ("support_masses", support_mass_rotor,
     "bearings linked to pedestal PointMasses, pedestals to ground",
     [(2, 1.0e-4, 0.0), (4, 0.5e-4, math.pi / 2)]),
    ("coaxial_sleeve", coaxial_rotor,
     "steel shaft with an aluminium sleeve layer (same n), 2 disks",
     [(3, 1.0e-4, 0.0), (5, 0.5e-4, math.pi / 2)]),
    ("compressor_no_seals", compressor_no_seals,
     "rs.compressor_example() without its 12 SealElements: 91 shaft elements "
     "(coaxial layers), 7 disks, 2 bearings on 8-point speed tables (PCHIP)",
     compressor_unbalance),
]  # fmt: skip

# Per-fixture settings other than the defaults: modal speeds (rpm), a
# second run_critical_speed with a tight rtol, the balance grade.
OPTIONS = {
    "compressor_no_seals": {
        "modal_speeds_rpm": COMPRESSOR_MODAL_SPEEDS_RPM,
        "critical_rtol": COMPRESSOR_CRITICAL_RTOL,
        "balance_grade": {
            "grade_mm_s": COMPRESSOR_GRADE_MM_S,
            "service_speed_rpm": COMPRESSOR_SERVICE_RPM,
            "rule": "sum m e = G / Omega * rotor.m (ISO 21940-11), "
            "2/3 at node 20 (phase 0), 1/3 at node 35 (phase pi/2)",
        },
    },
}

REFUSED = [
    ("refused_magnetic_bearing", magnetic_bearing_rotor,
     "rotor_example shaft on 2 MagneticBearingElements (PID)"),
    ("refused_seal", seal_rotor,
     "rotor_example plus a speed-dependent SealElement at node 3"),
    ("refused_tapered_shaft", tapered_rotor,
     "rotor_example with element 1 tapered (odl 0.05 -> odr 0.07, idl 0 -> idr 0.01)"),
]  # fmt: skip


# ---------------------------------------------------------------------------
# Analyses


class Caught:
    """Collect the distinct warning messages raised inside a block."""

    def __init__(self):
        self.messages = []

    def __enter__(self):
        self._cm = warnings.catch_warnings(record=True)
        self._log = self._cm.__enter__()
        warnings.simplefilter("always")
        return self

    def __exit__(self, *exc):
        for w in self._log:
            text = f"{w.category.__name__}: {w.message}"
            if text not in self.messages:
                self.messages.append(text)
        return self._cm.__exit__(*exc)


def modal_data(rotor, speed, num_modes=MODAL_NUM_MODES):
    modal = rotor.run_modal(speed, num_modes=num_modes)
    whirl = modal.whirl_direction()
    return {
        "speed_rad_s": speed,
        "wn": modal.wn,
        "wd": modal.wd,
        "log_dec": modal.log_dec,
        "damping_ratio": modal.damping_ratio,
        "whirl_direction": [str(w) for w in whirl],
        "whirl_values": modal.whirl_values(),
        "mode_type": [s.mode_type for s in modal.shapes],
        "evalue_re": np.real(modal.evalues[: len(modal.wn)]),
        "evalue_im": np.imag(modal.evalues[: len(modal.wn)]),
    }


def modal_block(rotor, speeds_rpm):
    out = []
    for rpm in speeds_rpm:
        with Caught() as caught:
            data = modal_data(rotor, rpm * RPM)
        data = {"speed_rpm": rpm, **data, "warnings": caught.messages}
        out.append(data)
    return out


def critical_block(rotor, rtol=None):
    with Caught() as caught:
        if rtol is None:
            crit = rotor.run_critical_speed()
        else:
            crit = rotor.run_critical_speed(rtol=rtol)
    return {
        "call": "rotor.run_critical_speed()"
        if rtol is None
        else f"rotor.run_critical_speed(rtol={rtol})",
        "arguments": {
            "speed_range": None,
            "num_modes": 12,
            "rtol": 0.005 if rtol is None else rtol,
        },
        "wn": crit.wn(),
        "wd": crit.wd(),
        "log_dec": crit.log_dec,
        "damping_ratio": crit.damping_ratio,
        "whirl_direction": [str(w) for w in crit.whirl_direction],
        "warnings": caught.messages,
    }


def lateral_critical_top(rotor, crit, count=4):
    """Highest of the first ``count`` lateral critical speeds (wd), rad/s.

    Also returns the mode type of each critical speed, taken as
    run_critical_speed does for the whirl direction: mode i of
    run_modal(wd_i) with the default num_modes.
    """
    types = [
        rotor.run_modal(wd).shapes[i].mode_type for i, wd in enumerate(crit["wd"])
    ]
    lateral = [w for w, t in zip(crit["wd"], types, strict=True) if t == "Lateral"]
    return max(lateral[:count]), types


def dof_index(element, node, axis):
    return int(element.dof_global_index[f"{axis}_{node}"])


def probe_nodes(rotor):
    """Bearing nodes (both ends of linked bearings) and disk nodes, with dofs."""
    probes = {}
    for brg in rotor.bearing_elements:
        for node in (brg.n, brg.n_link):
            if node is None or node in probes:
                continue
            probes[node] = {
                "node": node,
                "kind": "bearing",
                "dof_x": dof_index(brg, node, "x"),
                "dof_y": dof_index(brg, node, "y"),
            }
    for disk in rotor.disk_elements:
        if disk.n in probes:
            continue
        probes[disk.n] = {
            "node": disk.n,
            "kind": "disk",
            "dof_x": dof_index(disk, disk.n, "x"),
            "dof_y": dof_index(disk, disk.n, "y"),
        }
    return [probes[k] for k in sorted(probes)]


def response_block(rotor, unbalance, speeds):
    nodes = [u[0] for u in unbalance]
    mags = [u[1] for u in unbalance]
    phases = [u[2] for u in unbalance]
    with Caught() as caught:
        resp = rotor.run_unbalance_response(nodes, mags, phases, speed_range=speeds)
    fr = resp.forced_resp
    probes = []
    for p in probe_nodes(rotor):
        x = fr[p["dof_x"], :]
        y = fr[p["dof_y"], :]
        probes.append(
            {**p, "x_re": x.real, "x_im": x.imag, "y_re": y.real, "y_im": y.imag}
        )
    return {
        "call": "rotor.run_unbalance_response(node, unbalance_magnitude, "
        "unbalance_phase, speed_range=speed_rad_s)",
        "unbalance": [
            {"node": n, "magnitude_kg_m": m, "phase_rad": p}
            for n, m, p in unbalance
        ],
        "speed_rad_s": speeds,
        "probes": probes,
        "warnings": caught.messages,
    }


def coefficients_block(rotor, speeds):
    out = []
    for brg in rotor.bearing_elements:
        entry = {
            "tag": brg.tag,
            "n": brg.n,
            "axis": "speed" if brg.speed is not None else (
                "frequency" if brg.frequency is not None else None),
            "table_axis_rad_s": brg.speed if brg.speed is not None else brg.frequency,
            "interpolation": brg.interpolation,
            "at_rad_s": speeds,
        }  # fmt: skip
        for name in COEFFICIENTS:
            entry[name] = getattr(brg, f"{name}_interpolated")(speeds)
        out.append(entry)
    return out


def rotor_info(rotor):
    return {
        "ndof": rotor.ndof,
        "number_dof_per_node": rotor.number_dof,
        "dof_order_per_node": ["x", "y", "z", "alpha", "beta", "theta"],
        "nodes": rotor.nodes,
        "nodes_pos": rotor.nodes_pos,
        "mass_kg": rotor.m,
        "alpha": rotor.alpha,
        "beta": rotor.beta,
    }


def library_versions():
    import scipy

    return {
        "ross": rs.__version__,
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "python": sys.version.split()[0],
    }


def matrices_equal(a, b, speed=100.0):
    return (
        np.array_equal(a.M(speed), b.M(speed))
        and np.array_equal(a.K(speed), b.K(speed))
        and np.array_equal(a.C(speed), b.C(speed))
        and np.array_equal(a.G(), b.G())
    )


def save_and_load(builder, name):
    built = builder()
    path = HERE / f"{name}.toml"
    if path.exists():
        path.unlink()  # Rotor.save merges into an existing file
    built.save(path)
    with Caught() as caught:
        loaded = rs.Rotor.load(path)
    return built, loaded, path, caught.messages


def make_loadable(name, builder, description, unbalance):
    options = OPTIONS.get(name, {})
    modal_speeds_rpm = options.get("modal_speeds_rpm", MODAL_SPEEDS_RPM)
    built, rotor, path, load_warnings = save_and_load(builder, name)
    same = matrices_equal(built, rotor)
    if callable(unbalance):
        unbalance = unbalance(rotor)
    modal = modal_block(rotor, modal_speeds_rpm)
    crit = critical_block(rotor)
    top, crit_types = lateral_critical_top(rotor, crit)
    crit["mode_type"] = crit_types
    tight = None
    if "critical_rtol" in options:
        tight = critical_block(rotor, options["critical_rtol"])
        tight["mode_type"] = lateral_critical_top(rotor, tight)[1]
    w_end = 1.2 * top
    tables = [
        b for b in rotor.bearing_elements if b.speed is not None or b.frequency is not None
    ]
    for b in tables:
        axis = b.speed if b.speed is not None else b.frequency
        w_end = max(w_end, 1.15 * float(np.max(axis)))
    speeds = np.linspace(100.0 * RPM, w_end, N_RESPONSE_SPEEDS)
    response = response_block(rotor, unbalance, speeds)
    result = {
        "fixture": path.name,
        "description": description,
        "versions": library_versions(),
        "computed_on": "the rotor returned by ross.Rotor.load(fixture)",
        "built_and_loaded_matrices_equal": same,
        "load_warnings": load_warnings,
        "rotor": rotor_info(rotor),
        "modal": {
            "call": f"rotor.run_modal(speed, num_modes={MODAL_NUM_MODES})",
            "num_modes_returned": MODAL_NUM_MODES // 2,
            "order": "ascending damped frequency wd (eigenvalues with imag > 0), "
            "ties by wn; lateral forward/backward, axial and torsional modes "
            "mixed; eigenvalues with |lambda| <= 0.1 dropped",
            "speeds": modal,
        },
        "critical_speeds": crit,
        **({"critical_speeds_tight": tight} if tight is not None else {}),
        **(
            {"balance_grade": {**options["balance_grade"], "rotor_mass_kg": rotor.m}}
            if "balance_grade" in options
            else {}
        ),
        "unbalance_response": {
            **response,
            "speed_range_rule": "linspace(100 rpm, max(1.2 x highest of the first "
            "4 lateral critical speeds wd, 1.15 x last bearing-table point), "
            f"{N_RESPONSE_SPEEDS})",
            "phasor": "x(t) = Re{X exp(j w t)}, w = speed (synchronous); "
            "force at the node Fx = m e w^2 exp(j phase), Fy = -j Fx",
        },
    }
    if tables:
        check = np.unique(
            np.concatenate([speeds, np.array(modal_speeds_rpm) * RPM, crit["wd"]])
        )
        result["bearing_coefficients"] = coefficients_block(rotor, check)
    write_json(HERE / f"{name}.results.json", result)
    return result


# Probe tables: the unbalance response as ROSS reports it per probe
# (ForcedResponseResults.data_magnitude / data_phase), written as rotorid
# measurement files in ROSS's instrument conventions.
PROBE_TABLES = [
    # file suffix, amplitude_units, conventions line (None: no line)
    ("probes_m_0pk_lag", "m", None),
    ("probes_um_pkpk_lag", "um pkpk", "amplitude_unit=um amplitude=pk-pk phase=lag"),
]
# The same run's complex response at the same probes (forced_resp, the
# phasor convention x(t) = Re{X exp(j w t)}: rotorid's own), the reference
# for the tables (another machine's BLAS changes ROSS's last digits).
PROBE_COMPLEX = "probes_complex"


def probe_tables(name, unbalance):
    """Write ``<name>.<suffix>.csv`` for every entry of PROBE_TABLES, and
    ``<name>.probes_complex.csv`` (the same run's ``forced_resp``).

    The rotor is ``ross.Rotor.load(<name>.toml)``, the response
    ``run_unbalance_response`` with the fixture's unbalance at the speeds of
    ``<name>.results.json``. Probes: each bearing node at angle 0 (ROSS x,
    rotorid y) and pi/2 (ROSS y, rotorid z), bearings in node order
    (rotorid's b1, b2, ...). The columns are ROSS's own ``data_magnitude``
    (``amplitude_units`` as listed: 0-pk, or peak-to-peak with ``pkpk``) and
    ``data_phase(phase_units="deg")``, the lag 2 pi - mod(arg P, 2 pi);
    ``frequency_units="RPM"`` gives ``speed_rpm``.
    """
    rotor = rs.Rotor.load(HERE / f"{name}.toml")
    with open(HERE / f"{name}.results.json") as f:
        speeds = np.array(json.load(f)["unbalance_response"]["speed_rad_s"])
    nodes = [u[0] for u in unbalance]
    mags = [u[1] for u in unbalance]
    phases = [u[2] for u in unbalance]
    with Caught():
        resp = rotor.run_unbalance_response(nodes, mags, phases, speed_range=speeds)
    bearings = sorted(rotor.bearing_elements, key=lambda b: b.n)
    probes, columns, dofs = [], [], []
    for k, brg in enumerate(bearings, start=1):
        for axis, ross_axis, angle in (("y", "x", 0.0), ("z", "y", math.pi / 2)):
            tag = f"b{k}_{axis}"
            probes.append(rs.Probe(brg.n, angle, tag=tag))
            columns.append(tag)
            dofs.append(dof_index(brg, brg.n, ross_axis))
    rpm = Q_(speeds, "rad/s").to("RPM").m
    out = [
        f"# ROSS {rs.__version__}: {name}.toml, run_unbalance_response "
        f"{[(n, m, p) for n, m, p in unbalance]} (node, kg m, rad)",
        "# forced_resp at the bearing nodes: ROSS x, y are rotorid y, z",
        ",".join(["speed_rpm"] + [f"{c}_{p}" for c in columns for p in ("re", "im")]),
    ]
    for i in range(len(speeds)):
        row = [repr(float(rpm[i]))]
        for d in dofs:
            z = resp.forced_resp[d, i]
            row += [repr(float(z.real)), repr(float(z.imag))]
        out.append(",".join(row))
    (HERE / f"{name}.{PROBE_COMPLEX}.csv").write_text("\n".join(out) + "\n")
    for suffix, units, line in PROBE_TABLES:
        with Caught():
            mag = resp.data_magnitude(
                probes, frequency_units="RPM", amplitude_units=units
            )
            ph = resp.data_phase(probes, frequency_units="RPM", phase_units="deg")
        out = [
            f"# ROSS {rs.__version__}: {name}.toml, run_unbalance_response "
            f"{[(n, m, p) for n, m, p in unbalance]} (node, kg m, rad)",
            f"# data_magnitude(probes, frequency_units='RPM', amplitude_units='{units}'), "
            "data_phase(probes, frequency_units='RPM', phase_units='deg')",
        ]
        if line is not None:
            out.append(f"# conventions: {line}")
        header = ["speed_rpm"]
        for c in columns:
            header += [f"{c}_amp", f"{c}_phase_deg"]
        out.append(",".join(header))
        for i in range(len(speeds)):
            row = [repr(float(mag["frequency"][i]))]
            for c in columns:
                row += [repr(float(mag[c][i])), repr(float(ph[c][i]))]
            out.append(",".join(row))
        (HERE / f"{name}.{suffix}.csv").write_text("\n".join(out) + "\n")


def make_refused(name, builder, description):
    _, rotor, path, load_warnings = save_and_load(builder, name)
    kinds = sorted({type(b).__name__ for b in rotor.bearing_elements})
    return {"file": path.name, "loads": True, "bearing_classes": kinds,
            "description": description, "load_warnings": load_warnings}  # fmt: skip


def check_export(file, out, speeds_rpm):
    file = Path(file)
    result = {
        "file": file.name,
        "versions": library_versions(),
        "modal_call": f"rotor.run_modal(speed, num_modes={MODAL_NUM_MODES})",
    }
    try:
        with Caught() as caught:
            rotor = rs.Rotor.load(file)
        result["loads"] = True
        result["load_warnings"] = caught.messages
    except Exception as exc:  # record why it does not load
        result["loads"] = False
        result["error"] = f"{type(exc).__name__}: {exc}"
        write_json(Path(out), result)
        return result
    result["rotor"] = rotor_info(rotor)
    result["modal"] = modal_block(rotor, speeds_rpm)
    write_json(Path(out), result)
    return result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check-export", metavar="FILE.toml")
    parser.add_argument("--out", metavar="RESULT.json")
    parser.add_argument("--speeds-rpm", type=float, nargs="+",
                        default=[0.0, 1000.0, 3000.0, 5000.0, 6000.0])  # fmt: skip
    parser.add_argument("--probe-tables-only", action="store_true")
    args = parser.parse_args(argv)

    if args.probe_tables_only:
        name, _, _, unbalance = LOADABLE[0]
        probe_tables(name, unbalance)
        print(f"{name}: probe tables written")
        return

    if args.check_export:
        if not args.out:
            parser.error("--check-export needs --out")
        res = check_export(args.check_export, args.out, args.speeds_rpm)
        print(f"{args.check_export}: loads={res['loads']} -> {args.out}")
        return

    summary = {"versions": library_versions(), "loadable": [], "refused": []}
    for name, builder, description, unbalance in LOADABLE:
        print(f"{name} ...", flush=True)
        res = make_loadable(name, builder, description, unbalance)
        summary["loadable"].append(
            {"file": res["fixture"], "results": f"{name}.results.json",
             "description": description}  # fmt: skip
        )
    for name, builder, description in REFUSED:
        print(f"{name} ...", flush=True)
        summary["refused"].append(make_refused(name, builder, description))
    write_json(HERE / "index.json", summary)
    name, _, _, unbalance = LOADABLE[0]
    probe_tables(name, unbalance)


if __name__ == "__main__":
    main()
