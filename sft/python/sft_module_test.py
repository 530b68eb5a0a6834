"""polyfit.polysft against the polysft command line on the same scene."""
import json
import os
import subprocess

import numpy as np
import pytest

import polyfit

BIN_DIR = os.environ.get("POLYFIT_BIN_DIR", "")


def tool(name):
    path = os.path.join(BIN_DIR, name)
    if not os.path.exists(path):
        pytest.skip(f"{name} is not built at {path}")
    return path


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    directory = tmp_path_factory.mktemp("sft") / "scene"
    subprocess.run([tool("polysft"), "generate", "--out", str(directory), "--frames", "20", "--width", "160",
                    "--height", "120", "--motion", "bend"], check=True, capture_output=True)
    return directory


def test_polysft_equals_the_command_line(scene, tmp_path):
    frames = []
    summary = polyfit.polysft(scene, out_dir=tmp_path / "py", on_frame=lambda f: frames.append(f.index),
                              max_frames=3, num_threads=1)
    subprocess.run([tool("polysft"), "--scene", str(scene), "--out", str(tmp_path / "cli"), "--max-frames", "3",
                    "--threads", "1"], check=True, capture_output=True)
    assert summary.is_solution_usable() and len(summary.frames) == 3 and frames == [0, 1, 2]
    assert [name for name, _ in summary.terms] == ["photometric", "silhouette", "inextensibility", "occluded_hold",
                                                "temporal"]
    metrics = json.loads((tmp_path / "cli" / "metrics.json").read_text())
    py_metrics = json.loads((tmp_path / "py" / "metrics.json").read_text())
    assert py_metrics["settings"] == metrics["settings"]
    for frame in summary.frames:
        cli = polyfit.read_ply_vertices(str(tmp_path / "cli" / "meshes" / f"{frame.index:06d}.ply"))
        np.testing.assert_allclose(cli, frame.vertices, atol=1e-5)  # the PLY holds floats
        assert np.isfinite(frame.e3d) and frame.e3d < 0.05
        cli_frame = metrics["frames"][frame.index]
        assert (frame.patches, frame.flow_matches, frame.flow_start, frame.keypoint_matches,
                frame.relocalized) == (cli_frame["patches"], cli_frame["flow_matches"], cli_frame["flow_start"],
                                       cli_frame["keypoint_matches"], cli_frame["relocalized"])
    assert summary.frames[0].flow_matches == 0 and summary.frames[1].flow_matches > 0
    assert summary.mean_e3d == pytest.approx(np.mean([f.e3d for f in summary.frames]))
    assert len(summary.trace) >= 3 and summary.trace[-1].time_s > 0
    # Chosen by the solver, as the command line records them.
    assert summary.silhouette_band_px == metrics["silhouette_band_px"] == 0.0  # exact generated masks
    assert summary.pyramid_levels == metrics["pyramid_levels"] == 3
    assert (summary.coarse_moves_checked, summary.coarse_moves_undone) == (
        metrics["coarse_moves"]["checked"], metrics["coarse_moves"]["undone"])
    assert 0 <= summary.coarse_moves_undone <= summary.coarse_moves_checked


def test_settings_are_the_command_lines(scene, tmp_path):
    settings = polyfit.polysft_settings()
    assert settings["window_size"] == polyfit.polysft_settings()["window_size"] >= 1
    config = tmp_path / "config.json"
    config.write_text(json.dumps({"window_size": 1, "jet_order": 3}))
    summary = polyfit.polysft(scene, config=config, max_frames=1, jet_order=2)
    assert len(summary.frames) == 1 and "temporal" not in [name for name, _ in summary.terms]


def test_bad_settings_and_scenes_are_named(scene, tmp_path):
    with pytest.raises(polyfit.InvalidArgumentError, match="window_sise"):
        polyfit.polysft(scene, window_sise=2)
    with pytest.raises(polyfit.InputError, match="scene.json"):
        polyfit.polysft(tmp_path / "no_scene")
    with pytest.raises(ZeroDivisionError):
        polyfit.polysft(scene, max_frames=1, on_frame=lambda f: 1 / 0)
