"""rigfit from Python: refine the extrinsics of a depth-camera rig, simulate one, and read,
track, map (SLAM) and evaluate RGB-D sequences (docs/python.md).

The same library calls as the CLI, in one style: data (arrays, dicts of arrays, paths) are
positional; options are keyword-only and named as the CLI's long flags (``--max-frames`` is
``max_frames``, ``--no-ground`` is ``no_ground=True``); None, or leaving a keyword out, means
the library's default (``rigfit.defaults(command)`` lists them); every function returns a
dataclass (or None). ``refine`` on the same capture, initial extrinsics and options gives
``rigfit refine``'s poses bit for bit and exactly the ``_meta`` report the CLI writes (without
``timings_s``); ``compare``, ``simulate``, ``track``, ``slam``, ``evaluate`` and
``evaluate_trajectory`` are the CLI commands of those names. Files are read and written by
``read_*`` and ``write_*`` (C++'s ReadCapture, WriteExtrinsics, ...); nothing else touches the
disk. Bad input, an unknown keyword or a keyword of the wrong type raise ``ValueError`` with the
library's message. Progress and warnings go to the logger ``"rigfit"``.
"""

from __future__ import annotations

import inspect
import json
import logging
import operator
import os
import textwrap
from dataclasses import dataclass
from typing import (TYPE_CHECKING, Any, Callable, Dict, Iterator, List, Mapping, Optional, Tuple,
                    TypeVar, Union, overload)
from typing import Sequence as _Seq

from . import _rigfit

if TYPE_CHECKING:  # numpy is needed by the arrays, not by the import
    import numpy as np

__all__ = ["defaults", "refine", "RefineResult", "CameraReport", "PoseSigma", "SigmaInflation",
           "WeakDirection", "DepthModel", "PairReport", "compare", "CompareResult", "CompareRun", "evaluate", "RigErrors",
           "PairError", "CameraTilt", "ErrorSummary", "RmsMax", "read_capture", "write_capture",
           "read_extrinsics", "write_extrinsics", "simulate", "SimulatedRig", "open_sequence",
           "Sequence", "Frame", "track", "TrackResult", "TrackedFrame", "TrackTimings", "slam",
           "SlamResult", "SlamFrame", "SlamTimings", "SurfelMap", "Trajectory",
           "evaluate_trajectory", "TrajectoryErrors", "read_trajectory", "write_trajectory"]

logger = logging.getLogger("rigfit")

#: serial -> {"depth": (H, W) metres, "K": (3, 3)} or {"points": (N, 3), "normals": (N, 3)}
Cameras = Mapping[str, Mapping[str, Any]]
#: serial -> (4, 4) T_world_camera
Extrinsics = Mapping[str, "np.ndarray"]
#: a config: a dict with the YAML's sections and keys, the path of a YAML file, or None
Config = Union[None, Mapping[str, Any], str, os.PathLike]

_F = TypeVar("_F", bound=Callable[..., Any])


def defaults(command: str) -> Dict[str, Any]:
    """The keywords of ``command`` (``"refine"``, ``"track"``, ...) with the library's defaults,
    which a keyword left out or given as None takes. Read from the binding's keyword table, the
    one place a keyword is written, so that they cannot drift from the library's."""
    if command not in _rigfit.keyword_defaults:
        raise ValueError(f"defaults: no command {command!r} (commands: "
                         f"{', '.join(_rigfit.keyword_defaults)})")
    return dict(_rigfit.keyword_defaults[command])


def _keywords(command: str) -> Callable[[_F], _F]:
    """Gives a function that takes ``**options`` the keyword-only parameters of ``command``'s
    table (each defaulting to None: the library's default), so that ``help()`` and
    ``inspect.signature`` show them, and lists them with their defaults in its docstring."""

    def wrap(function: _F) -> _F:
        signature = inspect.signature(function)
        kept = [p for p in signature.parameters.values() if p.kind is not p.VAR_KEYWORD]
        table = [inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=None)
                 for name in _rigfit.keyword_defaults[command]]
        function.__signature__ = signature.replace(parameters=kept + table)
        listed = ", ".join(f"{name}={value!r}"
                           for name, value in _rigfit.keyword_defaults[command].items())
        function.__doc__ = (inspect.cleandoc(function.__doc__ or "") +
                            "\n\nKeywords and their defaults (None or left out: the default):\n" +
                            textwrap.fill(listed, 92, initial_indent="    ", subsequent_indent="    ",
                                          break_on_hyphens=False, break_long_words=False))
        return function

    return wrap


def _config_text(config: Config) -> Tuple[str, str]:
    """(yaml_text, path) of a config: a dict is written as JSON, which is YAML, and read by the
    YAML loader, so that a dict is checked exactly as a file (unknown keys, types, ranges)."""
    if config is None:
        return "", ""
    if isinstance(config, Mapping):
        return json.dumps(config, indent=2, allow_nan=False), ""
    if isinstance(config, (str, os.PathLike)):
        return "", os.fspath(config)
    raise ValueError(f"config must be a dict, a path or None, got {type(config).__name__}")


# --- refine -----------------------------------------------------------------------------------


@dataclass
class PoseSigma:
    """The 1-sigma read-off of a pose covariance: yaw and tilt (degrees), x, y, z (mm)."""

    yaw_deg: float
    tilt_deg: float
    x_mm: float
    y_mm: float
    z_mm: float


@dataclass
class SigmaInflation:
    """How much what the residuals show (correlated noise, surfaces' bias) raised the noise
    model's 1-sigma of a pose (``_meta``'s ``sigma_inflation``): factors, at least 1."""

    rotation: float
    translation: float


@dataclass
class DepthModel:
    """A camera's depth model in the surface bundle (``icp.depth_model``; ``_meta``'s
    ``surface_bundle.thickness.<serial>.depth_model``): its inverse depth w read as
    ``scale * w + offset`` (offset in 1/m; ``offset_px`` in pixels of disparity with a baseline),
    whether it was solved and observable (not observable: held at 1 and 0), the 1-sigma of
    each and of its prior, and its largest correlation with the camera's pose."""

    solved: bool
    observable: bool
    scale: float
    offset: float
    offset_px: float
    scale_sigma: float
    offset_sigma: float
    scale_prior_sigma: float
    offset_prior_sigma: float
    pose_correlation: float


@dataclass
class WeakDirection:
    """A direction of a camera's pose that the data fixes poorly (``_meta``'s
    ``weak_directions``): which, its information against the best-constrained direction's, and
    why."""

    direction: str
    information_fraction: float
    reason: str


@dataclass
class CameraReport:
    """One camera of a refine run (``_meta.icp_refined.cameras.<serial>`` as objects).

    ``covariance`` is the 6x6 covariance of the refined pose in the PoseManifold tangent (world
    rotation vector, world translation; gauge fixed by the reference), joint mode only, else
    None; ``sigma`` its 1-sigma read-off and ``sigma_inflation`` how much the residuals raised
    it above the noise model's. ``surfaces`` is the number of distinct surface orientations the
    joint pose rests on, ``few_surfaces`` whether they are too few for the 1-sigma to show one
    surface's bias (0 and False outside joint mode). ``surface_leveled``: the reference, its tilt
    leveled again on the surface bundle's floor (yaw and centre held; False: held whole).
    ``depth_model``: its surface bundle depth model with ``icp.depth_model`` on (None for the
    reference, points cameras, or off). ``delta_*`` is the registration change (refined against
    leveled), ``own_*`` the change against the rig that the safety bounds apply to.
    """

    serial: str
    reference: bool
    surface_leveled: bool
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
    sigma: Optional[PoseSigma]
    sigma_inflation: Optional[SigmaInflation]
    surfaces: int
    few_surfaces: bool
    weak_directions: List[WeakDirection]
    depth_model: Optional[DepthModel]


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
        meta: the ``_meta`` document ``rigfit refine --no-timings`` writes, parsed:
            ``{"ground_refined": ..., "icp_refined": ...}`` (``write_extrinsics``' ``meta``).
    """

    extrinsics: Dict[str, "np.ndarray"]
    success: bool
    message: str
    warnings: List[str]
    cameras: List[CameraReport]
    pairs: List[PairReport]
    meta: Dict[str, Any]


def _camera_report(raw: Dict[str, Any]) -> CameraReport:
    raw = dict(raw)
    raw["sigma"] = None if raw["sigma"] is None else PoseSigma(**raw["sigma"])
    raw["sigma_inflation"] = (None if raw["sigma_inflation"] is None
                              else SigmaInflation(**raw["sigma_inflation"]))
    raw["weak_directions"] = [WeakDirection(**w) for w in raw["weak_directions"]]
    raw["depth_model"] = None if raw["depth_model"] is None else DepthModel(**raw["depth_model"])
    return CameraReport(**raw)


@_keywords("refine")
def refine(cameras: Cameras, extrinsics: Extrinsics, *, config: Config = None,
           **options: Any) -> RefineResult:
    """Refines the extrinsics of a rig from one capture, as ``rigfit refine``.

    ``cameras``: serial -> ``{"depth": (H, W) float32/float64 metres (NaN, <= 0 invalid), "K":
    (3, 3) intrinsics}``, or uint16 depth with ``"depth_scale"`` (metres per unit), or
    ``{"points": (N, 3) camera-frame metres, "normals": (N, 3) optional}`` (``read_capture``
    returns this layout). ``extrinsics``: serial -> (4, 4) T_world_camera, one per camera.
    ``config`` (``--config``): a dict with the YAML's sections and keys (``{"icp":
    {"voxel_size": 0.03}}``), the path of a YAML file, or None for the defaults. The other
    keywords are ``rigfit refine``'s flags: ``mode``, ``method``, ``surface_bundle`` (True for
    ``--surface-bundle``, False for ``--no-surface-bundle``), ``voxel_size`` and ``reference``
    override the config (None: the config's); ``no_ground=True`` skips ground
    leveling, ``no_icp=True`` stops after it; ``threads`` (1 to 256).

    Raises ValueError on bad input (config, arrays, serials that do not match, keywords).
    """
    raw = _rigfit.refine(dict(cameras), dict(extrinsics), _config_text(config), options, logger)
    return RefineResult(
        extrinsics=dict(raw["extrinsics"]), success=bool(raw["success"]),
        message=raw["message"], warnings=list(raw["warnings"]),
        cameras=[_camera_report(c) for c in raw["cameras"]],
        pairs=[PairReport(**p) for p in raw["pairs"]], meta=json.loads(raw["meta_json"]))


# --- evaluate and compare ---------------------------------------------------------------------


@dataclass
class RmsMax:
    """RMS and largest value of an error over cameras or pairs (None: nothing to summarise)."""

    rms: Optional[float]
    max: Optional[float]


@dataclass
class ErrorSummary:
    """Gauge-free errors of a rig: relative rotation (deg) and translation (mm) over the pairs
    of cameras, tilt of each camera against the truth's floor (deg)."""

    rotation_deg: RmsMax
    translation_mm: RmsMax
    tilt_deg: RmsMax


@dataclass
class PairError:
    """Error of the relative pose of two cameras against the truth's."""

    serial_i: str
    serial_j: str
    rotation_deg: float
    translation_mm: float


@dataclass
class CameraTilt:
    """Tilt of one camera against the truth (deg)."""

    serial: str
    tilt_deg: float


@dataclass
class RigErrors:
    """What ``evaluate`` returns (``rigfit evaluate --json``'s document as objects)."""

    pairs: List[PairError]
    cameras: List[CameraTilt]
    summary: ErrorSummary
    ignored_cameras: List[str]


def _summary(raw: Optional[Mapping[str, Any]]) -> Optional[ErrorSummary]:
    if raw is None:
        return None
    return ErrorSummary(**{key: RmsMax(**value) for key, value in raw.items()})


def evaluate(estimated: Extrinsics, ground_truth: Extrinsics) -> RigErrors:
    """Gauge-free errors of estimated extrinsics against the truth, as ``rigfit evaluate EST
    GT``, over the cameras of ``ground_truth`` (every one must be in ``estimated``; the others
    of ``estimated`` are listed in ``ignored_cameras``). Raises ValueError on bad poses."""
    raw = json.loads(_rigfit.evaluate(dict(estimated), dict(ground_truth)))
    return RigErrors(pairs=[PairError(**p) for p in raw["pairs"]],
                     cameras=[CameraTilt(**c) for c in raw["cameras"]],
                     summary=_summary(raw["summary"]), ignored_cameras=raw["ignored_cameras"])


@dataclass
class CompareRun:
    """One of the three runs of ``compare``: how it was set, whether it was applied, its poses,
    its errors against ``gt`` (None without), its wall time and peak memory."""

    name: str
    mode: str
    method: str
    surface_bundle: bool
    success: bool
    message: str
    warnings: List[str]
    extrinsics: Dict[str, "np.ndarray"]
    errors: Optional[ErrorSummary]
    wall_s: float
    peak_rss_mb: float


@dataclass
class CompareResult:
    """What ``compare`` returns.

    Attributes:
        runs: ``pairwise``, ``joint``, ``surface_bundle``, in that order.
        method: the residual of the pairwise and joint runs.
        reference: the camera held fixed.
        errors_input, errors_leveled: the errors of the input and of the leveled poses (the
            runs' shared start) against ``gt``; None without ``gt``.
        verdict: the best run and the numbers behind it.
        text: the tables ``rigfit compare`` prints.
        document: the JSON document ``rigfit compare --json`` writes, parsed (also each
            camera's change, error, 1-sigma and plane thickness, and each pair's fit);
            ``capture``, ``extrinsics`` and ``ground_truth`` are None (no files), ``config`` the
            path when one was given.
    """

    runs: List[CompareRun]
    method: str
    reference: str
    errors_input: Optional[ErrorSummary]
    errors_leveled: Optional[ErrorSummary]
    verdict: str
    text: str
    document: Dict[str, Any]


def _compare_run(name: str, raw: Mapping[str, Any]) -> CompareRun:
    import numpy as np
    poses = {serial: np.array(c["T_world_camera"], dtype=np.float64)
             for serial, c in raw["cameras"].items()}
    return CompareRun(name=name, mode=raw["mode"], method=raw["method"],
                      surface_bundle=raw["surface_bundle"], success=raw["success"],
                      message=raw["message"], warnings=list(raw["warnings"]), extrinsics=poses,
                      errors=_summary(raw["errors"]), wall_s=raw["wall_s"],
                      peak_rss_mb=raw["peak_rss_mb"])


@_keywords("compare")
def compare(cameras: Cameras, extrinsics: Extrinsics, *, config: Config = None,
            gt: Optional[Extrinsics] = None, **options: Any) -> CompareResult:
    """Runs the three ways to refine a rig on the same input, as ``rigfit compare``.

    pairwise (pairwise ICP + pose graph) and joint (joint registration), both without the
    surface bundle, and surface_bundle (joint registration, then the surface bundle); all with
    the config's ``icp.method`` (point_to_plane or gicp). ``cameras``, ``extrinsics`` and
    ``config`` as ``refine`` takes them (``icp.mode`` and ``icp.surface_bundle`` ignored; the
    reference and ground leveling come from the config, as for the CLI); ``gt`` (``--gt``): serial -> (4, 4) true T_world_camera, one per
    camera, or None; adds each run's gauge-free errors and judges the runs by them.
    ``threads``: worker threads (1 to 256).

    Raises ValueError on bad input (as ``refine``; a single camera; a camera missing from
    ``gt``).
    """
    raw = _rigfit.compare(dict(cameras), dict(extrinsics), _config_text(config),
                          None if gt is None else dict(gt), options, logger)
    doc = json.loads(raw["json"])
    return CompareResult(
        runs=[_compare_run(name, doc["modes"][name]) for name in doc["runs"]],
        method=doc["method"], reference=doc["reference"],
        errors_input=_summary(doc["before"]["errors_input"]),
        errors_leveled=_summary(doc["before"]["errors_leveled"]), verdict=doc["verdict"],
        text=raw["text"], document=doc)


# --- files ------------------------------------------------------------------------------------


def read_capture(path: Union[str, os.PathLike]) -> Dict[str, Dict[str, "np.ndarray"]]:
    """Reads a rig capture (HDF5, docs/formats.md) in this process, as C++'s ReadCapture.

    Returns serial -> ``{"depth": (H, W) float32 metres with NaN where invalid, "K": (3, 3),
    ["confidence", "color"]}`` or ``{"points": (N, 3), ["normals": (N, 3)]}``, the layout
    ``refine`` takes. Raises ValueError naming the file and dataset on a bad file.
    """
    return dict(_rigfit.read_capture(os.fspath(path), logger))


@_keywords("write_capture")
def write_capture(path: Union[str, os.PathLike], cameras: Cameras, **options: Any) -> None:
    """Writes a rig capture (HDF5, docs/formats.md) atomically, as C++'s WriteCapture.

    ``cameras`` as ``refine`` takes them (``read_capture``'s layout), checked the same way.
    ``depth_as_uint16=True`` stores depth as uint16 with ``depth_scale`` metres per unit instead
    of float32 metres. Raises ValueError naming the file and camera on what cannot be written.
    """
    _rigfit.write_capture(os.fspath(path), dict(cameras), options)


def read_extrinsics(path: Union[str, os.PathLike]) -> Dict[str, "np.ndarray"]:
    """Reads an extrinsics file (JSON): serial -> (4, 4) T_world_camera (``_meta`` left out)."""
    return dict(_rigfit.read_extrinsics(os.fspath(path), logger))


def write_extrinsics(path: Union[str, os.PathLike], extrinsics: Extrinsics, *,
                     meta: Optional[Mapping[str, Any]] = None) -> None:
    """Writes an extrinsics file (JSON) atomically, as the CLI writes it, with ``meta`` (e.g.
    ``RefineResult.meta``) as its ``_meta``."""
    meta_json = "" if meta is None else json.dumps(meta, allow_nan=False)
    _rigfit.write_extrinsics(os.fspath(path), dict(extrinsics), meta_json)


# --- simulate ---------------------------------------------------------------------------------


@dataclass
class SimulatedRig:
    """What ``simulate`` returns: ``cameras`` in ``refine``'s layout (``{"depth", "K",
    "color"}`` per serial, and ``"baseline_m"`` with stereo depth), ``truth`` and ``start``
    serial -> (4, 4) T_world_camera (the CLI's gt.json and init.json)."""

    cameras: Dict[str, Dict[str, "np.ndarray"]]
    truth: Dict[str, "np.ndarray"]
    start: Dict[str, "np.ndarray"]


@_keywords("simulate")
def simulate(**options: Any) -> SimulatedRig:
    """Simulates a rig in memory, as ``rigfit simulate`` writes it (same defaults, same checks).

    A furnished room seen by ``cameras`` ZED-like depth cameras; deterministic for a seed (the
    CLI's files for the same options hold the same numbers). The keywords are the CLI's flags:
    ``noise`` is sigma = noise * z^2 (1/m); ``noise_corr_px`` and ``noise_corr_share`` make a
    share of its variance correlated over that many pixels; ``disparity_quant_px`` rounds the
    disparity to multiples of it; ``dropout`` drops that fraction of pixels; ``perturb_*`` set
    how far ``start`` is from ``truth``; ``bare=True`` leaves the room empty (floor and walls).
    ``rig = rigfit.simulate(); rigfit.refine(rig.cameras, rig.start)``.

    Raises ValueError: an option out of range, with the CLI's message (keywords for flags).
    """
    raw = _rigfit.simulate(options)
    return SimulatedRig(cameras=dict(raw["cameras"]), truth=dict(raw["truth"]),
                        start=dict(raw["start"]))


# --- RGB-D sequences, tracking, SLAM, trajectories --------------------------------------------


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
    """A camera trajectory: (N,) timestamps in seconds and (N, 4, 4) T_world_camera."""

    timestamps: "np.ndarray"
    poses: "np.ndarray"

    def __len__(self) -> int:
        return len(self.timestamps)


@dataclass
class TrackTimings:
    """Seconds spent by ``track``: the loop over the frames (``loop_s``, wall time), in it
    waiting for frames (``load_s``) and tracking (``track_s``); building each frame's pyramid
    (``preprocess_s``) on the loader's thread while the frame before is tracked."""

    loop_s: float
    load_s: float
    preprocess_s: float
    track_s: float


@dataclass
class TrackResult(Trajectory):
    """What ``track`` returns: the trajectory (``write_trajectory`` and ``evaluate_trajectory``
    take it) with a ``TrackedFrame`` per pose, the failed frames, the restarts and the
    timings."""

    frames: List[TrackedFrame]
    failures: int
    restarts: int
    timings: TrackTimings
    recovered: int = 0  #: frames the motion guard re-tracked successfully
    diverged: int = 0  #: frames whose re-track failed too (counted in ``failures``)
    weak_frames: int = 0  #: frames with a weakly constrained direction held
    relocalised: int = 0  #: frames relocalised after a lone-plane stretch
    color_aligned: int = 0  #: weak-direction frames whose weak directions colour measured
    color_tracked: int = 0  #: frames refined by colour tracking (``color_tracking``)
    color_rescued: int = 0  #: of them, frames whose depth track failed: tracked by colour alone
    #: of them, frames whose depth track was unverified (not converged, or re-tracked by the
    #: guard) and colour alone from the prediction aligned better (a lower grey residual)
    color_alone: int = 0
    #: with ``loop_closure``: {"keyframes", "candidates", "accepted",
    #: "accepted_across_stretch", "accepted_by_color", "rejected_after_solve", "applied",
    #: "message", "seconds"} (the loops checked, accepted by their check, of those across a
    #: lone-plane stretch and refined by colour, dropped by the check after the solve, whether
    #: the trajectory was corrected)
    loop_closure: Optional[Dict[str, Any]] = None


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
    model_pixels: int
    input_points: int
    merged: int
    added: int
    covered: int
    folded: int
    removed: int
    map_size: int
    recovered: bool
    diverged: bool


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
class SlamTimings:
    """Seconds spent by ``slam``: the loop over the frames (``loop_s``, wall time), in it
    waiting for frames, rendering the model, tracking and fusing; building each frame's
    pyramid (``preprocess_s``) on the loader's thread while the frame before is tracked."""

    loop_s: float
    load_s: float
    preprocess_s: float
    render_s: float
    track_s: float
    fuse_s: float


@dataclass
class SlamResult(Trajectory):
    """What ``slam`` returns: the trajectory (a ``Trajectory``: ``write_trajectory`` and
    ``evaluate_trajectory`` take it) with a ``SlamFrame`` per pose in ``frames``, the failed
    frames, the restarts, the timings, the final ``map`` (since the last restart) and
    ``map_sizes`` ((N,) int32, the map size after each frame)."""

    frames: List[SlamFrame]
    failures: int
    restarts: int
    timings: SlamTimings
    map: SurfelMap
    map_sizes: "np.ndarray"
    recovered: int = 0  #: frames the motion guard re-tracked successfully
    diverged: int = 0  #: frames whose re-track failed too (counted in ``failures``)
    weak_frames: int = 0  #: frames with a weakly constrained direction held
    relocalised: int = 0  #: frames relocalised after a lone-plane stretch
    color_aligned: int = 0  #: weak-direction frames whose weak directions colour measured
    color_tracked: int = 0  #: frames refined by colour tracking (``color_tracking``)
    color_rescued: int = 0  #: of them, frames whose depth track failed: tracked by colour alone
    #: of them, frames whose depth track was unverified (not converged, or re-tracked by the
    #: guard) and colour alone from the prediction aligned better (a lower grey residual)
    color_alone: int = 0
    #: with ``loop_closure``: {"keyframes", "candidates", "accepted",
    #: "accepted_across_stretch", "accepted_by_color", "rejected_after_solve", "applied",
    #: "message", "seconds"} (the loops checked, accepted by their check, of those across a
    #: lone-plane stretch and refined by colour, dropped by the check after the solve, whether
    #: the trajectory was corrected)
    loop_closure: Optional[Dict[str, Any]] = None
    halvings: int = 0  #: times every frame was halved (``halve``, or its default's choice)


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


@_keywords("open_sequence")
def open_sequence(path: Union[str, os.PathLike], **options: Any) -> Sequence:
    """Opens an RGB-D sequence, as ``rigfit track SEQUENCE`` does (docs/sequences.md).

    ``path``: a TUM RGB-D or ICL-NUIM folder, a 7-Scenes folder, or a rig capture (HDF5) whose
    camera ``camera`` (default the first) has a burst of depth frames. Lists and poses are read
    now, images on demand. ``camera``, ``tum_camera`` ("fr1", "fr2", "fr3", "default") and
    ``intrinsics`` ((fx, fy, cx, cy) of the depth image) are the CLI's ``--camera``,
    ``--tum-camera``, ``--intrinsics``; ``depth_scale`` (metres per unit of 16-bit depth; None:
    the format's), ``max_time_difference_s`` (associating colour and ground truth), ``stride``
    and ``max_frames`` (0: all) set the rest of SequenceOptions. The loader's notes go to the
    logger.

    Raises ValueError: a missing or malformed folder or file, options out of range.
    """
    return Sequence(_rigfit.open_sequence(os.fspath(path), options, logger))


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


@_keywords("track")
def track(frames: Union[Sequence, _Seq[FrameLike]], **options: Any) -> TrackResult:
    """Dense RGB-D odometry, as ``rigfit track`` (rgbd/odometry.h).

    Each frame is tracked by projective point-to-plane ICP, coarse to fine, against the last
    keyframe (``keyframes=False``: the previous frame). ``frames``: a ``Sequence`` (read from
    its files as it goes), or a list of ``Frame`` objects or dicts ``{"depth": (H, W)
    float32/float64 metres or uint16 with "depth_scale", "K": (3, 3), "timestamp": seconds
    (every frame or none; default index / 30 Hz), "T_world_camera": (4, 4) optional}`` (each
    depth read once, when its frame is tracked). The first frame's pose is its
    ``T_world_camera`` (ground truth) when it has one, else the identity.

    The keywords are the CLI's flags with its defaults and checks: ``first``, ``max_frames``
    (0: all), ``stride`` pick the frames; ``iterations`` per pyramid level, finest first (their
    count is the number of levels); ``prior`` "constant-velocity" or "identity"; ``min_depth``
    and ``max_depth`` (metres) the depth used; ``bilateral`` the level-0 normals,
    ``bilateral_range_grows`` its range sigma growing as z^2 beyond 1 m (stereo depth);
    ``max_distance`` (m) and ``max_angle`` (deg) the association; ``depth_weights``,
    ``noise_floor_depth`` (m: nearer depths weigh as this one; 0: none) and ``huber`` the
    weighting; ``min_step`` the convergence test; ``guard`` and ``weak_ratio`` the
    motion guard (weak directions held, divergence detected and re-tracked; docs/rgbd.md);
    ``color_align`` (with the guard: a frame's weak directions aligned by colour against the
    previous frame when both have registered colour; frames given as a list carry none);
    ``color_tracking`` "auto" (the default: frames that matched under 0.6 of their pixels,
    noisy depth such as stereo matching's), "on" or "off": a track refined by colour against
    the keyframe's, the depth's information as a prior (counted in ``color_tracked``; a
    ``Sequence``'s registered colour only);
    ``loop_closure`` (revisited keyframes verified by ICP, a keyframe pose graph solved, the
    trajectory corrected; counts in the result's ``loop_closure``); ``threads``. Runs without the
    GIL; progress (every tenth) and warnings (failed frames) go to the logger ``"rigfit"``. A
    failed frame keeps its prediction and is counted, as in the CLI.

    Raises ValueError: options out of range, a bad frame, an unreadable image.
    """
    raw = _rigfit.track(_frames_source(frames, "track"), options, logger)
    return TrackResult(
        timestamps=raw["timestamps"], poses=raw["poses"],
        frames=[TrackedFrame(**f) for f in raw["frames"]], failures=raw["failures"],
        restarts=raw["restarts"], timings=TrackTimings(**raw["timings"]),
        recovered=raw["recovered"], diverged=raw["diverged"], weak_frames=raw["weak_frames"],
        relocalised=raw["relocalised"], color_aligned=raw["color_aligned"],
        color_tracked=raw["color_tracked"], color_rescued=raw["color_rescued"],
        color_alone=raw["color_alone"], loop_closure=raw["loop_closure"])


@_keywords("slam")
def slam(frames: Union[Sequence, _Seq[FrameLike]], **options: Any) -> SlamResult:
    """Frame-to-model dense RGB-D SLAM, as ``rigfit slam`` (rgbd/slam.h, docs/rgbd.md section 6).

    Each frame is tracked by projective point-to-plane ICP against the surfel map rendered at its
    predicted pose, then fused into the map. ``frames`` as for ``track``: a ``Sequence`` (its
    registered colour is fused when ``color``), or a list of ``Frame`` objects or dicts (depth
    only: their colour is not read). The first frame's pose is its ``T_world_camera`` when it
    has one, else the identity.

    The keywords are the CLI's flags with its defaults and checks: ``first``, ``max_frames``
    (0: all), ``stride`` pick the frames, ``halve`` halves their resolution that many times
    first (None, the default: until they are at most 480 pixels wide); tracking as ``track``
    (``iterations``, ``prior``, ``min_depth``, ``max_depth``, ``max_distance``, ``max_angle``,
    ``bilateral``, ``bilateral_range_grows``, ``depth_weights``, ``noise_floor_depth``,
    ``huber``);
    fusion: ``fuse_distance`` (m) and ``fuse_angle`` (deg) gates, ``dormant_frames`` and ``min_stable_weight`` (dormant removal; 0 frames: off),
    ``cover_radius`` (the coverage rule; 0: off), ``fold``; the model: ``model_weight``,
    ``model_recent``, ``splat``; ``color``; ``guard``, ``weak_ratio``, ``color_align``,
    ``color_tracking`` (against the last fused frame with colour 10 cm or 5 deg from the one
    before: the map renders no colour) and ``loop_closure`` as for ``track`` (the map's points moved with the frame that last saw
    them); ``threads``. Runs without the GIL; progress (every tenth, with the map size) and warnings go to the logger ``"rigfit"``. A failed frame keeps
    its prediction and is not fused; a frame without colour while the map is coloured is
    tracked but not fused, with a warning (``color=False`` fuses depth only).

    Raises ValueError: options out of range, a bad frame, an unreadable image.
    """
    raw = _rigfit.slam(_frames_source(frames, "slam"), options, logger)
    return SlamResult(
        timestamps=raw["timestamps"], poses=raw["poses"],
        frames=[SlamFrame(**f) for f in raw["frames"]], failures=raw["failures"],
        restarts=raw["restarts"], timings=SlamTimings(**raw["timings"]),
        map=SurfelMap(**raw["map"]), map_sizes=raw["map_sizes"], recovered=raw["recovered"],
        diverged=raw["diverged"], weak_frames=raw["weak_frames"], relocalised=raw["relocalised"],
        color_aligned=raw["color_aligned"], color_tracked=raw["color_tracked"],
        color_rescued=raw["color_rescued"], color_alone=raw["color_alone"],
        loop_closure=raw["loop_closure"], halvings=raw["halvings"])


@dataclass
class TrajectoryErrors:
    """What ``evaluate_trajectory`` returns (core/trajectory.h TrajectoryErrors, SI units).

    ``pairs``: poses matched in time; ``T_gt_est`` (4, 4): the rigid alignment of the estimate
    onto the truth; ATE over the matched poses: ``ate_rmse_m``, ``ate_mean_m``,
    ``ate_median_m``, ``ate_max_m``, ``ate_m`` ((pairs,) per pose); RPE over pose pairs
    ``delta`` matched poses apart: ``rpe_pairs``, ``rpe_translation_rmse_m``,
    ``rpe_rotation_rmse_rad``.
    """

    pairs: int
    T_gt_est: "np.ndarray"
    ate_rmse_m: float
    ate_mean_m: float
    ate_median_m: float
    ate_max_m: float
    ate_m: "np.ndarray"
    rpe_pairs: int
    rpe_translation_rmse_m: float
    rpe_rotation_rmse_rad: float


TrajectoryLike = Union[Trajectory, Tuple["np.ndarray", "np.ndarray"]]


def _trajectory_arrays(trajectory: TrajectoryLike, name: str) -> tuple:
    if isinstance(trajectory, Trajectory):
        return trajectory.timestamps, trajectory.poses
    if isinstance(trajectory, (tuple, list)) and len(trajectory) == 2:
        return trajectory[0], trajectory[1]
    raise TypeError(f"{name} must be a rigfit.Trajectory or (timestamps, poses), got "
                    f"{type(trajectory).__name__}")


@_keywords("evaluate_trajectory")
def evaluate_trajectory(estimated: TrajectoryLike, ground_truth: TrajectoryLike,
                        **options: Any) -> TrajectoryErrors:
    """Errors of a trajectory against ground truth, as ``rigfit evaluate-trajectory EST GT``.

    Poses are matched by nearest timestamp (within ``max_dt`` seconds, the TUM tools' greedy
    association), the estimate aligned rigidly to the truth (no scale); RPE over pose pairs
    ``delta`` matched poses apart. Each trajectory is a ``Trajectory`` (or a result of
    ``track`` or ``slam``) or ``(timestamps (N,), poses (N, 4, 4))``, timestamps increasing.

    Raises ValueError: malformed arrays, fewer than 3 poses matched in time, max_dt <= 0,
    delta < 1.
    """
    est = _trajectory_arrays(estimated, "estimated")
    gt = _trajectory_arrays(ground_truth, "ground_truth")
    return TrajectoryErrors(**_rigfit.evaluate_trajectory(est[0], est[1], gt[0], gt[1], options))


def read_trajectory(path: Union[str, os.PathLike]) -> Trajectory:
    """Reads a trajectory in the TUM format (``timestamp tx ty tz qx qy qz qw`` per line), as
    C++'s ReadTumTrajectory (``rigfit evaluate-trajectory`` reads it so)."""
    timestamps, poses = _rigfit.read_trajectory(os.fspath(path))
    return Trajectory(timestamps=timestamps, poses=poses)


def write_trajectory(path: Union[str, os.PathLike], trajectory: TrajectoryLike) -> None:
    """Writes a trajectory in the TUM format atomically, as C++'s WriteTumTrajectory (``rigfit
    track --out`` writes it so: the same bytes for the same poses)."""
    timestamps, poses = _trajectory_arrays(trajectory, "trajectory")
    _rigfit.write_trajectory(os.fspath(path), timestamps, poses)
