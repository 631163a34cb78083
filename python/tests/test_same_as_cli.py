"""The module and the executable give the same files and numbers."""

import json
import os

import numpy as np

import mcvo
from conftest import REAL_DIR, TINY_RENDER, cli, comparable_outputs, file_hashes


def test_version_is_the_executables():
    assert cli("--version").stdout.split() == ["mcvo", mcvo.__version__]


def test_synth_writes_the_same_files(work, tiny_dataset):
    out = work / "tiny_py"
    summary = mcvo.synth(str(out), **TINY_RENDER)
    assert summary["frames"] == 12 and summary["cameras"] == 1
    assert summary["out"] == str(out)
    assert file_hashes(out) == file_hashes(tiny_dataset)


def test_run_writes_the_same_files_on_a_render(tiny_cli_run, tiny_py_run):
    assert comparable_outputs(tiny_py_run.out_dir) == comparable_outputs(tiny_cli_run)
    assert len(tiny_py_run.trajectory) > 0, "the tiny render should be posed"
    np.testing.assert_array_equal(tiny_py_run.trajectory,
                                  mcvo.read_trajectory(tiny_cli_run / "trajectory.tum"))


def test_thread_count_does_not_change_results(work, tiny_dataset, tiny_cli_run):
    one = mcvo.run(mcvo.open_dataset(str(tiny_dataset)), out=str(work / "tiny_py_run_1thread"), threads=1)
    assert one.manifest["config"]["runtime"]["threads"] == 0  # recorded as 0 whatever ran
    assert comparable_outputs(one.out_dir) == comparable_outputs(tiny_cli_run)


def test_run_with_a_dict_config_equals_its_file(work, tiny_dataset, tiny_cli_run):
    config = {"backend": {"window_size": 12}, "runtime": {"threads": 1}}
    path = work / "big_window.json"
    path.write_text(json.dumps(config))
    cli_out = work / "tiny_cli_run_window12"
    cli("run", "--dataset", tiny_dataset, "--config", path, "--out", cli_out)
    from_dict = mcvo.run(str(tiny_dataset), config=config, out=str(work / "tiny_py_run_window12"))
    hashes, manifest = comparable_outputs(from_dict.out_dir)
    cli_hashes, cli_manifest = comparable_outputs(cli_out)
    assert manifest.pop("config_source") == "<dict>"
    assert cli_manifest.pop("config_source") == str(path)
    assert (hashes, manifest) == (cli_hashes, cli_manifest)


def test_run_writes_the_same_files_on_a_real_sample(work, real_sample):
    cli_out = work / "kitti00_cli"
    cli("run", "--dataset", real_sample, "--out", cli_out)
    run = mcvo.run(mcvo.open_dataset(str(real_sample)), out=str(work / "kitti00_py"))
    assert comparable_outputs(run.out_dir) == comparable_outputs(cli_out)
    assert run.summary["frames"] == 20
    assert run.summary["scale_arbitrary"] is True  # one camera
    assert run.evaluation is not None
    with open(cli_out / "eval" / "eval.json") as f:
        assert run.evaluation == json.load(f)


def test_evaluate_gives_the_numbers_of_mcvo_eval(work, tiny_cli_run):
    for name, gt, est in [("tiny", tiny_cli_run.parent / "tiny_cli" / "groundtruth.tum",
                           tiny_cli_run / "trajectory.tum"),
                          ("peer", REAL_DIR / "kitti06_stereo" / "groundtruth.tum",
                           REAL_DIR / "kitti06_stereo" / "peers" / "libviso2.tum")]:
        if not os.path.exists(est):
            continue
        for align in ("auto", "sim3"):
            out = work / f"eval_{name}_{align}"
            cli("eval", "--gt", gt, "--est", est, "--align", align, "--out", out)
            with open(out / "eval.json") as f:
                expected = json.load(f)
            assert mcvo.evaluate(str(gt), str(est), align=align) == expected
            py_out = work / f"eval_{name}_{align}_py"
            mcvo.evaluate(str(gt), str(est), align=align, out=str(py_out))
            assert file_hashes(py_out) == file_hashes(out)


def test_evaluate_auto_follows_run_json(tiny_py_run, tiny_dataset):
    # One camera: sim3, as `mcvo eval --align auto` on a run's trajectory.
    result = mcvo.evaluate(str(tiny_dataset / "groundtruth.tum"), tiny_py_run)
    assert result["options"]["align"] == "sim3"
    assert mcvo.evaluate(str(tiny_dataset / "groundtruth.tum"), tiny_py_run,
                         align="se3")["options"]["align"] == "se3"
