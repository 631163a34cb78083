"""The module's surface: numpy shapes and dtypes, the camera models, errors."""

import json

import numpy as np
import pytest

import mcvo
from conftest import REAL_DIR, cli

# One camera of every model, parameters in rig.json order (docs/rig-json.md).
MODELS = {
    "pinhole": [400.0, 410.0, 320.0, 240.0],
    "radtan": [400.0, 410.0, 320.0, 240.0, -0.1, 0.01, 0.001, -0.0005, 0.0],
    "kannala_brandt": [300.0, 300.0, 320.0, 240.0, 0.01, -0.005, 0.001, -0.0001],
    "mei": [1.2, -0.1, 0.02, 0.001, 0.0005, 700.0, 700.0, 320.0, 240.0],
    "double_sphere": [250.0, 250.0, 320.0, 240.0, -0.2, 0.6],
}


@pytest.mark.parametrize("model", sorted(MODELS))
def test_every_camera_model_projects_and_unprojects(model):
    camera = mcvo.Camera(model, MODELS[model], 640, 480, name="c")
    assert camera.model == model and camera.size == (640, 480)
    assert camera.params.dtype == np.float64 and len(camera.param_names) == len(camera.params)
    rng = np.random.default_rng(1)
    points = np.column_stack([rng.uniform(-1, 1, 50), rng.uniform(-0.8, 0.8, 50), rng.uniform(2, 5, 50)])
    pixels = camera.project(points)
    assert pixels.shape == (50, 2) and pixels.dtype == np.float64
    assert np.isfinite(pixels).all()
    bearings = camera.unproject(pixels)
    assert bearings.shape == (50, 3)
    np.testing.assert_allclose(bearings, points / np.linalg.norm(points, axis=1, keepdims=True), atol=1e-9)
    # One point in, one pixel out; a point outside the domain gives NaN.
    assert camera.project(points[0]).shape == (2,)
    if model in ("pinhole", "radtan"):
        assert np.isnan(camera.project([[0.5, 0.0, -1.0]])).all()
    assert camera.is_in_image(pixels).dtype == np.bool_


def test_camera_rejects_bad_values():
    with pytest.raises(mcvo.InputError, match="4 parameters, got 2"):
        mcvo.Camera("pinhole", [1.0, 2.0], 10, 10)
    with pytest.raises(mcvo.InputError, match="unknown model"):
        mcvo.Camera("nope", [1.0], 10, 10)
    with pytest.raises(mcvo.UsageError, match="N x 3"):
        mcvo.Camera("pinhole", MODELS["pinhole"], 640, 480).project(np.zeros((4, 2)))


def test_rig_load(tmp_path):
    rig = mcvo.Rig.load(REAL_DIR / "kitti06_stereo" / "rig.json")
    assert len(rig) == 2 and rig.names == [c.name for c in rig.cameras]
    second = rig[1]
    assert rig[second.name].name == second.name
    assert second.cam_from_rig.shape == (4, 4) and second.cam_from_rig.dtype == np.float64
    # The stereo baseline of KITTI odometry, 0.5372 m.
    assert abs(np.linalg.norm(second.cam_from_rig[:3, 3]) - 0.5372) < 1e-3
    rig.save(tmp_path / "rig.json")
    again = mcvo.Rig.load(tmp_path / "rig.json")
    np.testing.assert_array_equal(again[1].cam_from_rig, second.cam_from_rig)
    np.testing.assert_array_equal(again[1].params, second.params)


def test_open_dataset_shapes():
    dataset = mcvo.open_dataset(REAL_DIR / "kitti06_stereo")
    n = len(dataset)
    assert dataset.format == "generic" and n == 51
    assert dataset.times.shape == (n,) and dataset.times.dtype == np.int64
    assert np.all(np.diff(dataset.times) > 0)
    assert dataset.image_paths.shape == (n, 2)
    assert dataset.ground_truth.shape == (n, 8) and dataset.ground_truth.dtype == np.float64
    np.testing.assert_allclose(dataset.ground_truth[:, 0], dataset.times / 1e9)
    one = mcvo.open_dataset(REAL_DIR / "kitti06_stereo", cameras=[dataset.camera_names[1]])
    assert one.camera_names == dataset.camera_names[1:] and one.image_paths.shape == (n, 1)


def test_run_outputs_shapes(tiny_py_run):
    run = tiny_py_run
    assert run.trajectory.ndim == 2 and run.trajectory.shape[1] == 8 and run.trajectory.dtype == np.float64
    assert run.keyframes.shape[1] == 8 and 0 < len(run.keyframes) <= len(run.trajectory)
    stats = run.frame_stats
    assert len(stats["frame"]) == 12 and stats["frame"].dtype == np.int64
    assert stats["t_ns"].dtype == np.int64 and stats["state"].dtype.kind == "U"
    assert "event" in run.scale_log
    assert run.manifest["program"] == "mcvo" and run.manifest["version"] == mcvo.__version__
    assert run.summary["frames"] == 12 and run.summary["posed_frames"] == len(run.trajectory)
    again = mcvo.read_run(run.out_dir)
    np.testing.assert_array_equal(again.trajectory, run.trajectory)
    assert again.manifest == run.manifest and set(again.frame_stats) == set(stats)
    for key in ("trajectory", "keyframes", "scale_log", "frame_stats", "run_json"):
        assert key in run.paths


def test_trajectory_round_trip(tmp_path):
    gt = mcvo.read_trajectory(REAL_DIR / "kitti06_stereo" / "groundtruth.tum")
    for fmt in ("tum", "euroc", "kitti", "kitti-indexed"):
        path = tmp_path / f"t.{fmt}"
        mcvo.write_trajectory(path, gt, format=fmt)
        back = mcvo.read_trajectory(path, format=fmt)
        np.testing.assert_array_equal(back[:, 1:4], gt[:, 1:4])
        if fmt in ("tum", "euroc"):
            np.testing.assert_array_equal(back[:, 0], gt[:, 0])
        else:
            assert np.isnan(back[:, 0]).all()
    with pytest.raises(mcvo.UsageError):
        mcvo.write_trajectory(tmp_path / "x", gt, format="bogus")


def test_errors_carry_the_clis_message(tmp_path, tiny_dataset):
    bad = {"frontend": {"max_features_pinhole": "many"}}
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(bad))
    proc = cli("run", "--dataset", tiny_dataset, "--config", path, "--out", tmp_path / "o1", check=False)
    assert proc.returncode == 3
    line = proc.stderr.strip().splitlines()[-1]
    assert line.startswith("mcvo run: error: ")
    cli_message = line[len("mcvo run: error: "):]
    with pytest.raises(mcvo.InputError) as from_file:
        mcvo.run(str(tiny_dataset), config=str(path), out=str(tmp_path / "o2"))
    assert str(from_file.value) == cli_message
    with pytest.raises(mcvo.InputError) as from_dict:
        mcvo.run(str(tiny_dataset), config=bad, out=str(tmp_path / "o3"))
    assert str(from_dict.value) == cli_message.replace(str(path), "<dict>")
    assert "/frontend/max_features_pinhole" in str(from_dict.value)
    assert isinstance(from_dict.value, ValueError)
    for out in ("o1", "o2", "o3"):
        assert not (tmp_path / out).exists()


def test_error_kinds(tmp_path, tiny_dataset):
    with pytest.raises(mcvo.InputError, match="nowhere"):
        mcvo.open_dataset(tmp_path / "nowhere")
    (tmp_path / "rig.json").write_text('{"cameras": [{"name": "a"}]}')
    with pytest.raises(mcvo.InputError, match=r"rig\.json"):
        mcvo.Rig.load(tmp_path / "rig.json")
    with pytest.raises(mcvo.UsageError, match="threads"):
        mcvo.run(str(tiny_dataset), out=str(tmp_path / "o"), threads=-1)
    with pytest.raises(mcvo.UsageError, match="align"):
        mcvo.evaluate(str(tiny_dataset / "groundtruth.tum"), str(tiny_dataset / "groundtruth.tum"), align="x")
    with pytest.raises(mcvo.UsageError, match="is not a camera of"):
        mcvo.open_dataset(tiny_dataset, cameras=["nope"])
    assert issubclass(mcvo.UsageError, ValueError) and issubclass(mcvo.InputError, ValueError)
