"""rotorid beside ROSS: ROSS's example rotor, ROSS's own unbalance
response read at the bearings as a probe system reports it (0-pk
amplitude, phase as ROSS writes it: a lag), with probe noise (0.5 % plus a
0.5 um floor); rotorid identifies the bearings and the unbalance, and ROSS
draws the identified rotor's natural frequencies.

    python std-ext/python/examples/ross_side_by_side.py

Needs ``ross-rotordynamics`` 3.1 (Python 3.13) and the ``rotorid`` wheel.
"""

from __future__ import annotations

import numpy as np
import ross as rs

import rotorid

rng = np.random.default_rng(1)

# ROSS's example rotor: 6 shaft elements, 2 disks, 2 bearings.
rotor = rs.rotor_example()
model = rotorid.Model.from_ross(rotor)
print(model)

# ROSS's unbalance response, 50 rpm steps to 9000 rpm; the unbalance at the
# disks at balance grade G6.3 for the rotor's mass at 9000 rpm.
speeds_rpm = np.arange(100.0, 9001.0, 50.0)
omega = speeds_rpm * np.pi / 30.0
me = 6.3e-3 * rotor.m / omega[-1] / 2  # kg m per disk
disks = [d.n for d in rotor.disk_elements]
resp = rotor.run_unbalance_response(disks, [me, me], [0.0, 2.0], speed_range=omega)

# The bearing probes as a monitoring system names them (y: ROSS's x at 0
# deg, z: ROSS's y at 90 deg); 0-pk amplitude (m) and phase lag (deg).
probes, columns = [], []
bearings = sorted(rotor.bearing_elements, key=lambda b: b.n)
for k, brg in enumerate(bearings, start=1):
    for axis, angle in (("y", 0.0), ("z", np.pi / 2)):
        probes.append(rs.Probe(brg.n, angle, tag=f"b{k}_{axis}"))
        columns.append(f"b{k}_{axis}")
amp = resp.data_magnitude(probes, frequency_units="RPM", amplitude_units="m")
lag = resp.data_phase(probes, frequency_units="RPM", phase_units="deg")
phasors = np.column_stack(
    [amp[c].to_numpy() * np.exp(-1j * np.radians(lag[c].to_numpy())) for c in columns]
)

# Probe noise: 0.5 % of the response plus a 0.5 um floor.
noise = (0.005 * np.abs(phasors) + 0.5e-6) * (
    rng.standard_normal(phasors.shape) + 1j * rng.standard_normal(phasors.shape)
) / np.sqrt(2)
measured = phasors + noise

ident = rotorid.identify(model, speeds_rpm, measured)
k_std, c_std = ident.std
print(f"\nidentified at {ident.speed_rpm:.0f} rpm, beside ROSS's bearings (nodes from 1)")
for b, brg in enumerate(bearings):
    K, C = np.asarray(brg.K(omega[-1])), np.asarray(brg.C(omega[-1]))
    print(
        f"  node {brg.n + 1}: kyy {ident.k[b, 0]:.4e} +- {k_std[b, 0]:.1e} (ROSS {K[0, 0]:.4e}), "
        f"kzz {ident.k[b, 3]:.4e} +- {k_std[b, 3]:.1e} (ROSS {K[1, 1]:.4e}) N/m; "
        f"cyy {ident.c[b, 0]:.3g} +- {c_std[b, 0]:.1g} (ROSS {C[0, 0]:.3g}), "
        f"czz {ident.c[b, 3]:.3g} +- {c_std[b, 3]:.1g} (ROSS {C[1, 1]:.3g}) N s/m"
    )
for node, a in zip(ident.planes, ident.unbalance):
    print(f"  unbalance at node {node}: m e {abs(a):.3e} kg m at {np.degrees(np.angle(a)):.1f} deg")
print(f"  ROSS: m e {me:.3e} kg m at 0.0 and {np.degrees(2.0):.1f} deg at nodes {[n + 1 for n in disks]}")
print(f"  noise: {ident.noise}")

# Back to ROSS: the identified rotor's natural frequencies beside the
# original's.
identified = ident.to_ross()
for name, r in (("ROSS model", rotor), ("identified", identified)):
    wn = r.run_modal(speed=0).wn[:4] / (2 * np.pi)
    print(f"{name:>10}: natural frequencies at rest {np.round(wn, 3).tolist()} Hz")
