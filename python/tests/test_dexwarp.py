"""The Python binding: arrays in and out, the command line's report, errors with fields."""

import json
import math
import subprocess

import numpy as np
import pytest

import dexwarp

# The quickest built-in config with waypoints, a new end and physics (the gripper's IK is
# small): every test here warps it.
CONFIG = "scenes/configs/gripper_box_waypoints.json"


def arrays_of(demo):
    """Demo.from_arrays keywords reproducing `demo` from its arrays."""
    return dict(
        name=demo.name,
        fps=demo.fps,
        robot=demo.robot,
        object_mesh=demo.object_mesh,
        object_mass=demo.object_mass,
        object_name=demo.object_name,
        joint_names=demo.joint_names,
        object_positions=demo.object_positions,
        object_quaternions=demo.object_quaternions,
        wrist_positions=demo.wrist_positions,
        wrist_quaternions=demo.wrist_quaternions,
        joints=demo.joints,
        contact_frames=demo.contact_frames,
        contact_links=demo.contact_links,
        contact_hand_points=demo.contact_hand_points,
        contact_object_points=demo.contact_object_points,
        scene=demo.scene,
        barriers=demo.barriers,
    )


@pytest.fixture(scope="module")
def loaded():
    config = dexwarp.Config.load(CONFIG)
    return dexwarp.Demo.load(config.demo), config


@pytest.fixture(scope="module")
def warped(loaded):
    demo, config = loaded
    return dexwarp.warp(demo, config)


def test_arrays_round_trip_through_demo_and_warp(loaded, warped):
    demo, config = loaded
    again = dexwarp.Demo.from_arrays(**arrays_of(demo))
    assert len(again) == len(demo) and str(again.source) == "<arrays>"
    for name in ["object_positions", "object_quaternions", "wrist_positions",
                 "wrist_quaternions", "joints", "contact_hand_points", "contact_object_points"]:
        a, b = getattr(demo, name), getattr(again, name)
        assert a.dtype == np.float64 and a.shape == b.shape, name
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-15, err_msg=name)
    np.testing.assert_array_equal(again.contact_frames, demo.contact_frames)
    assert again.contact_links == demo.contact_links

    result = dexwarp.warp(again, config)
    report = result.report
    n_out, n_in = report["frames_out"], report["frames_in"]
    assert n_in == len(demo)
    assert result.object_positions.shape == (n_out, 3)
    assert result.object_quaternions.shape == (n_out, 4)
    assert result.wrist_positions.shape == (n_out, 3)
    assert result.wrist_quaternions.shape == (n_out, 4)
    assert result.joints.shape == (n_out, len(demo.joint_names))
    assert result.tau.shape == (n_in,)
    # tau is strictly increasing, within the output, and the demo carries it.
    assert np.all(np.diff(result.tau) > 0) and 0 <= result.tau[0] and result.tau[-1] <= n_out - 1
    np.testing.assert_array_equal(result.demo.timewarp, result.tau)
    np.testing.assert_allclose(np.linalg.norm(result.object_quaternions, axis=1), 1, atol=1e-12)
    # The waypoints are hit at their output frames.
    for w in config.to_dict()["waypoints"]:
        error_mm = 1e3 * np.linalg.norm(result.object_positions[int(w["t_new"])] - w["position"])
        assert error_mm <= report["constraints"]["max_waypoint_error_mm"] + 1e-9
    # The same warp as from the file: the arrays went in unchanged.
    for name in ["object_positions", "object_quaternions", "wrist_positions",
                 "wrist_quaternions", "joints", "tau"]:
        np.testing.assert_allclose(getattr(result, name), getattr(warped, name),
                                   rtol=0, atol=1e-9, err_msg=name)
    assert report["metrics"]["d_c_mm"] == pytest.approx(warped.report["metrics"]["d_c_mm"])


def without_timing(report):
    """The report without what varies between identical runs: stage times, and the
    hashes of written files (present only once files are written)."""
    r = json.loads(json.dumps(report))
    r.pop("timing_s")
    r.pop("outputs", None)
    if r.get("physics"):
        r["physics"].pop("timing_s", None)
        # Whether the convex decomposition came from the disk cache (the first run fills it).
        r["physics"].get("replay", {}).pop("decomposition_cached", None)
    return r


def assert_same(a, b, where="report"):
    """Equal JSON values; floats to 1e-9 relative (a wheel and a binary built with other
    optimization levels may differ in the last bits)."""
    if isinstance(a, dict) and isinstance(b, dict):
        assert a.keys() == b.keys(), f"{where}: keys {sorted(a.keys() ^ b.keys())} differ"
        for k in a:
            assert_same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list) and isinstance(b, list):
        assert len(a) == len(b), f"{where}: {len(a)} against {len(b)} items"
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{where}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12), f"{where}: {a} != {b}"
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


def test_same_report_and_outputs_as_the_command_line(cli, warped, tmp_path):
    out = tmp_path / "cli"
    subprocess.run([cli, "warp", "--config", CONFIG, "--out", out], check=True,
                   capture_output=True)
    expected = json.loads((out / "report.json").read_text())
    assert expected["physics"]["verdict"] in ("pass", "fail")
    assert_same(without_timing(warped.report), without_timing(expected))

    # The warped demonstration's arrays are the file's.
    name = expected["name"]
    stored = json.loads((out / f"{name}.demo.json").read_text())
    frames = stored["frames"]
    np.testing.assert_allclose(warped.object_positions,
                               [f["object"]["position"] for f in frames], rtol=0, atol=1e-12)
    np.testing.assert_allclose(warped.wrist_quaternions,
                               [f["wrist"]["orientation"] for f in frames], rtol=0, atol=1e-12)
    np.testing.assert_allclose(warped.joints, [f["joints"] for f in frames], rtol=0, atol=1e-12)
    np.testing.assert_allclose(warped.tau, stored["timewarp"], rtol=0, atol=1e-12)

    # save() writes the command line's set: the same report, files that read back.
    mine = tmp_path / "py"
    saved = warped.save(mine)
    assert set(saved["outputs"]) == {f"{name}.demo.json", "frames.csv"}
    assert_same(without_timing(saved), without_timing(expected))
    back = dexwarp.Demo.load(mine / f"{name}.demo.json")
    np.testing.assert_allclose(back.joints, warped.joints, rtol=0, atol=1e-12)


def test_validate_matches_the_command_line(cli, warped, tmp_path):
    path = tmp_path / "w" / "out.demo.json"
    warped.demo.save(path)
    out = tmp_path / "v"
    subprocess.run([cli, "validate", path, "--out", out], check=True, capture_output=True)
    expected = json.loads((out / "report.json").read_text())
    report = dexwarp.validate(dexwarp.Demo.load(path))
    assert_same(without_timing(report), without_timing(expected))
    assert report["physics"]["verdict"] == warped.report["physics"]["verdict"]


def test_validate_takes_the_ensemble_of_the_command_line(cli, warped, tmp_path):
    path = tmp_path / "w" / "out.demo.json"
    warped.demo.save(path)
    out = tmp_path / "v"
    subprocess.run(
        [cli, "validate", path, "--out", out, "--ensemble", "3", "--ensemble-seed", "5",
         "--ensemble-max", "6"],
        check=True,
        capture_output=True,
    )
    expected = json.loads((out / "report.json").read_text())
    report = dexwarp.validate(
        dexwarp.Demo.load(path), ensemble=3, ensemble_seed=5, ensemble_max=6
    )
    assert_same(without_timing(report), without_timing(expected))
    e = report["physics"]["ensemble"]
    assert e["members"] == 3 and e["seed"] == 5 and e["max_members"] == 6, e
    assert e["replayed"] <= 6, e
    assert e["member"][0]["draw"]["friction_scale"] == 1.0
    single = dexwarp.validate(dexwarp.Demo.load(path), ensemble=1)
    assert single["physics"]["ensemble"] is None


def cli_error(cli, *args):
    run = subprocess.run([cli, *args], capture_output=True, text=True)
    assert run.returncode != 0
    assert run.stderr.startswith("error: "), run.stderr
    return run.stderr[len("error: "):].strip()


def test_a_bad_file_raises_the_command_lines_message(cli, tmp_path):
    demo = dexwarp.Demo.load("scenes/demos/small_box.demo.json")
    stored = json.loads(open("scenes/demos/small_box.demo.json").read())
    stored["robot"] = str(demo.robot.resolve())
    stored["object"]["mesh"] = str(demo.object_mesh.resolve())
    stored.pop("scene", None)
    stored["frames"][3]["joints"][0] = 1e9
    bad = tmp_path / "a" / "b" / "bad.demo.json"
    bad.parent.mkdir(parents=True)
    bad.write_text(json.dumps(stored))
    expected = cli_error(cli, "validate", bad, "--out", tmp_path / "out")
    with pytest.raises(dexwarp.DexwarpError) as err:
        dexwarp.Demo.load(bad)
    assert str(err.value) == expected
    assert err.value.field == "frames[3].joints[0]" and err.value.path == str(bad)


def test_bad_arrays_raise_with_the_field_named(loaded):
    demo, _ = loaded
    kw = arrays_of(demo)
    joints = demo.joints.copy()
    joints[5, 0] = np.nan
    with pytest.raises(dexwarp.DexwarpError, match=r"<arrays>: frames\[5\]\.joints\[0\]: is NaN"):
        dexwarp.Demo.from_arrays(**{**kw, "joints": joints})
    with pytest.raises(dexwarp.DexwarpError) as err:
        dexwarp.Demo.from_arrays(**{**kw, "wrist_positions": demo.wrist_positions[:, :2]})
    assert err.value.field == "wrist_positions"
    assert f"has shape ({len(demo)}, 2); expected an array of shape ({len(demo)}, 3)" in str(err.value)
    q = demo.object_quaternions.copy()
    q[2] *= 2
    with pytest.raises(dexwarp.DexwarpError, match=r"frames\[2\]\.object\.orientation"):
        dexwarp.Demo.from_arrays(**{**kw, "object_quaternions": q})
    frames = demo.contact_frames.copy()
    frames[0] = len(demo)
    with pytest.raises(dexwarp.DexwarpError, match=r"contact_frames\[0\]: is"):
        dexwarp.Demo.from_arrays(**{**kw, "contact_frames": frames})


def test_bad_config_dict_and_keywords_raise_with_the_field_named(loaded):
    demo, config = loaded
    d = config.to_dict()
    d["waypoints"][1]["t"] = d["waypoints"][0]["t"]
    with pytest.raises(dexwarp.DexwarpError) as err:
        dexwarp.Config.from_dict(d, path=CONFIG)
    assert err.value.field == "waypoints[1].t" and "strictly increasing t" in str(err.value)
    d = config.to_dict()
    d["params"]["alpha_m"] = float("nan")
    with pytest.raises(dexwarp.DexwarpError, match=r"<dict>: params\.alpha_m: is NaN"):
        dexwarp.Config.from_dict(d)
    d = config.to_dict()
    d["barriers"] = ["no_such_item"]
    with pytest.raises(dexwarp.DexwarpError, match=r"barriers\[0\]: \"no_such_item\" is not an item"):
        dexwarp.warp(demo, dexwarp.Config.from_dict(d, path=CONFIG))
    with pytest.raises(dexwarp.DexwarpError, match="threshold_mm: the value must be positive"):
        dexwarp.warp(demo, config, threshold_mm=-1)
    with pytest.raises(dexwarp.DexwarpError, match="hand: unknown variant `hands`"):
        dexwarp.warp(demo, config, hand="hands")
    with pytest.raises(dexwarp.DexwarpError) as err:
        dexwarp.Config.load("scenes/no_such.json")
    assert err.value.path == "scenes/no_such.json" and "cannot read" in str(err.value)


def test_augment_returns_the_stats_it_writes(tmp_path):
    out = tmp_path / "aug"
    stats = dexwarp.augment("scenes/demos/cube.demo.json", "scenes/variations/cube.json",
                            count=2, seed=1, out=out, jobs=1)
    assert stats["attempts"] == 2 and stats["ran"] + stats["rejected"] == 2
    assert stats == json.loads((out / "stats.json").read_text())
    with pytest.raises(dexwarp.DexwarpError, match="shard"):
        dexwarp.augment("scenes/demos/cube.demo.json", "scenes/variations/cube.json",
                        count=2, out=tmp_path / "x", shard="3/2", margin=True)
