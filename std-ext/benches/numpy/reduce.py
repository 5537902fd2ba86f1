"""Independent NumPy reduction of the paper rotor to its bearing DOFs.

The reference side of the whole-process comparison with `rotorid tables`
(README, "Benchmark: building the tables for 1000 speeds"). It reads the
shaft matrices that `examples/export_matrices.rs` writes and, for 1000
speeds (15..15000 rpm, evenly spaced in rad/s, the grid of
`std-ext/benches/tables.rs`), forms

    Z = K - w^2 M + j w^2 G                       (shaft and disks only)

and evaluates the literal dense Schur complement (Eqs. 38/39 of
`rotorid::reduce`), with `B` the bearing translations in channel order
(`b1_y, b1_z, b2_y, b2_z`) and `i` every other shaft DOF:

    X = Z_ii^-1 [Z_iB, T_i]                       (numpy.linalg.solve)
    A = Z_BB - Z_Bi X[:, :2N_b]
    B = w^2 (T_B - Z_Bi X[:, 2N_b:])

It writes one array of shape (n_speeds, 2N_b, 2N_b + N_p), `[A | B]` per
speed, to a .npy file, and prints the time of the computation alone
(`time.perf_counter` and `time.process_time`, file reading and writing
excluded; the CPU time counts every BLAS thread).

Reproduce (from the workspace root):

    cargo run --release --example export_matrices -- /tmp/rotorid-npy
    python std-ext/benches/numpy/reduce.py /tmp/rotorid-npy --check
    OPENBLAS_NUM_THREADS=1 /usr/bin/time -f '%e s wall %U s user' \
        python std-ext/benches/numpy/reduce.py /tmp/rotorid-npy
    /usr/bin/time -f '%e s wall %U s user' \
        target/release/rotorid tables --model paper \
        --rpm-min 15 --rpm-max 15000 --rpm-step 15 --out /tmp/t.bin

Options:

    --out FILE   the .npy written (default DIR/numpy_AB.npy)
    --check      also compare with rotorid's A and B at the three speeds
                 of model.json (banded split reduction and modal reduction)
    --batched    one stacked numpy.linalg.solve over all speeds instead of
                 a Python loop over the speeds (same results)

OPENBLAS_NUM_THREADS=1 keeps OpenBLAS on one thread, as rotorid is; on a
loaded 2-core machine its default (one thread per core) made the whole
script 7 to 60 times slower (threads waiting for each other on the small
solves).

The literal formula subtracts numbers of the order of the shaft's element
stiffness to get A; its relative accuracy is about eps |Z_BB| / |A|
(see the module docs of `rotorid::reduce`), so the agreement with rotorid
is best at high speed.
"""

import argparse
import json
import os
import time

import numpy as np


def load(d):
    with open(os.path.join(d, "model.json")) as f:
        meta = json.load(f)
    files = meta["files"]

    def real(name):
        return np.fromfile(os.path.join(d, name), dtype="<f8").reshape(files[name])

    def cplx(name):
        return np.fromfile(os.path.join(d, name), dtype="<c16").reshape(files[name])

    return meta, real("K.f64"), real("M.f64"), real("G.f64"), cplx("T.c128"), cplx


def speeds(n=1000, rpm_min=15.0, rpm_max=15000.0):
    return np.linspace(rpm_min * np.pi / 30.0, rpm_max * np.pi / 30.0, n)


def reduce_loop(K, M, G, T, b, i, omegas):
    """A and B per speed, one dense solve per speed."""
    nq, np_ = len(b), T.shape[1]
    out = np.empty((len(omegas), nq, nq + np_), dtype=complex)
    Ti, TB = T[i, :], T[b, :]
    for k, w in enumerate(omegas):
        Z = K - w**2 * M + 1j * w**2 * G
        Zii = Z[np.ix_(i, i)]
        ZiB = Z[np.ix_(i, b)]
        ZBi = Z[np.ix_(b, i)]
        ZBB = Z[np.ix_(b, b)]
        X = np.linalg.solve(Zii, np.hstack([ZiB, Ti]))
        out[k, :, :nq] = ZBB - ZBi @ X[:, :nq]
        out[k, :, nq:] = w**2 * (TB - ZBi @ X[:, nq:])
    return out


def reduce_batched(K, M, G, T, b, i, omegas):
    """The same, with one stacked solve over all speeds."""
    nq = len(b)
    w2 = (omegas**2)[:, None, None]
    Z = K[None] - w2 * M[None] + 1j * w2 * G[None]
    Zii = Z[:, i][:, :, i]
    ZiB = Z[:, i][:, :, b]
    ZBi = Z[:, b][:, :, i]
    ZBB = Z[:, b][:, :, b]
    rhs = np.concatenate([ZiB, np.broadcast_to(T[i, :], (len(omegas),) + T[i, :].shape)], axis=2)
    X = np.linalg.solve(Zii, rhs)
    A = ZBB - ZBi @ X[:, :, :nq]
    B = w2 * (T[b, :][None] - ZBi @ X[:, :, nq:])
    return np.concatenate([A, B], axis=2)


def rel(x, ref):
    return np.linalg.norm(x - ref) / np.linalg.norm(ref)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("dir")
    p.add_argument("--out")
    p.add_argument("--check", action="store_true")
    p.add_argument("--batched", action="store_true")
    a = p.parse_args()

    meta, K, M, G, T, cplx = load(a.dir)
    n = meta["n"]
    b = np.array(meta["bearing_dofs"])
    i = np.array([d for d in range(n) if d not in set(meta["bearing_dofs"])])
    omegas = speeds()
    red = reduce_batched if a.batched else reduce_loop

    t0, c0 = time.perf_counter(), time.process_time()
    AB = red(K, M, G, T, b, i, omegas)
    t1, c1 = time.perf_counter(), time.process_time()
    out = a.out or os.path.join(a.dir, "numpy_AB.npy")
    np.save(out, AB)
    print(
        f"numpy {np.__version__}: {len(omegas)} speeds, n = {n}, "
        f"{len(b)} bearing DOFs, {T.shape[1]} planes, "
        f"{'batched' if a.batched else 'loop'}: compute {1e3 * (t1 - t0):.1f} ms wall, {1e3 * (c1 - c0):.1f} ms CPU; wrote {out}"
    )

    if a.check:
        nq = len(b)
        ws = np.array(meta["check_omega"])
        mine = red(K, M, G, T, b, i, ws)
        for tag in ("", "_modal"):
            RA, RB = cplx(f"check_A{tag}.c128"), cplx(f"check_B{tag}.c128")
            for k, w in enumerate(ws):
                print(
                    f"check vs rotorid {'modal' if tag else 'banded'} at {w * 30 / np.pi:8.1f} rpm: "
                    f"|dA|/|A| = {rel(mine[k, :, :nq], RA[k]):.2e}, "
                    f"|dB|/|B| = {rel(mine[k, :, nq:], RB[k]):.2e}"
                )
        idx = np.array(meta["check_index"])
        assert np.allclose(omegas[idx], ws, rtol=1e-15, atol=0), "speed grids differ"
        print(f"grid speeds {idx.tolist()} of the .npy equal the check speeds: "
              f"max |d[A|B]| = {np.abs(AB[idx] - mine).max():.1e}")


if __name__ == "__main__":
    main()
