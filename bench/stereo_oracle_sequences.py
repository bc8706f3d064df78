#!/usr/bin/env python3
"""Oracle sequences for stereo depth: which part of block matching's error holds tracking back.

Usage: bench/stereo_oracle_sequences.py STEREO TRUTH OUT [--fx F --fy F --cx C --cy C]

STEREO is a `rigfit simulate-sequence --noise stereo` sequence, TRUTH the same command with
`--noise none` (same seed, size and frames: the same path). Writes three TUM-layout sequences,
each the truth where STEREO has depth and a hole where it has none:
  OUT-holes  the truth itself (stereo's holes only);
  OUT-white  plus white noise as large as stereo's error at that depth (1.4826 x the median
             absolute deviation of the error in 0.5 m bins of true depth, per frame);
  OUT-bias   plus stereo's error smoothed by a Gaussian of 6 px (its slowly varying part: the
             per-surface bias of block matching).
Track each with `rigfit track OUT-x --evaluate` (docs/benchmarks.md, "Dense RGB-D tracking").
Needs numpy and the rigfit Python module (PYTHONPATH=build/python).
"""
import argparse
import os
import shutil
import struct
import zlib

import numpy as np
import rigfit


def write_depth_png(path, depth_m, scale=5000.0):
    """16-bit grey PNG, `scale` units per metre, 0 for no depth (the TUM convention)."""
    h, w = depth_m.shape
    units = np.where(np.isfinite(depth_m), np.round(depth_m * scale), 0).astype(">u2")
    raw = b"".join(b"\x00" + units[y].tobytes() for y in range(h))

    def chunk(tag, body):
        return (struct.pack(">I", len(body)) + tag + body +
                struct.pack(">I", zlib.crc32(tag + body) & 0xFFFFFFFF))

    header = struct.pack(">IIBBBBB", w, h, 16, 0, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) +
                chunk(b"IDAT", zlib.compress(raw, 1)) + chunk(b"IEND", b""))


def smooth(values, sigma_px):
    """Gaussian smoothing of an image with NaN holes (normalised by the valid weight)."""
    r = int(3 * sigma_px)
    kernel = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma_px) ** 2)

    def separable(a):
        a = np.apply_along_axis(lambda row: np.convolve(row, kernel, "same"), 1, a)
        return np.apply_along_axis(lambda col: np.convolve(col, kernel, "same"), 0, a)

    valid = np.isfinite(values)
    return separable(np.where(valid, values, 0.0)) / np.maximum(separable(valid * 1.0), 1e-9)


def noise_sigma(truth, error, valid, bin_m=0.5):
    """Per pixel: the robust standard deviation of the error at its true depth."""
    sigma = np.zeros_like(truth)
    for lo in np.arange(0.0, np.nanmax(truth) + bin_m, bin_m):
        in_bin = (truth >= lo) & (truth < lo + bin_m)
        m = valid & in_bin
        if m.sum() > 20:
            sigma[in_bin] = 1.4826 * np.median(np.abs(error[m] - np.median(error[m])))
    return sigma


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("stereo")
    p.add_argument("truth")
    p.add_argument("out")
    p.add_argument("--fx", type=float, default=262.5)
    p.add_argument("--fy", type=float, default=262.5)
    p.add_argument("--cx", type=float, default=159.5)
    p.add_argument("--cy", type=float, default=119.5)
    a = p.parse_args()
    K = (a.fx, a.fy, a.cx, a.cy)
    stereo = rigfit.open_sequence(a.stereo, intrinsics=K)
    truth = rigfit.open_sequence(a.truth, intrinsics=K)
    kinds = ("holes", "white", "bias")
    for kind in kinds:
        folder = f"{a.out}-{kind}"
        if os.path.exists(folder):
            raise SystemExit(f"{folder} exists: not overwritten")
        os.makedirs(os.path.join(folder, "depth"))
        for name in ("groundtruth.txt", "depth.txt"):
            shutil.copy(os.path.join(a.stereo, name), folder)
    names = [l.split()[1] for l in open(os.path.join(a.stereo, "depth.txt"))
             if l.strip() and not l.startswith("#")]
    rng = np.random.default_rng(1)
    for i, name in enumerate(names):
        s = np.array(stereo[i].depth, float)
        t = np.array(truth[i].depth, float)
        s[~(s > 0)] = np.nan
        t[~(t > 0)] = np.nan
        valid = np.isfinite(s) & np.isfinite(t)
        error = s - t
        images = {
            "holes": np.where(valid, t, np.nan),
            "white": np.where(valid, t + noise_sigma(t, error, valid) *
                              rng.standard_normal(t.shape), np.nan),
            "bias": np.where(valid, t + smooth(np.where(valid, error, np.nan), 6.0), np.nan),
        }
        for kind in kinds:
            write_depth_png(os.path.join(f"{a.out}-{kind}", name), images[kind])
        if (i + 1) % 30 == 0:
            print(f"{i + 1} of {len(names)} frames", flush=True)


if __name__ == "__main__":
    main()
