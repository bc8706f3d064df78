"""Tests of the Python module (docs/python.md), run by ctest (python_tests).

RIGFIT_CLI (set by ctest) is the rigfit executable of the same build; without it the tests that
need it skip in a bare local clone and fail under CI (support.py).
"""

import dataclasses
import inspect
import json
import logging
import re
import subprocess

import numpy as np
import pytest

import rigfit
from support import CLI, require_cli

# A small rig keeps the suite short: 3 cameras of 160x90 (the simulator's room, seed 0).
SIM_ARGS = ["--cameras", "3", "--width", "160", "--height", "90"]


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    """A simulated rig and the CLI's refinement of it: (dir, cli output document)."""
    require_cli()
    d = tmp_path_factory.mktemp("rig")
    subprocess.run([CLI, "simulate", "--out", str(d), *SIM_ARGS], check=True,
                   stdout=subprocess.DEVNULL)
    out = d / "cli.json"
    done = subprocess.run([CLI, "refine", "--capture", str(d / "capture.h5"), "--extrinsics",
                           str(d / "init.json"), "--out", str(out), "--no-timings", "-q"],
                          stdout=subprocess.DEVNULL)
    assert done.returncode == 0  # 3 would be "nothing refined"
    with open(out) as f:
        return d, json.load(f)


def cli_poses(doc):
    return {k: np.array(v["T_world_camera"], dtype=np.float64)
            for k, v in doc.items() if k != "_meta"}


def test_refine_equals_cli(rig):
    d, doc = rig
    cameras = rigfit.read_capture(d / "capture.h5")
    initial = rigfit.read_extrinsics(d / "init.json")
    result = rigfit.refine(cameras, initial)
    expected = cli_poses(doc)
    assert sorted(result.extrinsics) == sorted(expected)
    for serial, T in expected.items():
        got = result.extrinsics[serial]
        assert got.shape == (4, 4) and got.dtype == np.float64
        # The CLI writes doubles that read back bit-exactly: identical to the last bit.
        assert np.array_equal(got, T), serial
    assert result.success == doc["_meta"]["icp_refined"]["success"]
    # Exactly the CLI's _meta (the file's _meta also holds the input's, e.g. _meta.simulated).
    for key, value in result.meta.items():
        assert doc["_meta"][key] == value, key
    assert set(result.meta) == {"ground_refined", "icp_refined"}


def test_refine_from_memory_arrays(rig):
    """Arrays made here, never read from a file: uint16 millimetres with a depth_scale give the
    same poses as the same depths in float64 metres, and the refinement nears the truth."""
    d, doc = rig
    cameras = rigfit.read_capture(d / "capture.h5")
    initial = rigfit.read_extrinsics(d / "init.json")
    truth = rigfit.read_extrinsics(d / "gt.json")
    as_uint16, as_metres = {}, {}
    for serial, cam in cameras.items():
        mm = np.round(np.nan_to_num(cam["depth"], nan=0.0) * 1000.0).astype(np.uint16)
        K = [list(row) for row in cam["K"]]
        as_uint16[serial] = {"depth": mm, "depth_scale": 0.001, "K": K}
        as_metres[serial] = {"depth": mm * 0.001, "K": np.array(K)}
    start = {k: v.copy() for k, v in initial.items()}
    a = rigfit.refine(as_uint16, start, threads=1)
    b = rigfit.refine(as_metres, start)
    assert a.success, a.message
    for serial in truth:
        assert np.array_equal(a.extrinsics[serial], b.extrinsics[serial]), serial

    # Each camera relative to the first: measured worst 0.475 deg and 46.8 mm (from 3.61 deg and
    # 155 mm; 160x90 pixels with the default noise, its planes barely fix the translation along
    # the walls); the bounds leave a factor of 2.
    ref = sorted(truth)[0]
    errors = [relative_pose_error(a.extrinsics, truth, ref, s) for s in truth if s != ref]
    assert max(rotation for rotation, _ in errors) < 0.95
    assert max(translation for _, translation in errors) < 0.094


def test_points_cameras_in_memory():
    """A rig of point clouds made here: a floor and two walls seen by two cameras, with 2 mm of
    noise, the second started 1 deg and 39 mm off its pose; the refinement brings it back."""
    rng = np.random.default_rng(0)
    n = 4000
    floor = np.c_[rng.uniform(-2, 2, n), np.zeros(n), rng.uniform(-2, 2, n)]
    wall = np.c_[rng.uniform(-2, 2, n), rng.uniform(0, 2, n), np.full(n, 2.0)]
    side = np.c_[np.full(n, -2.0), rng.uniform(0, 2, n), rng.uniform(-2, 2, n)]
    world = np.vstack([floor, wall, side])
    poses = {}
    cameras = {}
    for serial, x in (("a", -0.3), ("b", 0.3)):
        T = np.eye(4)
        T[:3, 3] = [x, 1.0, 0.0]
        poses[serial] = T
        cameras[serial] = {"points": world - T[:3, 3] + rng.normal(0.0, 0.002, world.shape)}
    start = {k: v.copy() for k, v in poses.items()}
    yaw = np.radians(1.0)
    start["b"][:3, :3] = np.array([[np.cos(yaw), 0, np.sin(yaw)], [0, 1, 0],
                                   [-np.sin(yaw), 0, np.cos(yaw)]])
    start["b"][:3, 3] += [0.03, 0.0, -0.025]
    result = rigfit.refine(cameras, start, config={"region": {"band_height": 0.0}})
    assert set(result.extrinsics) == {"a", "b"}
    assert result.success, result.message
    assert "icp_refined" in result.meta
    rotation_deg, translation_m = relative_pose_error(result.extrinsics, poses, "a", "b")
    # Measured 0.00144 deg and 0.085 mm; the bounds leave a factor of 2.
    assert rotation_deg < 0.003
    assert translation_m < 0.17e-3


def relative_pose_error(poses, truth, a, b):
    """Rotation (deg) and translation (m) error of b's pose relative to a's (gauge-free)."""
    rel = np.linalg.inv(poses[a]) @ poses[b]
    rel_true = np.linalg.inv(truth[a]) @ truth[b]
    delta = np.linalg.inv(rel_true) @ rel
    # The rotation angle from the skew part (exact to the last digits for small angles, where
    # arccos of the trace is not).
    r = delta[:3, :3]
    sin = 0.5 * np.linalg.norm([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    return np.degrees(np.arcsin(min(sin, 1.0))), np.linalg.norm(delta[:3, 3])


def test_dict_config_checked_as_yaml(rig):
    d, _ = rig
    cameras = rigfit.read_capture(d / "capture.h5")
    initial = rigfit.read_extrinsics(d / "init.json")
    with pytest.raises(ValueError, match=r"icp\.voxel_sizee|voxel_sizee.*unknown key|unknown key"):
        rigfit.refine(cameras, initial, config={"icp": {"voxel_sizee": 0.02}})
    with pytest.raises(ValueError, match="unknown key"):
        rigfit.refine(cameras, initial, config={"gound": {}})
    with pytest.raises(ValueError, match="voxel_size"):
        rigfit.refine(cameras, initial, config={"icp": {"voxel_size": -1.0}})
    # The same config as a file gives the same options and the same result.
    path = d / "config.yaml"
    path.write_text("icp:\n  voxel_size: 0.03\n")
    a = rigfit.refine(cameras, initial, config={"icp": {"voxel_size": 0.03}})
    b = rigfit.refine(cameras, initial, config=path)
    # The CLI's --voxel-size as a keyword: the same options again.
    c = rigfit.refine(cameras, initial, voxel_size=0.03)
    assert c.meta == a.meta
    assert a.meta == b.meta
    assert a.meta["icp_refined"]["config"]["icp"]["voxel_size"] == 0.03


def test_dict_config_message_matches_file(rig, tmp_path):
    """A dict's unknown key gets the message a YAML file gets (with its own source name)."""
    d, _ = rig
    cameras = rigfit.read_capture(d / "capture.h5")
    initial = rigfit.read_extrinsics(d / "init.json")
    with pytest.raises(ValueError) as from_dict:
        rigfit.refine(cameras, initial, config={"icp": {"voxel_sise": 0.02}})
    path = tmp_path / "c.yaml"
    path.write_text("icp:\n  voxel_sise: 0.02\n")
    with pytest.raises(ValueError) as from_file:
        rigfit.refine(cameras, initial, config=path)
    # "<source>:<line>: " differs (the dict's source is "config"); the rest is the same.
    strip = lambda e: re.sub(r"\S+:\d+: ", "", str(e.value))
    assert "config:" in str(from_dict.value)
    assert "did you mean 'voxel_size'?" in str(from_dict.value)
    assert strip(from_dict) == strip(from_file)


def one_camera():
    depth = np.full((20, 30), 2.0, dtype=np.float32)
    K = np.array([[25.0, 0, 15], [0, 25.0, 10], [0, 0, 1]])
    return {"depth": depth, "K": K}


@pytest.mark.parametrize("cameras, extrinsics, message", [
    ({"a": one_camera()}, {"b": np.eye(4)}, "extrinsics has no pose for camera"),
    ({"a": one_camera()}, {"a": np.eye(4), "b": np.eye(4)}, "b"),
    ({}, {}, "cameras: no cameras"),
    ({"a": {"depth": np.zeros(5), "K": np.eye(3)}}, {"a": np.eye(4)}, "expected a 2-D array"),
    ({"a": {"depth": np.ones((4, 4)), "K": np.eye(2)}}, {"a": np.eye(4)}, "K: expected shape"),
    ({"a": {"depth": np.ones((4, 4))}}, {"a": np.eye(4)}, "needs \"K\""),
    ({"a": {"depth": np.ones((4, 4), np.uint16), "K": np.eye(3)}}, {"a": np.eye(4)},
     "depth_scale"),
    ({"a": {"depth": np.ones((4, 4), np.int32), "K": np.eye(3)}}, {"a": np.eye(4)},
     "expected float32 or float64"),
    ({"a": {"depth": np.full((4, 4), 1500.0), "K": np.eye(3)}}, {"a": np.eye(4)},
     "median valid depth"),
    ({"a": {**one_camera(), "K": np.diag([25.0, 25.0, 2.0])}}, {"a": np.eye(4)},
     "last row must be"),
    ({"a": {**one_camera(), "K": np.array([[25.0, 0, 500], [0, 25.0, 10], [0, 0, 1]])}},
     {"a": np.eye(4)}, "principal point"),
    ({"a": {**one_camera(), "K": np.diag([0.5, 0.5, 1.0])}}, {"a": np.eye(4)},
     "must be at least 1 pixel"),
    ({"a": {**one_camera(), "points": np.zeros((3, 3))}}, {"a": np.eye(4)}, "exactly one of"),
    ({"a": {"points": np.full((3, 3), np.nan)}}, {"a": np.eye(4)}, "not finite"),
    ({"a": {"points": np.zeros((3, 3)), "normals": np.zeros((2, 3))}}, {"a": np.eye(4)},
     "normals: expected shape"),
    ({"a": {**one_camera(), "dept": 1}}, {"a": np.eye(4)}, "unknown key \"dept\""),
    ({"a": one_camera()}, {"a": np.eye(3)}, "expected shape \\(4, 4\\)"),
    ({"a": one_camera()}, {"a": np.diag([1.0, 1.0, 2.0, 1.0])}, "not a rotation"),
    ({"a": one_camera()}, {"a": np.full((4, 4), np.nan)}, "finite"),
])
def test_input_checks_raise_value_error(cameras, extrinsics, message):
    with pytest.raises(ValueError, match=message):
        rigfit.refine(cameras, extrinsics)


@pytest.mark.parametrize("kwargs, message", [
    ({"mode": "both"}, "mode must be joint or pairwise"),
    ({"method": "icp"}, "point_to_plane"),
    ({"method": "surface_bundle"}, "set icp.surface_bundle: true"),
    ({"surface_bundle": 1}, "refine: surface_bundle must be True or False"),
    ({"reference": "zz"}, "reference"),
    ({"threads": 0}, "threads must be in"),
    ({"voxel_size": 0.0}, "voxel_size"),
    ({"threads": 2.0}, "refine: threads must be an integer, got 2.0"),
    ({"no_ground": 1}, "refine: no_ground must be True or False"),
    ({"mode": 1}, "refine: mode must be a str"),
    ({"treads": 2},
     "refine: unknown keyword 'treads' \\(refine takes mode, method, surface_bundle, voxel_size"),
    ({"level_ground": False}, "unknown keyword 'level_ground'"),
])
def test_keyword_checks_raise_value_error(kwargs, message):
    with pytest.raises(ValueError, match=message):
        rigfit.refine({"a": one_camera()}, {"a": np.eye(4)}, **kwargs)


def test_file_errors_raise_value_error(tmp_path):
    with pytest.raises(ValueError, match="missing.h5"):
        rigfit.read_capture(tmp_path / "missing.h5")
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    with pytest.raises(ValueError, match="bad.json"):
        rigfit.read_extrinsics(bad)


def test_write_extrinsics_round_trip(tmp_path):
    rng = np.random.default_rng(1)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))
    T = np.eye(4)
    T[:3, :3] = q
    T[:3, 3] = rng.normal(size=3)
    path = tmp_path / "out.json"
    rigfit.write_extrinsics(path, {"cam": T}, meta={"note": {"x": 1}})
    back = rigfit.read_extrinsics(path)
    assert np.allclose(back["cam"], T, atol=1e-12, rtol=0)
    with open(path) as f:
        assert json.load(f)["_meta"] == {"note": {"x": 1}}


def test_warnings_reach_logging(rig, caplog):
    d, _ = rig
    cameras = rigfit.read_capture(d / "capture.h5")
    initial = rigfit.read_extrinsics(d / "init.json")
    with caplog.at_level(logging.INFO, logger="rigfit"):
        rigfit.refine(cameras, initial)
    assert any(r.name == "rigfit" for r in caplog.records)


def test_camera_and_pair_reports_match_meta(rig):
    d, _ = rig
    result = rigfit.refine(rigfit.read_capture(d / "capture.h5"),
                           rigfit.read_extrinsics(d / "init.json"))
    meta = result.meta["icp_refined"]
    assert [c.serial for c in result.cameras] == sorted(meta["cameras"])
    for c in result.cameras:
        m = meta["cameras"][c.serial]
        assert (c.accepted, c.reference, c.delta_rotation_deg) == (
            m["accepted"], m["reference"], m["delta_rotation_deg"])
        if c.reference:
            continue
        # Joint mode: the 6x6 covariance, symmetric, and its 1-sigma as in _meta.
        assert c.covariance.shape == (6, 6) and np.allclose(c.covariance, c.covariance.T)
        assert dataclasses.asdict(c.sigma) == m["sigma"]
        assert dataclasses.asdict(c.sigma_inflation) == m["sigma_inflation"]
        assert (c.surfaces, c.few_surfaces) == (m["surfaces"], m["few_surfaces"])
        assert [dataclasses.asdict(w) for w in c.weak_directions] == m.get("weak_directions", [])
    assert len(result.pairs) == len(meta["pairs"])
    for p, m in zip(result.pairs, meta["pairs"]):
        assert (p.serial_a, p.serial_b, p.fitness, p.accepted) == (
            m["serial_a"], m["serial_b"], m["fitness"], m["accepted"])


def test_depth_model_matches_meta(rig):
    # icp.depth_model through the config: every free depth camera's model, as _meta has it.
    d, _ = rig
    result = rigfit.refine(rigfit.read_capture(d / "capture.h5"),
                           rigfit.read_extrinsics(d / "init.json"),
                           config={"icp": {"surface_bundle": True, "depth_model": "offset"}})
    meta = result.meta["icp_refined"]["surface_bundle"]["thickness"]
    for c in result.cameras:
        if c.reference:
            assert c.depth_model is None
            continue
        assert dataclasses.asdict(c.depth_model) == meta[c.serial]["depth_model"]
        assert c.depth_model.scale == 1.0  # offset alone


def test_evaluate_equals_cli(rig, tmp_path):
    d, _ = rig
    out = tmp_path / "errors.json"
    subprocess.run([CLI, "evaluate", str(d / "init.json"), str(d / "gt.json"), "--json",
                    str(out)], check=True, stdout=subprocess.DEVNULL)
    with open(out) as f:
        expected = json.load(f)
    got = rigfit.evaluate(rigfit.read_extrinsics(d / "init.json"),
                          rigfit.read_extrinsics(d / "gt.json"))
    assert isinstance(got, rigfit.RigErrors) and isinstance(got.summary.rotation_deg, rigfit.RmsMax)
    for key in ("pairs", "cameras", "summary", "ignored_cameras"):
        assert dataclasses.asdict(got)[key] == expected[key], key
    with pytest.raises(ValueError, match="estimated has no pose for camera"):
        rigfit.evaluate({}, rigfit.read_extrinsics(d / "gt.json"))


def test_compare_equals_cli(rig, tmp_path):
    """rigfit.compare runs the CLI's three runs: the same document (but the sources and the
    measured time and memory), the same tables."""
    d, _ = rig
    out = tmp_path / "compare.json"
    done = subprocess.run([CLI, "compare", "--capture", str(d / "capture.h5"), "--extrinsics",
                           str(d / "init.json"), "--gt", str(d / "gt.json"), "--json", str(out),
                           "-q"], check=True, stdout=subprocess.PIPE, text=True)
    with open(out) as f:
        expected = json.load(f)
    got = rigfit.compare(rigfit.read_capture(d / "capture.h5"),
                         rigfit.read_extrinsics(d / "init.json"),
                         gt=rigfit.read_extrinsics(d / "gt.json"))
    doc = got.document
    # The typed runs: the document's numbers as objects.
    assert [r.name for r in got.runs] == expected["runs"]
    for run in got.runs:
        cli = expected["modes"][run.name]
        assert (run.mode, run.method, run.success) == (cli["mode"], cli["method"], cli["success"])
        assert run.errors.translation_mm.rms == doc["modes"][run.name]["errors"][
            "translation_mm"]["rms"]
        for serial, T in run.extrinsics.items():
            assert T.shape == (4, 4) and np.allclose(
                T, cli["cameras"][serial]["T_world_camera"], atol=1e-6), (run.name, serial)
    assert got.reference == expected["reference"] and got.errors_input is not None
    assert sorted(doc) == sorted(expected)
    assert doc["runs"] == expected["runs"] == ["pairwise", "joint", "surface_bundle"]
    assert doc["capture"] is None and doc["ground_truth"] is None
    assert doc["verdict"] == got.verdict and got.verdict
    assert "verdict: " + got.verdict in got.text
    for name in doc["runs"]:
        run, cli = doc["modes"][name], expected["modes"][name]
        assert run["success"] == cli["success"], name
        assert (run["mode"], run["method"]) == (cli["mode"], cli["method"]), name
        assert run["errors"]["translation_mm"]["rms"] is not None, name
        for serial, camera in run["cameras"].items():
            assert np.allclose(camera["T_world_camera"],
                               cli["cameras"][serial]["T_world_camera"], atol=1e-6), (name, serial)
    bundle = doc["modes"]["surface_bundle"]
    assert bundle["surface"]["ran"]
    assert all(c["surface"]["thickness_before"] > 0 for c in bundle["cameras"].values())
    # The CLI's tables but the header's capture name and the measured wall time and memory.
    def tables(text):
        return text[text.index("pair fit"):text.index("run  ")]
    assert tables(got.text) == tables(done.stdout)


@pytest.mark.parametrize("kwargs, message", [
    ({"gt": {"a": np.eye(4)}}, "compare: gt has no pose for camera b"),
    ({"config": {"icp": {"reference": "zz"}}}, "reference"),
    ({"reference": "a"}, "compare: unknown keyword 'reference' \\(compare takes threads\\)"),
    ({"threads": 0}, "compare: threads must be in"),
    ({"config": {"icp": {"mode": "both"}}}, "mode"),
])
def test_compare_checks_raise_value_error(kwargs, message):
    cameras = {"a": one_camera(), "b": one_camera()}
    with pytest.raises(ValueError, match=message):
        rigfit.compare(cameras, {"a": np.eye(4), "b": np.eye(4)}, **kwargs)


def test_compare_of_one_camera_raises_value_error():
    with pytest.raises(ValueError, match="compare: cameras holds one camera"):
        rigfit.compare({"a": one_camera()}, {"a": np.eye(4)})


def test_write_capture_round_trip(rig, tmp_path):
    d, _ = rig
    cameras = rigfit.read_capture(d / "capture.h5")
    path = tmp_path / "copy.h5"
    rigfit.write_capture(path, cameras)
    back = rigfit.read_capture(path)
    assert sorted(back) == sorted(cameras)
    for serial, cam in cameras.items():
        assert np.array_equal(back[serial]["depth"], cam["depth"], equal_nan=True)
        assert np.array_equal(back[serial]["K"], cam["K"])
    points = {"p": {"points": np.array([[0.0, 0.0, 1.0], [1.0, 2.0, 3.0]])}}
    rigfit.write_capture(tmp_path / "points.h5", points)
    assert np.allclose(rigfit.read_capture(tmp_path / "points.h5")["p"]["points"],
                       points["p"]["points"])
    mm = tmp_path / "mm.h5"
    rigfit.write_capture(mm, cameras, depth_as_uint16=True, depth_scale=0.001)
    for serial, cam in rigfit.read_capture(mm).items():
        assert np.nanmax(np.abs(cam["depth"] - cameras[serial]["depth"])) <= 0.0005 + 1e-6
    with pytest.raises(ValueError, match="no cameras"):
        rigfit.write_capture(tmp_path / "none.h5", {})


def test_no_icp_equals_cli(rig, tmp_path):
    """no_icp=True is `rigfit refine --no-icp`: the leveled poses and the same _meta."""
    d, _ = rig
    out = tmp_path / "leveled.json"
    subprocess.run([CLI, "refine", "--capture", str(d / "capture.h5"), "--extrinsics",
                    str(d / "init.json"), "--out", str(out), "--no-icp", "--no-timings", "-q"],
                   stdout=subprocess.DEVNULL)
    with open(out) as f:
        doc = json.load(f)
    result = rigfit.refine(rigfit.read_capture(d / "capture.h5"),
                           rigfit.read_extrinsics(d / "init.json"), no_icp=True)
    for serial, T in cli_poses(doc).items():
        assert np.array_equal(result.extrinsics[serial], T), serial
    for key, value in result.meta.items():
        assert doc["_meta"][key] == value, key


# One calling style: keyword-only options named as the CLI's flags, None for "not given".

KEYWORD_COMMANDS = ["refine", "compare", "write_capture", "simulate", "open_sequence", "track",
                    "slam", "evaluate_trajectory"]


@pytest.mark.parametrize("command", KEYWORD_COMMANDS)
def test_signature_is_the_keyword_table(command):
    """Every option is keyword-only with the default None, and the options of the binding's
    table (its one list of names) are all there, listed with their defaults in the docstring."""
    function = getattr(rigfit, command)
    params = inspect.signature(function).parameters
    options = {n: p for n, p in params.items() if p.kind is p.KEYWORD_ONLY}
    assert all(p.default is None for p in options.values()), command
    assert set(rigfit.defaults(command)) <= set(options)
    assert not any(p.kind is p.VAR_KEYWORD for p in params.values())
    for name, default in rigfit.defaults(command).items():
        assert f"{name}={default!r}" in function.__doc__, name


@pytest.mark.parametrize("call, message", [
    (lambda: rigfit.simulate(seeed=1), "simulate: unknown keyword 'seeed' \\(simulate takes "
                                       "cameras, seed,"),
    (lambda: rigfit.track([], first_frame=1), "track: unknown keyword 'first_frame'"),
    (lambda: rigfit.slam([], halvings=1), "slam: unknown keyword 'halvings'"),
    (lambda: rigfit.open_sequence("x", serial="a"), "open_sequence: unknown keyword 'serial'"),
    (lambda: rigfit.write_capture("x.h5", {}, scale=1.0), "write_capture: unknown keyword"),
    (lambda: rigfit.evaluate_trajectory(([], []), ([], []), max_dt_s=1.0),
     "evaluate_trajectory: unknown keyword 'max_dt_s'"),
    (lambda: rigfit.track([], iterations=[10, "5"]), r"track: iterations\[1\] must be an integer"),
    (lambda: rigfit.track([], iterations=5), "track: iterations must be a list of integers"),
    (lambda: rigfit.slam([], color="yes"), "slam: color must be True or False"),
    (lambda: rigfit.open_sequence("x", intrinsics="1,2,3,4"), "intrinsics must be a list"),
    (lambda: rigfit.evaluate_trajectory(([], []), ([], []), delta=1.5),
     "evaluate_trajectory: delta must be an integer"),
])
def test_unknown_or_mistyped_keyword_raises_value_error(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_none_is_the_default():
    small = {"cameras": 2, "width": 32, "height": 24}
    a = rigfit.simulate(**small)
    b = rigfit.simulate(**small, seed=None, noise=None, bare=None)
    for serial in a.cameras:
        assert np.array_equal(a.cameras[serial]["depth"], b.cameras[serial]["depth"],
                              equal_nan=True)
    assert rigfit.defaults("simulate")["seed"] == 0
    with pytest.raises(ValueError, match="defaults: no command 'refin'"):
        rigfit.defaults("refin")
