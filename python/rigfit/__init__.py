"""rigfit from Python: refine the extrinsics of a depth-camera rig, simulate one, and read,
track, map (SLAM) and evaluate RGB-D sequences (docs/python.md).

The same library calls as the CLI: ``refine`` on the same capture, initial extrinsics and
options gives ``rigfit refine``'s poses bit for bit and exactly the ``_meta`` report the CLI
writes (without ``timings_s``); ``compare`` is ``rigfit compare``; ``simulate`` is ``rigfit simulate``, ``track`` is ``rigfit
track``, ``slam`` is ``rigfit slam``. Nothing is written to disk unless asked. Bad input raises ``ValueError`` with the
library's message. Progress and warnings go to the logger ``"rigfit"``.
"""

from __future__ import annotations

import json
import logging
import operator
import os
from dataclasses import dataclass, field
from typing import (TYPE_CHECKING, Any, Dict, Iterator, List, Mapping, Optional, Tuple, Union,
                    overload)
from typing import Sequence as _Seq

from . import _rigfit

if TYPE_CHECKING:  # numpy is needed by the arrays, not by the import
    import numpy as np

__all__ = ["RefineResult", "CameraReport", "PairReport", "refine", "CompareResult", "compare", "load_capture", "save_capture", "load_extrinsics",
           "save_extrinsics", "evaluate", "simulate", "Frame", "Sequence", "open_sequence", "TrackedFrame",
           "Trajectory", "track", "SlamFrame", "SurfelMap", "SlamResult", "slam", "evaluate_trajectory",
           "load_trajectory", "save_trajectory"]

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


@dataclass
class CompareResult:
    """What ``compare`` returns.

    Attributes:
        document: the JSON document ``rigfit compare --json`` writes, as a dict: ``runs``
            (``["pairwise", "joint", "surface_bundle"]``), ``modes`` (per run: ``mode``,
            ``method``, ``success``, ``cameras`` with change, error, ``sigma`` and
            ``surface`` thickness, ``fit``, ``errors``, ``wall_s``, ``peak_rss_mb``),
            ``before``, ``verdict``; ``capture``, ``extrinsics`` and ``ground_truth`` are
            None (no files), ``config`` the path when one was given.
        text: the tables ``rigfit compare`` prints.
        verdict: ``document["verdict"]``: the best run and the numbers behind it.
    """

    document: Dict[str, Any]
    text: str
    verdict: str


def compare(
    cameras: Cameras,
    extrinsics: Extrinsics,
    config: Union[None, Mapping[str, Any], str, os.PathLike] = None,
    *,
    ground_truth: Optional[Extrinsics] = None,
    reference: Optional[str] = None,
    level_ground: bool = True,
    threads: int = 2,
) -> CompareResult:
    """Runs the three ways to refine a rig on the same input, as ``rigfit compare``.

    pairwise (pairwise ICP + pose graph) and joint (joint registration), both with
    point_to_plane or, when the config sets it, gicp; and surface_bundle (joint
    point_to_plane, then the surface bundle). ``icp.mode`` of the config is ignored.

    Args:
        cameras, extrinsics, config, reference, level_ground, threads: as ``refine`` takes
            them (checked the same way).
        ground_truth: serial -> (4, 4) true T_world_camera, one per camera, or None; adds
            each run's gauge-free errors and judges the runs by them.

    Raises:
        ValueError: bad input (as ``refine``; a single camera; a camera missing from
            ``ground_truth``), with the message.
    """
    yaml_text, path = _config_text(config)
    raw = _rigfit.compare(
        dict(cameras), dict(extrinsics), yaml_text, path,
        None if ground_truth is None else dict(ground_truth), reference or "",
        bool(level_ground), int(threads), logger)
    document = json.loads(raw["json"])
    return CompareResult(document=document, text=raw["text"], verdict=document["verdict"])


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
    return json.loads(_rigfit.evaluate(dict(estimated), dict(ground_truth)))


def load_extrinsics(path: Union[str, os.PathLike]) -> Dict[str, "np.ndarray"]:
    """Reads an extrinsics file (JSON): serial -> (4, 4) T_world_camera (``_meta`` left out)."""
    return dict(_rigfit.load_extrinsics(os.fspath(path), logger))


def save_extrinsics(path: Union[str, os.PathLike], extrinsics: Extrinsics,
                    meta: Optional[Mapping[str, Any]] = None) -> None:
    """Writes an extrinsics file (JSON) atomically, as the CLI writes it, with ``meta`` (e.g.
    ``RefineResult.meta``) as its ``_meta``."""
    meta_json = "" if meta is None else json.dumps(meta, allow_nan=False)
    _rigfit.save_extrinsics(os.fspath(path), dict(extrinsics), meta_json)


# The keyword defaults below are the library's own (SimOptions, SequenceOptions, the tracking
# and SLAM options), read once from the compiled module, so that they cannot drift from the CLI's.
_SIM = _rigfit.simulate_defaults()
_SEQ = _rigfit.sequence_defaults()
_TRACK = _rigfit.track_defaults()
_SLAM = _rigfit.slam_defaults()


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


@dataclass
class Frame:
    """One frame of an RGB-D sequence (core/rgbd.h RgbdFrame).

    Attributes:
        index: position in its sequence, from 0.
        timestamp: seconds (the sequence's clock; index / 30 Hz where it has none).
        depth: (H, W) float32 metres, NaN where invalid (the library's buffer, not a copy).
        K: (3, 3) intrinsics of the depth image (OpenCV axes: x right, y down, z forward).
        color: (H, W, 3) uint8 registered to depth, or None.
        T_world_camera: (4, 4) ground-truth pose of this frame, or None.
        source: the file the depth came from.
    """

    index: int
    timestamp: float
    depth: "np.ndarray"
    K: "np.ndarray"
    color: Optional["np.ndarray"]
    T_world_camera: Optional["np.ndarray"]
    source: str


@dataclass
class TrackedFrame:
    """How one frame of ``track`` went (rgbd/odometry.h OdometryFrame).

    ``success`` False: tracking failed and the frame kept the predicted pose (``message`` says
    why). ``keyframe``: became the reference of the next frames. ``weak_directions``: directions
    of the motion the frame could not fix (a flat wall), held at their prediction, named in
    ``weak_direction_names`` ("translation along camera x", ...). ``recovered``: suspected of
    divergence and re-tracked from the last good pose; ``diverged``: so was the re-track (a
    failure that kept the last good pose; docs/rgbd.md).
    """

    index: int
    timestamp: float
    success: bool
    message: str
    keyframe: bool
    iterations: int
    correspondences: int
    matched_ratio: float
    rmse_m: float
    weak_directions: int
    weak_direction_names: List[str]
    recovered: bool
    diverged: bool


@dataclass
class Trajectory:
    """A camera trajectory: (N,) timestamps in seconds and (N, 4, 4) T_world_camera.

    From ``track`` also ``frames`` (one ``TrackedFrame`` per pose), ``failures``, ``restarts``,
    ``recovered`` and ``diverged`` (frames the divergence guard re-tracked, or declared
    diverged: counted in ``failures`` too), ``weak_frames`` (frames with weak directions held)
    and ``timings`` (seconds: ``load_s``, ``preprocess_s``, ``track_s``); a ground truth or a
    loaded file has none.
    """

    timestamps: "np.ndarray"
    poses: "np.ndarray"
    frames: List[TrackedFrame] = field(default_factory=list)
    failures: int = 0
    restarts: int = 0
    recovered: int = 0
    diverged: int = 0
    weak_frames: int = 0
    timings: Dict[str, float] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.timestamps)


@dataclass
class SlamFrame:
    """How one frame of ``slam`` went (rgbd/slam.h SlamFrame): its tracking against the
    rendered model (as ``TrackedFrame``), the model's valid pixels, what fusion did
    (rgbd/surfel_map.h FusionStats; zeros for a failed frame, which is not fused) and the map
    size after it."""

    index: int
    timestamp: float
    success: bool
    message: str
    iterations: int
    correspondences: int
    matched_ratio: float
    rmse_m: float
    weak_directions: int
    weak_direction_names: List[str]
    recovered: bool
    diverged: bool
    model_pixels: int
    input_points: int
    merged: int
    added: int
    covered: int
    folded: int
    removed: int
    map_size: int


@dataclass
class SurfelMap:
    """The surfel map of ``slam`` (rgbd/surfel_map.h), one row per point.

    The arrays are the library's own buffers (no copy; they share one owner, freed when the
    last of them goes). ``points`` (N, 3) float32 world metres, ``normals`` (N, 3) float32
    unit, ``colors`` (N, 3) float32 RGB averages in [0, 255] or None (no registered colour, or
    ``color=False``), ``confidence`` (N,) float32 (the weight: 1 + the merges), ``radii`` (N,)
    float32 metres; ``input_points``: valid pixels of every frame fused (the concatenated
    input, for the compression ratio).
    """

    points: "np.ndarray"
    normals: "np.ndarray"
    colors: Optional["np.ndarray"]
    confidence: "np.ndarray"
    radii: "np.ndarray"
    input_points: int

    def __len__(self) -> int:
        return len(self.points)

    @property
    def compression(self) -> float:
        """``input_points / len(self)`` (0 for an empty map), as ``rigfit slam`` prints it."""
        return self.input_points / len(self) if len(self) else 0.0


@dataclass
class SlamResult(Trajectory):
    """What ``slam`` returns: the trajectory (a ``Trajectory``: ``save_trajectory`` and
    ``evaluate_trajectory`` take it) with a ``SlamFrame`` per pose in ``frames``, the final
    ``map`` (since the last restart) and ``map_sizes`` ((N,) int32, the map size after each
    frame). ``timings`` (seconds): ``load_s``, ``preprocess_s``, ``render_s``, ``track_s``,
    ``fuse_s``."""

    frames: List[SlamFrame] = field(default_factory=list)
    map: Optional[SurfelMap] = None
    map_sizes: Optional["np.ndarray"] = None


def _frame(raw: Mapping[str, Any]) -> Frame:
    return Frame(index=raw["index"], timestamp=raw["timestamp"], depth=raw["depth"], K=raw["K"],
                 color=raw["color"], T_world_camera=raw["T_world_camera"], source=raw["source"])


class Sequence:
    """An RGB-D sequence opened by ``open_sequence``: frames read from the files on demand.

    ``len(seq)`` frames; ``seq[i]`` reads frame i (negative from the end) as a ``Frame``,
    ``seq[a:b]`` a list of them, iteration all of them in order. ``ground_truth``: the dataset's
    trajectory (for TUM the 100 Hz motion capture, elsewhere one pose per frame) or None.
    """

    def __init__(self, native: Any) -> None:
        self._native = native

    def __len__(self) -> int:
        return len(self._native)

    @overload
    def __getitem__(self, index: int) -> Frame: ...

    @overload
    def __getitem__(self, index: slice) -> List[Frame]: ...

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        return _frame(self._native.frame(operator.index(index)))

    def __iter__(self) -> Iterator[Frame]:
        for i in range(len(self)):
            yield self[i]

    @property
    def ground_truth(self) -> Optional[Trajectory]:
        gt = self._native.ground_truth()
        return None if gt is None else Trajectory(timestamps=gt[0], poses=gt[1])

    def describe(self) -> str:
        """One line: the format, the folder or file, the frame count."""
        return self._native.describe()

    def __repr__(self) -> str:
        return f"<rigfit.Sequence: {self.describe()}>"


def open_sequence(
    path: Union[str, os.PathLike],
    *,
    camera: Optional[str] = None,
    tum_camera: Optional[str] = None,
    intrinsics: Optional[_Seq[float]] = None,
    depth_scale: Optional[float] = None,
    max_time_difference_s: float = _SEQ["max_time_difference_s"],
    stride: int = _SEQ["stride"],
    max_frames: int = _SEQ["max_frames"],
) -> Sequence:
    """Opens an RGB-D sequence, as ``rigfit track SEQUENCE`` does (docs/sequences.md).

    ``path``: a TUM RGB-D or ICL-NUIM folder, a 7-Scenes folder, or a rig capture (HDF5) whose
    camera ``camera`` (default the first) has a burst of depth frames. Lists and poses are read
    now, images on demand. ``camera``, ``tum_camera`` ("fr1", "fr2", "fr3", "default") and
    ``intrinsics`` ((fx, fy, cx, cy) of the depth image) are the CLI's ``--camera``,
    ``--tum-camera``, ``--intrinsics``; ``depth_scale`` (metres per unit of 16-bit depth),
    ``max_time_difference_s`` (associating colour and ground truth), ``stride`` and
    ``max_frames`` (0: all) replace the format's defaults. The loader's notes go to the logger.

    Raises:
        ValueError: a missing or malformed folder or file, options out of range.
    """
    native = _rigfit.open_sequence(
        os.fspath(path), camera or "", tum_camera or "",
        [] if intrinsics is None else [float(v) for v in intrinsics],
        None if depth_scale is None else float(depth_scale), float(max_time_difference_s),
        operator.index(stride), operator.index(max_frames), logger)
    return Sequence(native)


#: A frame for ``track`` and ``slam``: a ``Frame``, or a dict {"depth", "K", ["depth_scale",
#: "timestamp", "T_world_camera"]} as ``refine``'s cameras take depth.
FrameLike = Union[Frame, Mapping[str, Any]]


def _frame_dict(frame: FrameLike, command: str) -> Dict[str, Any]:
    if isinstance(frame, Frame):  # its arrays as they are: nothing copied here
        d = {"depth": frame.depth, "K": frame.K, "timestamp": frame.timestamp}
        if frame.T_world_camera is not None:
            d["T_world_camera"] = frame.T_world_camera
        return d
    if isinstance(frame, Mapping):
        return dict(frame)
    raise TypeError(f"{command}: a frame must be a rigfit.Frame or a dict, got "
                    f"{type(frame).__name__}")


def _frames_source(frames: Union[Sequence, _Seq[FrameLike]], command: str) -> Any:
    """What ``_rigfit.track`` and ``_rigfit.slam`` take: a sequence's native object, or the
    frames as dicts."""
    if isinstance(frames, Sequence):
        return frames._native
    if isinstance(frames, (str, bytes, os.PathLike)):
        raise TypeError(f"{command}: expected a rigfit.Sequence or a list of frames; open a path "
                        "with rigfit.open_sequence(path)")
    return [_frame_dict(f, command) for f in frames]


def track(
    frames: Union[Sequence, _Seq[FrameLike]],
    *,
    first: int = _TRACK["first"],
    max_frames: int = _TRACK["max_frames"],
    stride: int = _TRACK["stride"],
    iterations: _Seq[int] = tuple(_TRACK["iterations"]),
    prior: str = _TRACK["prior"],
    keyframes: bool = _TRACK["keyframes"],
    min_depth: float = _TRACK["min_depth"],
    max_depth: float = _TRACK["max_depth"],
    bilateral: bool = _TRACK["bilateral"],
    max_distance: float = _TRACK["max_distance"],
    max_angle: float = _TRACK["max_angle"],
    depth_weights: bool = _TRACK["depth_weights"],
    huber: float = _TRACK["huber"],
    min_step: float = _TRACK["min_step"],
    guard: bool = _TRACK["guard"],
    weak_ratio: float = _TRACK["weak_ratio"],
    threads: int = _TRACK["threads"],
) -> Trajectory:
    """Frame-to-frame dense RGB-D odometry, as ``rigfit track`` (rgbd/odometry.h).

    Each frame is tracked by projective point-to-plane ICP, coarse to fine, against the previous
    frame or the last keyframe. ``frames``: a ``Sequence`` (read from its files as it goes), or
    a list of ``Frame`` objects or dicts ``{"depth": (H, W) float32/float64 metres or uint16 with
    "depth_scale", "K": (3, 3), "timestamp": seconds (every frame or none; default index /
    30 Hz), "T_world_camera": (4, 4) optional}`` (each depth read once, when its frame is
    tracked). The first frame's pose is its ``T_world_camera`` (ground truth) when it has one,
    else the identity.

    The keywords are the CLI's flags (``--max-frames`` is ``max_frames``, ``--no-keyframes`` is
    ``keyframes=False``, ...), with the same defaults and checks: ``first``, ``max_frames`` (0:
    all), ``stride`` pick the frames; ``iterations`` per pyramid level, finest first (their count
    is the number of levels); ``prior`` "constant-velocity" or "identity"; ``min_depth`` and
    ``max_depth`` (metres) the depth used; ``max_distance`` (m) and ``max_angle`` (deg) the
    association; ``depth_weights`` and ``huber`` the weighting; ``min_step`` the convergence
    test; ``threads``. Runs without the GIL; progress (every tenth) and warnings (failed frames)
    go to the logger ``"rigfit"``. A failed frame keeps its prediction and is counted, as in the
    CLI.

    Raises:
        ValueError: options out of range, a bad frame, an unreadable image.
    """
    raw = _rigfit.track(
        _frames_source(frames, "track"), operator.index(first), operator.index(max_frames), operator.index(stride),
        [operator.index(n) for n in iterations], str(prior), bool(keyframes), float(min_depth),
        float(max_depth), bool(bilateral), float(max_distance), float(max_angle),
        bool(depth_weights), float(huber), float(min_step), bool(guard), float(weak_ratio),
        operator.index(threads), logger)
    return Trajectory(
        timestamps=raw["timestamps"], poses=raw["poses"],
        frames=[TrackedFrame(**f) for f in raw["frames"]], failures=raw["failures"],
        restarts=raw["restarts"], recovered=raw["recovered"], diverged=raw["diverged"],
        weak_frames=raw["weak_frames"], timings=dict(raw["timings"]))


def slam(
    frames: Union[Sequence, _Seq[FrameLike]],
    *,
    first: int = _SLAM["first"],
    max_frames: int = _SLAM["max_frames"],
    stride: int = _SLAM["stride"],
    halve: int = _SLAM["halve"],
    iterations: _Seq[int] = tuple(_SLAM["iterations"]),
    prior: str = _SLAM["prior"],
    min_depth: float = _SLAM["min_depth"],
    max_depth: float = _SLAM["max_depth"],
    max_distance: float = _SLAM["max_distance"],
    max_angle: float = _SLAM["max_angle"],
    fuse_distance: float = _SLAM["fuse_distance"],
    fuse_angle: float = _SLAM["fuse_angle"],
    dormant_frames: int = _SLAM["dormant_frames"],
    cover_radius: float = _SLAM["cover_radius"],
    fold: bool = _SLAM["fold"],
    min_stable_weight: float = _SLAM["min_stable_weight"],
    model_weight: float = _SLAM["model_weight"],
    model_recent: int = _SLAM["model_recent"],
    splat: bool = _SLAM["splat"],
    color: bool = _SLAM["color"],
    guard: bool = _SLAM["guard"],
    weak_ratio: float = _SLAM["weak_ratio"],
    threads: int = _SLAM["threads"],
) -> SlamResult:
    """Frame-to-model dense RGB-D SLAM, as ``rigfit slam`` (rgbd/slam.h, docs/rgbd.md section 6).

    Each frame is tracked by projective point-to-plane ICP against the surfel map rendered at its
    predicted pose, then fused into the map. ``frames`` as for ``track``: a ``Sequence`` (its
    registered colour is fused when ``color``), or a list of ``Frame`` objects or dicts (depth
    only: their colour is not read). The first frame's pose is its ``T_world_camera`` when it has
    one, else the identity.

    The keywords are the CLI's flags (``--fuse-distance`` is ``fuse_distance``, ``--no-color``
    is ``color=False``, ...), with the same defaults and checks (``ApplyTrackingSettings`` and
    ``CheckSlamSettings``, called by both): ``first``, ``max_frames`` (0: all), ``stride`` pick
    the frames, ``halve`` halves their resolution that many times first; tracking as ``track``
    (``iterations``, ``prior``, ``min_depth``, ``max_depth``, ``max_distance``, ``max_angle``);
    fusion: ``fuse_distance`` (m) and ``fuse_angle`` (deg) gates, ``dormant_frames`` and
    ``min_stable_weight`` (dormant removal; 0 frames: off), ``cover_radius`` (the coverage
    rule; 0: off), ``fold``; the model: ``model_weight``, ``model_recent``, ``splat``;
    ``threads``. Runs without the GIL; progress (every tenth, with the map size) and warnings go
    to the logger ``"rigfit"``. A failed frame keeps its prediction and is not fused; a frame
    without colour while the map is coloured is tracked but not fused, with a warning
    (``color=False`` fuses depth only).

    Raises:
        ValueError: options out of range, a bad frame, an unreadable image.
    """
    raw = _rigfit.slam(
        _frames_source(frames, "slam"), operator.index(first), operator.index(max_frames),
        operator.index(stride), operator.index(halve), [operator.index(n) for n in iterations],
        str(prior), float(min_depth), float(max_depth), float(max_distance), float(max_angle),
        float(fuse_distance), float(fuse_angle), operator.index(dormant_frames),
        float(cover_radius), bool(fold), float(min_stable_weight), float(model_weight),
        operator.index(model_recent), bool(splat), bool(color), bool(guard), float(weak_ratio),
        operator.index(threads), logger)
    return SlamResult(
        timestamps=raw["timestamps"], poses=raw["poses"],
        frames=[SlamFrame(**f) for f in raw["frames"]], failures=raw["failures"],
        restarts=raw["restarts"], recovered=raw["recovered"], diverged=raw["diverged"],
        weak_frames=raw["weak_frames"], timings=dict(raw["timings"]), map=SurfelMap(**raw["map"]),
        map_sizes=raw["map_sizes"])


TrajectoryLike = Union[Trajectory, Tuple["np.ndarray", "np.ndarray"]]


def _trajectory_arrays(trajectory: TrajectoryLike, name: str) -> tuple:
    if hasattr(trajectory, "timestamps") and hasattr(trajectory, "poses"):
        return trajectory.timestamps, trajectory.poses
    if isinstance(trajectory, (tuple, list)) and len(trajectory) == 2:
        return trajectory[0], trajectory[1]
    raise TypeError(f"{name} must be a rigfit.Trajectory or (timestamps, poses), got "
                    f"{type(trajectory).__name__}")


def evaluate_trajectory(estimated: TrajectoryLike, ground_truth: TrajectoryLike, *,
                        max_dt: float = 0.02, delta: int = 1) -> Dict[str, Any]:
    """Errors of a trajectory against ground truth, as ``rigfit evaluate-trajectory``.

    Poses are matched by nearest timestamp (within ``max_dt`` seconds, the TUM tools' greedy
    association), the estimate aligned rigidly to the truth (no scale). Each trajectory is a
    ``Trajectory`` or ``(timestamps (N,), poses (N, 4, 4))``, timestamps increasing.

    Returns core/trajectory.h's TrajectoryErrors as a dict, SI units: ``pairs`` (matched
    poses), ``T_gt_est`` (4, 4) (the alignment), ``ate_rmse_m``, ``ate_mean_m``,
    ``ate_median_m``, ``ate_max_m``, ``ate_m`` (per pair), ``rpe_pairs``,
    ``rpe_translation_rmse_m`` and ``rpe_rotation_rmse_rad`` (pose pairs ``delta`` matched poses
    apart).

    Raises:
        ValueError: malformed arrays, fewer than 3 poses matched in time, max_dt <= 0, delta < 1.
    """
    est = _trajectory_arrays(estimated, "estimated")
    gt = _trajectory_arrays(ground_truth, "ground_truth")
    return dict(_rigfit.evaluate_trajectory(est[0], est[1], gt[0], gt[1], float(max_dt),
                                            operator.index(delta)))


def load_trajectory(path: Union[str, os.PathLike]) -> Trajectory:
    """Reads a trajectory in the TUM format (``timestamp tx ty tz qx qy qz qw`` per line), as
    ``rigfit evaluate-trajectory`` reads it."""
    timestamps, poses = _rigfit.load_trajectory(os.fspath(path))
    return Trajectory(timestamps=timestamps, poses=poses)


def save_trajectory(path: Union[str, os.PathLike], trajectory: TrajectoryLike) -> None:
    """Writes a trajectory in the TUM format atomically, as ``rigfit track --out`` writes it
    (the same bytes for the same poses)."""
    timestamps, poses = _trajectory_arrays(trajectory, "trajectory")
    _rigfit.save_trajectory(os.fspath(path), timestamps, poses)
