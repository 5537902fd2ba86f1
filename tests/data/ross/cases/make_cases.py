"""Build the ROSS-made diagnosis cases in this folder.

Each case is one measurement file (rotorid's CSV, re/im layout, metres,
rotorid's phasor convention) of a rotor whose unbalance response ROSS 3.1.0
computed with one hidden effect (or none) in ROSS's own element forms, plus
probe noise. ``index.json`` is the answer key: per case the file, the
rotorid model to diagnose it against, the hidden effect (the names of
rotorid's ``diagnose``), its form, size and place, and the seed.

Usage (from any folder, with the ROSS venv's python):

    python make_cases.py
        writes every case, the noise-free nominal responses and index.json.

Everything is drawn from ``numpy.random.default_rng(seed)`` with the seed of
the case (listed in index.json), in a fixed order, so re-runs on the same
library versions give the same files.

Conventions (see ../README.md, "Conventions"): ROSS's rotor axis is z with
transverse x, y; rotorid's is x with transverse y, z. ROSS x, y at a node are
rotorid's y, z; both write a signal as Re{X exp(j w t)} and spin the rotor
from the first transverse axis toward the second, and both put the unbalance
force of ``m e exp(j phase)`` at ``(1, -j) m e w^2 exp(j phase)``, so ROSS's
complex response at the bearing nodes is rotorid's measurement as it is.
ROSS numbers nodes from 0, as rotorid does inside; the files and index.json
give nodes numbered from 1 (rotorid's files and reports).
"""

import os
import sys

# ROSS assembles the rotor matrices by iterating over a set of elements
# hashed by their tag strings: fix the hash seed (a fresh interpreter) and
# use one BLAS thread so that re-runs give the same files bit for bit.
if os.environ.get("PYTHONHASHSEED") != "0":
    os.environ["PYTHONHASHSEED"] = "0"
    os.execv(sys.executable, [sys.executable] + sys.argv)
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import copy
import json
import math
import warnings
from pathlib import Path

import numpy as np

import ross as rs
from ross.materials import Material

ROSS_VERSION = "3.1.0"
assert rs.__version__ == ROSS_VERSION, (
    f"these cases are made with ROSS {ROSS_VERSION}, found {rs.__version__}"
)

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[3]

RPM = math.pi / 30.0  # rad/s per rpm
BALANCE_GRADE = 6.3e-3  # G6.3: e Omega_max = 6.3 mm/s
NOISE_RELATIVE = 0.005  # s of E|e|^2 = f^2 + s^2 |q|^2
NOISE_FLOOR = 0.5e-6  # f (m)
CASES_PER_EFFECT = 3
EFFECTS = [
    "none",
    "speed_dependent_bearing",
    "foundation_flexibility",
    "shaft_stiffness_error",
    "extra_unbalance_plane",
    "probe_runout",
    "probe_sensitivity",
]
COEFFS = ["kxx", "kxy", "kyx", "kyy", "cxx", "cxy", "cyx", "cyy"]

# The rotors: the ROSS file that ROSS loads, the rotorid model file the
# cases are diagnosed against (paths relative to the repository), the
# unbalance planes of that model (numbered from 1, as in the model file; a
# ROSS file's planes are its disk nodes) and the speed grid (rpm: first,
# last, step; 300 speeds from a slow roll to above the highest critical speed
# of the range).
ROTORS = [
    {
        "name": "paper",
        "ross": "examples/paper_ross.toml",
        "model": "examples/paper.toml",
        "planes": [5, 11, 21],
        # the paper's grid (lateral criticals near 5800, 6110, 15400 rpm
        # with the model bearings; the scattered ones move them)
        "rpm": (50.0, 15000.0, 50.0),
    },
    {
        "name": "stepped_hollow",
        "ross": "tests/data/ross/stepped_hollow.toml",
        "model": "tests/data/ross/stepped_hollow.toml",
        "planes": [5, 9],
        "rpm": (40.0, 12000.0, 40.0),
    },
    {
        "name": "three_bearing",
        # written by rotorid's ROSS writer from the model file (exact: the
        # same elements, bearings and materials); see the README
        "ross": "tests/data/ross/cases/three_bearing.ross.toml",
        "model": "tests/data/rotors/three_bearing.toml",
        "planes": [11, 27, 41],
        # lateral criticals (ROSS) near 3480, 3850, 8000, 8530, 11650,
        # 13270 and 15210 rpm; the next is above 25000
        "rpm": (55.0, 16500.0, 55.0),
    },
]


# ---------------------------------------------------------------------------
# JSON


def clean(value):
    """Plain JSON values (numpy scalars and arrays to Python ones)."""
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
        assert math.isfinite(value)
        return value
    if value is None or isinstance(value, str):
        return value
    raise TypeError(f"cannot write {type(value)} to JSON")


def write_json(path, data):
    path.write_text(json.dumps(clean(data), indent=1) + "\n")


# ---------------------------------------------------------------------------
# Rotors


class Quiet:
    """Silence ROSS's warnings (none is expected; counted to be sure)."""

    def __enter__(self):
        self._ctx = warnings.catch_warnings(record=True)
        self.caught = self._ctx.__enter__()
        warnings.simplefilter("always")
        return self

    def __exit__(self, *exc):
        self._ctx.__exit__(*exc)
        self.messages = sorted({str(w.message) for w in self.caught})
        return False


def constant(brg, name):
    values = getattr(brg, name)
    assert len(values) == 1, f"bearing at node {brg.n}: {name} is not constant"
    return float(values[0])


def build(base, bearings, point_masses=(), e_factor=None, od=None):
    """``base``'s shaft and disks rebuilt from their constructors, on
    ``bearings`` (and ``point_masses``); the shaft's E times ``e_factor`` (G
    kept), or the outer diameter of the elements in ``od = (elements,
    factor)`` times the factor."""
    shaft = []
    for el in base.shaft_elements:
        mat = el.material
        if e_factor is not None:
            mat = Material(name=f"{mat.name}_E", rho=mat.rho, E=mat.E * e_factor, G_s=mat.G_s)
        odl, odr = el.odl, el.odr
        if od is not None and el.n in od[0]:
            odl, odr = odl * od[1], odr * od[1]
        shaft.append(
            rs.ShaftElement(
                L=el.L, idl=el.idl, odl=odl, idr=el.idr, odr=odr, material=mat, n=el.n,
                shear_effects=el.shear_effects, rotary_inertia=el.rotary_inertia,
                gyroscopic=el.gyroscopic, shear_method_calc=el.shear_method_calc,
                alpha=el.alpha, beta=el.beta, tag=el.tag,
            )
        )  # fmt: skip
    disks = [rs.DiskElement(n=d.n, m=d.m, Id=d.Id, Ip=d.Ip, tag=d.tag) for d in base.disk_elements]
    return rs.Rotor(shaft, disks, list(bearings), list(point_masses))


def bearing(n, co, tag, **extra):
    return rs.BearingElement(n=n, tag=tag, **co, **extra)


def response(rotor, unbalance, omegas):
    nodes = [u[0] for u in unbalance]
    with Quiet() as q:
        resp = rotor.run_unbalance_response(
            nodes, [u[1] for u in unbalance], [u[2] for u in unbalance], speed_range=omegas
        )
    assert not q.messages, q.messages
    return resp.forced_resp


def dof(element, node, axis):
    return int(element.dof_global_index[f"{axis}_{node}"])


def probe_response(rotor, unbalance, omegas, shaft_bearings, links=None):
    """Complex response at the bearing probes, rotorid's channel order
    ``b1_y, b1_z, b2_y, ...`` (bearings by node): ROSS x, y at each shaft
    bearing node, minus the pedestal's where the bearing sits on one
    (``links``: bearing index -> the pedestal's ground bearing; proximity
    probes on the housing read the shaft relative to it)."""
    fr = response(rotor, unbalance, omegas)
    by_n = {b.n: b for b in rotor.bearing_elements}
    q = []
    for k, brg in enumerate(shaft_bearings):
        el = by_n[brg.n]
        for axis in ("x", "y"):
            z = fr[dof(el, brg.n, axis), :].copy()
            if links and k in links:
                ped = links[k]
                z -= fr[dof(ped, ped.n, axis), :]
            q.append(z)
    return np.array(q).T  # speeds x channels


def first_critical(rotor):
    """Lowest forward critical speed (rad/s) of ``rotor``
    (``run_critical_speed`` with ROSS's defaults), or the lowest lateral
    one when ROSS labels none of them forward (on bearings as anisotropic
    as the three-bearing rotor's, every whirl is elliptic and ROSS calls it
    ``Mixed``; ``None`` marks torsional and axial modes)."""
    with Quiet():
        crit = rotor.run_critical_speed()
    wn = np.asarray(crit.wn())
    whirl = list(crit.whirl_direction)
    forward = [w for w, d in zip(wn, whirl) if d == "Forward"]
    lateral = [w for w, d in zip(wn, whirl) if d != "None"]
    return float(min(forward or lateral))


# ---------------------------------------------------------------------------
# Effects


def scatter(rng, base_bearings):
    """Each model bearing coefficient times U(0.7, 1.3), constant."""
    out = []
    for brg in base_bearings:
        out.append({c: constant(brg, c) * rng.uniform(0.7, 1.3) for c in COEFFS})
    return out


def film_table(rng, co, omega_max, npts=9):
    """Fluid-film-like speed table (ROSS ``frequency=`` arrays, PCHIP):
    direct stiffness ``K (1 - a/2 + a r^1.5)``, cross-coupled stiffness
    ``k_xy + g K_d r`` and ``k_yx - g K_d r`` (``K_d`` the mean direct
    stiffness), direct damping ``C (1 + d/2 - d r)``, cross-coupled damping
    as drawn, ``r = Omega / Omega_max``."""
    a = rng.uniform(0.3, 0.6)
    g = rng.uniform(0.15, 0.35)
    d = rng.uniform(0.3, 0.6)
    w = omega_max * np.linspace(0.0, 1.0, npts)
    r = w / omega_max
    kd = 0.5 * (co["kxx"] + co["kyy"])
    table = {
        "kxx": co["kxx"] * (1 - a / 2 + a * r**1.5),
        "kyy": co["kyy"] * (1 - a / 2 + a * r**1.5),
        "kxy": co["kxy"] + g * kd * r,
        "kyx": co["kyx"] - g * kd * r,
        "cxx": co["cxx"] * (1 + d / 2 - d * r),
        "cyy": co["cyy"] * (1 + d / 2 - d * r),
        "cxy": co["cxy"] * np.ones(npts),
        "cyx": co["cyx"] * np.ones(npts),
    }
    return {k: list(v) for k, v in table.items()}, list(w), (a, g, d)


def channel_name(ch):
    return f"b{ch // 2 + 1}_{'y' if ch % 2 == 0 else 'z'}"


def make_case(spec, base, base_bearings, effect, k, seed, omegas, crit):
    """One case: (probe response with noise, hidden-effect record)."""
    rng = np.random.default_rng(seed)
    nb = len(base_bearings)
    omega_max = float(omegas[-1])
    co = scatter(rng, base_bearings)
    planes = [p - 1 for p in spec["planes"]]
    mass = float(base.m)
    me_total = BALANCE_GRADE * mass / omega_max
    shares = rng.uniform(0.5, 1.5, len(planes))
    shares = shares / shares.sum()
    unbalance = [
        (n, me_total * s, rng.uniform(0.0, 2 * math.pi)) for n, s in zip(planes, shares)
    ]
    me_plane = me_total / len(planes)
    bearings = [bearing(b.n, co[i], f"Bearing {i}") for i, b in enumerate(base_bearings)]
    hidden = {"effect": effect}
    rotor_kw = {}
    links = None
    gain = None
    runout = []
    extra = []
    if effect == "none":
        hidden["form"] = "nothing: the scattered bearings and the G6.3 unbalance"
    elif effect == "speed_dependent_bearing":
        bearings = []
        laws = []
        for i, b in enumerate(base_bearings):
            table, w, (a, g, d) = film_table(rng, co[i], omega_max)
            bearings.append(rs.BearingElement(n=b.n, tag=f"Bearing {i}", frequency=w, **table))
            laws.append({"bearing": i + 1, "a": a, "g": g, "d": d})
        hidden["form"] = (
            "BearingElement tables over frequency= (9 points, 0..Omega_max, PCHIP): "
            "K (1 - a/2 + a r^1.5), k_xy + g K_d r, k_yx - g K_d r, C (1 + d/2 - d r)"
        )
        hidden["size"] = max(x["a"] for x in laws)
        hidden["unit"] = "relative change of the direct stiffness over the range (a)"
        hidden["laws"] = laws
    elif effect == "foundation_flexibility":
        b = int(rng.integers(nb))
        m_y = rng.uniform(0.5, 2.0) * mass / nb
        m_z = m_y * rng.uniform(1.2, 1.6)
        w_y = rng.uniform(0.5, 1.6) * crit
        w_z = w_y * rng.uniform(1.0, 1.25)
        z_y, z_z = rng.uniform(0.02, 0.08), rng.uniform(0.02, 0.08)
        p = len(base.nodes)  # the point mass's node, after the shaft nodes
        bearings[b] = bearing(base_bearings[b].n, co[b], f"Bearing {b}", n_link=p)
        ground = rs.BearingElement(
            n=p, tag="Pedestal", kxx=m_y * w_y**2, kyy=m_z * w_z**2,
            cxx=2 * z_y * m_y * w_y, cyy=2 * z_z * m_z * w_z,
        )  # fmt: skip
        bearings.append(ground)
        rotor_kw["point_masses"] = [rs.PointMass(n=p, mx=m_y, my=m_z, mz=m_y, tag="Pedestal mass")]
        links = {b: ground}
        hidden["form"] = (
            "bearing linked (n_link) to a PointMass with mx != my, on a bearing to ground"
        )
        hidden.update(
            bearing=b + 1, node=int(base_bearings[b].n) + 1, size=w_y,
            unit="rad/s (pedestal natural frequency in y, uncoupled)",
            mass_kg=[m_y, m_z], natural_frequency_hz=[w_y / (2 * math.pi), w_z / (2 * math.pi)],
            damping_ratio=[z_y, z_z], first_critical_ratio=w_y / crit,
        )  # fmt: skip
    elif effect == "shaft_stiffness_error":
        form = ["E", "diameter", "E" if rng.random() < 0.5 else "diameter"][k]
        if form == "E":
            f = 1 + rng.uniform(0.03, 0.10) * (1 if rng.random() < 0.5 else -1)
            rotor_kw["e_factor"] = f
            hidden["form"] = "shaft Material with E alone changed (G_s kept)"
            hidden["unit"] = "factor on E"
        else:
            f = 1 + rng.uniform(0.02, 0.05) * (1 if rng.random() < 0.5 else -1)
            n_el = len(base.shaft_elements)
            length = max(n_el // 3, 1)
            first = int(rng.integers(0, n_el - length + 1))
            elements = list(range(first, first + length))
            rotor_kw["od"] = (elements, f)
            hidden["form"] = (
                f"outer diameter of shaft elements {first}..{first + length - 1} "
                "(ROSS numbering) changed"
            )
            hidden["unit"] = "factor on the outer diameter"
            hidden["elements"] = elements
        hidden["size"] = f
    elif effect == "extra_unbalance_plane":
        spread = [1, 3, 2][k]
        bearing_nodes = {int(b.n) for b in base_bearings}
        n_nodes = len(base.nodes)
        allowed = [n for n in range(n_nodes) if n not in planes and n not in bearing_nodes]
        starts = [n for n in allowed if all(n + i in allowed for i in range(spread))]
        start = starts[int(rng.integers(len(starts)))]
        me = rng.uniform(0.3, 1.0) * me_plane
        phase = rng.uniform(0.0, 2 * math.pi)
        nodes = list(range(start, start + spread))
        for n in nodes:
            ph = phase + (rng.uniform(-0.2, 0.2) if spread > 1 else 0.0)
            extra.append((n, me / spread, ph))
        hidden["form"] = (
            "an extra unbalance at a node that is not a plane"
            if spread == 1
            else f"an extra unbalance spread equally over {spread} adjacent nodes, phases within 0.2 rad"
        )
        hidden.update(
            node=nodes[spread // 2] + 1 if spread != 2 else nodes[0] + 1,
            nodes=[n + 1 for n in nodes], size=me, unit="kg m (total)",
            phase_rad=phase, plane_ratio=me / me_plane,
        )  # fmt: skip
    elif effect == "probe_runout":
        nq = 2 * nb
        first = int(rng.integers(nq))
        chans = [first]
        if rng.random() < 0.5:
            chans.append((first + int(rng.integers(1, nq))) % nq)
        for ch in chans:
            amp = rng.uniform(3e-6, 15e-6)
            ph = rng.uniform(0.0, 2 * math.pi)
            runout.append((ch, amp * complex(math.cos(ph), math.sin(ph))))
        hidden["form"] = "a constant phasor added to the channel's reading at every speed"
        hidden.update(
            channel=channel_name(chans[0]), channel_index=chans[0], size=abs(runout[0][1]),
            unit="m (first channel)",
            runout=[{"channel": channel_name(c), "channel_index": c, "re": z.real,
                     "im": z.imag, "amplitude_m": abs(z)} for c, z in runout],
        )  # fmt: skip
    elif effect == "probe_sensitivity":
        ch = int(rng.integers(2 * nb))
        g = 1 + rng.uniform(0.05, 0.20) * (1 if rng.random() < 0.5 else -1)
        gain = (ch, g)
        hidden["form"] = "one channel's reading times a real factor"
        hidden.update(channel=channel_name(ch), channel_index=ch, size=g, unit="factor")
    else:
        raise ValueError(effect)

    rotor = build(
        base, bearings, rotor_kw.get("point_masses", ()), rotor_kw.get("e_factor"),
        rotor_kw.get("od"),
    )  # fmt: skip
    q = probe_response(rotor, unbalance + extra, omegas, base_bearings, links)
    if gain is not None:
        q[:, gain[0]] *= gain[1]
    for ch, z in runout:
        q[:, ch] += z
    # SPEC section 7: E|e|^2 = f^2 + s^2 |q|^2, two independent standard
    # complex Gaussians (E|eps|^2 = 1).
    shape = q.shape

    def eps():
        return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / math.sqrt(2)

    q = q + NOISE_FLOOR * eps() + NOISE_RELATIVE * np.abs(q) * eps()
    record = {
        "unbalance": [
            {"node": n + 1, "me": me, "phase_rad": ph} for n, me, ph in unbalance
        ],
        "bearings": [
            {"node": int(b.n) + 1, **{c: co[i][c] for c in COEFFS}}
            for i, b in enumerate(base_bearings)
        ],
    }
    return q, hidden, record


# ---------------------------------------------------------------------------
# Files


def write_csv(path, rpm, q, comments):
    nq = q.shape[1]
    header = ["speed_rpm"]
    for ch in range(nq):
        header += [f"{channel_name(ch)}_re", f"{channel_name(ch)}_im"]
    lines = [f"# {c}" for c in comments] + [",".join(header)]
    for i, s in enumerate(rpm):
        row = [f"{s:.10g}"]
        for z in q[i]:
            row += [f"{z.real:.9e}", f"{z.imag:.9e}"]
        lines.append(",".join(row))
    path.write_text("\n".join(lines) + "\n")


def main():
    cases = []
    rotors = []
    for ri, spec in enumerate(ROTORS):
        print(f"{spec['name']} ...", flush=True)
        with Quiet():
            base = rs.Rotor.load(REPO / spec["ross"])
        assert not base.point_mass_elements
        base_bearings = sorted(base.bearing_elements, key=lambda b: b.n)
        assert [d.n + 1 for d in base.disk_elements] == spec["planes"] or spec["name"] != "stepped_hollow"
        lo, hi, step = spec["rpm"]
        rpm = lo + step * np.arange(round((hi - lo) / step) + 1)
        assert len(rpm) == 300 and rpm[-1] == hi
        omegas = rpm * RPM
        crit = first_critical(base)
        # The rebuilt rotor (every element from its constructor) is the
        # loaded one: same response to within rounding.
        nominal_co = [{c: constant(b, c) for c in COEFFS} for b in base_bearings]
        rebuilt = build(
            base, [bearing(b.n, nominal_co[i], f"Bearing {i}") for i, b in enumerate(base_bearings)]
        )
        planes = [p - 1 for p in spec["planes"]]
        me_total = BALANCE_GRADE * float(base.m) / float(omegas[-1])
        nominal_unbalance = [
            (n, me_total / len(planes), 2 * math.pi * i / len(planes)) for i, n in enumerate(planes)
        ]
        q_loaded = probe_response(base, nominal_unbalance, omegas, base_bearings)
        q_rebuilt = probe_response(rebuilt, nominal_unbalance, omegas, base_bearings)
        rebuild_error = float(np.max(np.abs(q_loaded - q_rebuilt)) / np.max(np.abs(q_loaded)))
        assert rebuild_error < 1e-9, rebuild_error
        nominal_file = f"{spec['name']}.nominal.csv"
        write_csv(
            HERE / nominal_file, rpm, q_loaded,
            [f"ROSS {rs.__version__}: {spec['ross']} as loaded, unbalance response without noise",
             "unbalance (node from 1, kg m, rad): "
             + ", ".join(f"({n + 1}, {me!r}, {ph!r})" for n, me, ph in nominal_unbalance)],
        )  # fmt: skip
        rotors.append(
            {
                "name": spec["name"],
                "ross_file": spec["ross"],
                "model": spec["model"],
                "planes": spec["planes"],
                "bearing_nodes": [int(b.n) + 1 for b in base_bearings],
                "mass_kg": float(base.m),
                "speeds_rpm": {"first": lo, "last": hi, "step": step, "count": len(rpm)},
                "first_critical_rpm": crit / RPM,
                "unbalance_total_kg_m": me_total,
                "nominal_response": {
                    "file": nominal_file,
                    "unbalance": [
                        {"node": n + 1, "me": me, "phase_rad": ph}
                        for n, me, ph in nominal_unbalance
                    ],
                    "rebuilt_vs_loaded": rebuild_error,
                },
            }
        )
        print(f"  first forward critical {crit / RPM:.0f} rpm, rebuilt {rebuild_error:.1e}", flush=True)
        for ei, effect in enumerate(EFFECTS):
            for k in range(CASES_PER_EFFECT):
                seed = 10000 * (ri + 1) + 100 * ei + k
                number = ei * CASES_PER_EFFECT + k + 1
                name = f"{spec['name']}_{number:02d}.csv"
                q, hidden, record = make_case(
                    spec, base, base_bearings, effect, k, seed, omegas, crit
                )
                write_csv(
                    HERE / name, rpm, q,
                    [f"ROSS {rs.__version__} unbalance response of {spec['ross']}, made by "
                     "make_cases.py (the answer is in index.json)",
                     f"probe noise: E|e|^2 = f^2 + s^2 |q|^2, f = {NOISE_FLOOR} m, s = {NOISE_RELATIVE}"],
                )  # fmt: skip
                cases.append(
                    {"file": name, "rotor": spec["name"], "model": spec["model"],
                     "seed": seed, **hidden, **record}  # fmt: skip
                )
                print(f"  {name}: {effect} {hidden.get('size', '')}", flush=True)
    index = {
        "generator": "make_cases.py",
        "versions": {"ross": rs.__version__, "numpy": np.__version__,
                     "python": sys.version.split()[0]},  # fmt: skip
        "balance_grade_mm_s": BALANCE_GRADE * 1e3,
        "noise": {"relative": NOISE_RELATIVE, "floor_m": NOISE_FLOOR},
        "bearing_scatter": "each coefficient of the model's bearings times U(0.7, 1.3)",
        "nodes": "numbered from 1 (rotorid's files); ROSS's node is one less",
        "rotors": rotors,
        "cases": cases,
    }
    write_json(HERE / "index.json", index)
    print(f"{len(cases)} cases", flush=True)


if __name__ == "__main__":
    main()
