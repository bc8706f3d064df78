#!/usr/bin/env python3
"""Refine a rig's extrinsics with rigfit from a Python pipeline (docs/python.md).

What a calibration script that levels the floor with RANSAC and then runs pairwise Open3D ICP
(its flags --icp, --icp-method point_to_plane|gicp, --icp-voxel-size, metrics under
_meta.icp_refined) does instead: read the HDF5 capture and the JSON extrinsics, call
rigfit.refine (leveling and registration in one call), write the refined extrinsics with
rigfit's report as _meta.

    PYTHONPATH=build/python python3 python/examples/refine_with_rigfit.py \\
        --capture rig/capture.h5 --extrinsics rig/init.json --out refined.json
"""

import argparse
import logging
import sys

import rigfit


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--capture", required=True, help="rig capture (HDF5)")
    parser.add_argument("--extrinsics", required=True, help="initial extrinsics (JSON)")
    parser.add_argument("--out", required=True, help="refined extrinsics (JSON)")
    parser.add_argument("--method", choices=["point_to_plane", "gicp", "surface_bundle"],
                        help="registration residual (default: rigfit's, point_to_plane)")
    parser.add_argument("--voxel-size", type=float, help="finest voxel size in metres")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")

    try:
        cameras = rigfit.read_capture(args.capture)
        initial = rigfit.read_extrinsics(args.extrinsics)
        # None (a flag not given) leaves rigfit's default.
        result = rigfit.refine(cameras, initial, method=args.method, voxel_size=args.voxel_size)
        rigfit.write_extrinsics(args.out, result.extrinsics, meta=result.meta)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for serial, T in sorted(result.extrinsics.items()):
        moved = T[:3, 3] - initial[serial][:3, 3]
        print(f"{serial}: moved {1e3 * (moved @ moved) ** 0.5:.1f} mm")
    print(("refined" if result.success else f"not applied: {result.message}") +
          f" -> {args.out}")
    return 0 if result.success else 3


if __name__ == "__main__":
    sys.exit(main())
