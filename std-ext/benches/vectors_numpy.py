"""Angle-domain 1X reference for the `rotorid vectors` benchmark.

Reads the benchmark WAV (examples/signals_wav.rs: channels 0..3 probes in
volts at 7.87 V/mm, channel 4 the keyphasor, 32-bit float, full scale 20 V)
with NumPy (the RIFF chunks read directly: the standard library's
`wave` refuses float samples), finds the keyphasor's
rising crossings of the level midway between its extremes (linear
interpolation between samples), takes per revolution the 1X Fourier
integral in angle, the angle linear in time between events,
Y = (1/pi) sum y_i exp(-j theta_i) dtheta_i, averages groups of 8
revolutions and writes speed_rpm and re/im per channel as CSV.

    python vectors_numpy.py IN.wav OUT.csv
"""
import sys

import numpy as np


def main(src, dst):
    # The standard library's `wave` reads integer PCM only (it refuses
    # WAVE_FORMAT_IEEE_FLOAT): the RIFF chunks are read directly.
    raw = open(src, "rb").read()
    pos, fmt, data = 12, None, None
    while pos + 8 <= len(raw):
        cid, size = raw[pos:pos + 4], int.from_bytes(raw[pos + 4:pos + 8], "little")
        body = raw[pos + 8:pos + 8 + size]
        if cid == b"fmt ":
            fmt = body
        elif cid == b"data":
            data = body
        pos += 8 + size + (size & 1)
    nch = int.from_bytes(fmt[2:4], "little")
    fs = int.from_bytes(fmt[4:8], "little")
    x = np.frombuffer(data, dtype="<f4").reshape(-1, nch).astype(np.float64) * 20.0
    kp = x[:, 4]
    y = x[:, :4] / 7870.0
    level = 0.5 * (kp.min() + kp.max())
    above = kp >= level
    i = np.nonzero(~above[:-1] & above[1:])[0]
    ev = i + (level - kp[i]) / (kp[i + 1] - kp[i])
    n = np.arange(len(kp), dtype=np.float64)
    theta = np.interp(n, ev, 2.0 * np.pi * np.arange(len(ev)), left=np.nan, right=np.nan)
    first, last = int(np.ceil(ev[0])), int(np.floor(ev[-1]))
    th = theta[first:last + 1]
    dth = np.gradient(th)
    w = np.exp(-1j * th) * dth / np.pi
    rev = np.floor(th / (2 * np.pi)).astype(np.int64)
    starts = np.r_[0, np.nonzero(np.diff(rev))[0] + 1]
    yy = y[first:last + 1] - y[first]
    per_rev = np.add.reduceat(yy * w[:, None], starts, axis=0)
    period = np.diff(ev)[: len(per_rev)]
    speed = 60.0 * fs / period[: len(per_rev)]
    g = len(per_rev) // 8
    vec = per_rev[: 8 * g].reshape(g, 8, 4).mean(axis=1)
    spd = speed[: 8 * g].reshape(g, 8).mean(axis=1)
    out = np.column_stack([spd] + [c for k in range(4) for c in (vec[:, k].real, vec[:, k].imag)])
    np.savetxt(dst, out, delimiter=",", header="speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,b2_y_re,b2_y_im,b2_z_re,b2_z_im", comments="")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
