"""rigfit from Python: refine the extrinsics of a depth-camera rig, or simulate one
(docs/python.md).

The same library calls as the CLI: ``refine`` on the same capture, initial extrinsics and
options gives ``rigfit refine``'s poses bit for bit and exactly the ``_meta`` report the CLI
writes (without ``timings_s``); ``simulate`` is ``rigfit simulate``. Nothing is written to
disk unless asked. Bad input raises ``ValueError`` with the library's message. Progress and
warnings go to the logger ``"rigfit"``.
"""

from __future__ import annotations

import json
import logging
import operator
import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Dict, List, Mapping, Optional, Tuple, Union

from . import _rigfit

if TYPE_CHECKING:  # numpy is needed by the arrays, not by the import
    import numpy as np

__all__ = ["RefineResult", "CameraReport", "PairReport", "refine", "load_capture", "save_capture", "load_extrinsics",
           "save_extrinsics", "evaluate", "simulate"]

logger = logging.getLogger("rigfit")

#: serial -> {"depth": (H, W) metres, "K": (3, 3)} or {"points": (N, 3), "normals": (N, 3)}
Cameras = Mapping[str, Mapping[str, Any]]
#: serial -> (4, 4) T_world_camera
Extrinsics = Mapping[str, "np.ndarray"]


@dataclass
class CameraReport:
    """One camera of a refine run (``_meta.icp_refined.cameras.<serial>`` as objects).

    ``covariance`` is the 6x6 covariance of the refined pose in the PoseManifold tangent (world
    rotation vector, world translation; gauge fixed by the reference), joint mode only, else
    None; ``sigma`` its 1-sigma read-off (``yaw_deg``, ``tilt_deg``, ``x_mm``, ``y_mm``,
    ``z_mm``). ``delta_*`` is the registration change (refined against leveled), ``own_*`` the
    change against the rig that the safety bounds apply to.
    """

    serial: str
    reference: bool
    leveled: bool
    leveling_message: str
    leveling_rotation_deg: float
    leveling_translation_m: float
    connected: bool
    accepted: bool
    message: str
    delta_rotation_deg: float
    delta_translation_m: float
    own_rotation_deg: float
    own_translation_m: float
    covariance: Optional["np.ndarray"]
    sigma: Optional[Dict[str, float]]
    weak_directions: List[Dict[str, Any]]


@dataclass
class PairReport:
    """One candidate pair of a refine run: overlap, fit before and after, accepted or why not."""

    serial_a: str
    serial_b: str
    overlap_area_m2: float
    fitness: float
    rmse_before_m: float
    rmse_after_m: float
    correspondences: int
    iterations: int
    accepted: bool
    message: str


@dataclass
class RefineResult:
    """What ``refine`` returns.

    Attributes:
        extrinsics: serial -> (4, 4) float64 T_world_camera: the refined poses, or the leveled
            ones when the refinement was not applied (``success`` False), as the CLI writes.
        success: whether the refinement was applied.
        message: why not, when ``success`` is False.
        warnings: every warning of the run (also logged to ``"rigfit"``).
        cameras: per-camera reports (in serial order), covariance as numpy.
        pairs: per-pair reports.
        meta: the ``_meta`` object ``rigfit refine --no-timings`` writes:
            ``{"ground_refined": ..., "icp_refined": ...}``.
    """

    extrinsics: Dict[str, "np.ndarray"]
    success: bool
    message: str
    warnings: List[str] = field(default_factory=list)
    cameras: List[CameraReport] = field(default_factory=list)
    pairs: List[PairReport] = field(default_factory=list)
    meta: Dict[str, Any] = field(default_factory=dict)


def _config_text(config: Union[None, Mapping[str, Any], str, os.PathLike]) -> tuple:
    """(yaml_text, path) of a config: a dict is written as JSON, which is YAML, and read by the
    YAML loader, so that a dict is checked exactly as a file (unknown keys, types, ranges)."""
    if config is None:
        return "", ""
    if isinstance(config, Mapping):
        return json.dumps(config, indent=2, allow_nan=False), ""
    if isinstance(config, (str, os.PathLike)):
        return "", os.fspath(config)
    raise TypeError(f"config must be a dict, a path or None, got {type(config).__name__}")


def refine(
    cameras: Cameras,
    extrinsics: Extrinsics,
    config: Union[None, Mapping[str, Any], str, os.PathLike] = None,
    *,
    mode: Optional[str] = None,
    method: Optional[str] = None,
    reference: Optional[str] = None,
    level_ground: bool = True,
    threads: int = 2,
) -> RefineResult:
    """Refines the extrinsics of a rig from one capture, as ``rigfit refine``.

    Args:
        cameras: serial -> ``{"depth": (H, W) float32/float64 metres (NaN, <= 0 invalid), "K":
            (3, 3) intrinsics}``, or with uint16 depth and ``"depth_scale"`` (metres per unit),
            or ``{"points": (N, 3) camera-frame metres, "normals": (N, 3) optional}``
            (``load_capture`` returns this layout).
        extrinsics: serial -> (4, 4) T_world_camera, one per camera.
        config: the options (docs/config.md): a dict with the YAML's sections and keys
            (``{"icp": {"voxel_size": 0.03}}``), or the path of a YAML file, or None for
            the defaults.
        mode: "joint" or "pairwise"; overrides icp.mode (None: the config's).
        method: "point_to_plane", "gicp" or "surface_bundle"; overrides icp.method.
        reference: serial of the camera held fixed; overrides icp.reference.
        level_ground: False skips ground leveling (as ``--no-ground``).
        threads: worker threads (1 to 256).

    Raises:
        ValueError: bad input (config, arrays, serials that do not match), with the message.
    """
    yaml_text, path = _config_text(config)
    raw = _rigfit.refine(
        dict(cameras), dict(extrinsics), yaml_text, path, mode or "", method or "",
        reference or "", bool(level_ground), int(threads), logger)
    return RefineResult(
        extrinsics=dict(raw["extrinsics"]),
        success=bool(raw["success"]),
        message=raw["message"],
        warnings=list(raw["warnings"]),
        cameras=[CameraReport(**c) for c in raw["cameras"]],
        pairs=[PairReport(**p) for p in raw["pairs"]],
        meta=json.loads(raw["meta_json"]),
    )


def load_capture(path: Union[str, os.PathLike]) -> Dict[str, Dict[str, "np.ndarray"]]:
    """Reads a rig capture (HDF5, docs/formats.md) in this process, under the CLI's rules.

    Returns serial -> ``{"depth": (H, W) float32 metres with NaN where invalid, "K": (3, 3),
    ["confidence", "color"]}`` or ``{"points": (N, 3), ["normals": (N, 3)]}``, the layout
    ``refine`` takes. Raises ValueError naming the file and dataset on a bad file.
    """
    return dict(_rigfit.load_capture(os.fspath(path), logger))


def save_capture(path: Union[str, os.PathLike], cameras: Cameras, *,
                 depth_as_uint16: bool = False, depth_scale: float = 0.001) -> None:
    """Writes a rig capture (HDF5, docs/formats.md) atomically, as ``rigfit simulate`` does.

    ``cameras`` as ``refine`` takes them (``load_capture``'s layout), checked the same way.
    ``depth_as_uint16`` stores depth as uint16 with ``depth_scale`` metres per unit instead of
    float32 metres. Raises ValueError naming the file and camera on what cannot be written.
    """
    _rigfit.save_capture(os.fspath(path), dict(cameras), bool(depth_as_uint16),
                         float(depth_scale))


def evaluate(estimated: Extrinsics, ground_truth: Extrinsics) -> Dict[str, Any]:
    """Gauge-free errors of estimated extrinsics against the truth, as ``rigfit evaluate --json``.

    Returns ``{"pairs": [{"serial_i", "serial_j", "rotation_deg", "translation_mm"}],
    "cameras": [{"serial", "tilt_deg"}], "summary": {"rotation_deg": {"rms", "max"},
    "translation_mm": ..., "tilt_deg": ...}, "ignored_cameras": [...]}`` over the cameras of
    ``ground_truth``, every one of which must be in ``estimated`` (else ValueError).
    """
    return _rigfit.evaluate(dict(estimated), dict(ground_truth))


def load_extrinsics(path: Union[str, os.PathLike]) -> Dict[str, "np.ndarray"]:
    """Reads an extrinsics file (JSON): serial -> (4, 4) T_world_camera (``_meta`` left out)."""
    return dict(_rigfit.load_extrinsics(os.fspath(path), logger))


def save_extrinsics(path: Union[str, os.PathLike], extrinsics: Extrinsics,
                    meta: Optional[Mapping[str, Any]] = None) -> None:
    """Writes an extrinsics file (JSON) atomically, as the CLI writes it, with ``meta`` (e.g.
    ``RefineResult.meta``) as its ``_meta``."""
    meta_json = "" if meta is None else json.dumps(meta, allow_nan=False)
    _rigfit.save_extrinsics(os.fspath(path), dict(extrinsics), meta_json)


# The keyword defaults below are the library's own (SimOptions), read once from the compiled
# module, so that they cannot drift from the CLI's.
_SIM = _rigfit.simulate_defaults()


def simulate(
    *,
    cameras: int = _SIM["cameras"],
    seed: int = _SIM["seed"],
    width: int = _SIM["width"],
    height: int = _SIM["height"],
    noise: float = _SIM["noise"],
    noise_corr_px: float = _SIM["noise_corr_px"],
    noise_corr_share: float = _SIM["noise_corr_share"],
    disparity_quant_px: float = _SIM["disparity_quant_px"],
    dropout: float = _SIM["dropout"],
    perturb_yaw_deg: float = _SIM["perturb_yaw_deg"],
    perturb_xz_m: float = _SIM["perturb_xz_m"],
    perturb_tilt_deg: float = _SIM["perturb_tilt_deg"],
    bare: bool = _SIM["bare"],
) -> Tuple[Dict[str, Dict[str, "np.ndarray"]], Dict[str, "np.ndarray"], Dict[str, "np.ndarray"]]:
    """Simulates a rig in memory, as ``rigfit simulate`` writes it (same defaults, same checks).

    A furnished room seen by ``cameras`` ZED-like depth cameras; deterministic for a seed (the
    CLI's files for the same options hold the same numbers). The keywords are the CLI's flags:
    ``noise`` is sigma = noise * z^2 (1/m); ``noise_corr_px`` and ``noise_corr_share`` make a
    share of its variance correlated over that many pixels; ``disparity_quant_px`` rounds the
    disparity to multiples of it; ``dropout`` drops that fraction of pixels; ``perturb_*`` set how
    far ``start`` is from ``truth``; ``bare`` leaves the room empty (floor and walls only).

    Returns ``(cameras, truth, start)``: ``cameras`` in ``refine``'s layout (``{"depth", "K",
    "color"}`` per serial), ``truth`` and ``start`` serial -> (4, 4) T_world_camera; so
    ``cameras, truth, start = rigfit.simulate(); rigfit.refine(cameras, start)``.

    Raises:
        ValueError: an option out of range, with the CLI's message (keywords for flags).
    """
    seed = operator.index(seed)
    if not 0 <= seed < 2**64:
        raise ValueError(f"simulate: seed must be in [0, 2^64 - 1], got {seed}")
    cameras_out, truth, start = _rigfit.simulate(
        operator.index(cameras), seed, operator.index(width), operator.index(height), float(noise),
        float(noise_corr_px), float(noise_corr_share), float(disparity_quant_px), float(dropout),
        float(perturb_yaw_deg), float(perturb_xz_m), float(perturb_tilt_deg), bool(bare))
    return dict(cameras_out), dict(truth), dict(start)
