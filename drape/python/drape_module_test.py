"""polyfit.onefit_simulate and polyfit.onefit_drape against `onefit` on the
shared MakeHuman data (skipped with a message where it is absent)."""
import csv
import os
import subprocess

import numpy as np
import pytest

import polyfit

BIN_DIR = os.environ.get("POLYFIT_BIN_DIR", "")
DATA = os.environ.get("POLYFIT_SHARED_DATA_DIR", "")
SOURCE = os.environ.get("POLYFIT_SOURCE_DIR", "")
DRAPE = os.path.join(DATA, "drape")
BODY = os.path.join(DRAPE, "body")
SUIT = os.path.join(DRAPE, "garments", "makehuman_cc0", "male_casualsuit02.mhclo")
WALK = os.path.join(DRAPE, "motion", "02_01.bvh")
CLIP = dict(num_frames=2, lead_in_frames=2, render_every=0)

pytestmark = pytest.mark.skipif(not all(os.path.exists(p) for p in (BODY, SUIT, WALK)),
                                reason=f"the shared drape data is not at {DRAPE}")


def test_simulate_equals_the_command_line(tmp_path):
    summary = polyfit.onefit_simulate(SUIT, WALK, tmp_path / "py", body_dir=BODY, **CLIP)
    cli = os.path.join(BIN_DIR, "onefit")
    if not os.path.exists(cli):
        pytest.skip(f"onefit is not built at {cli}")
    subprocess.run([cli, "simulate", "--body", BODY, "--garment", SUIT, "--motion", WALK, "--out",
                    str(tmp_path / "cli"), "--frames", "2", "--lead-in", "2", "--render-every", "0"],
                   check=True, capture_output=True)
    assert summary.frames == 2 and len(summary.positions) == 2 and summary.all_finite
    assert summary.positions[0].shape == (summary.garment_vertices, 3)
    with open(tmp_path / "cli" / "frames.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 2
    for record, positions, row in zip(summary.records, summary.positions, rows):
        written = polyfit.read_ply_vertices(str(tmp_path / "cli" / "meshes" / f"frame_{record.frame:04d}.ply"))
        np.testing.assert_allclose(positions, written, atol=1e-5)  # the PLY holds floats
        keys = [k for k in row if "inside" in k and "nearest" not in k and "unprojected" not in k]
        assert float(row[keys[0]]) == pytest.approx(record.inside_percent, abs=1e-4)  # CSV rounding
        assert 0.0 <= record.inside_percent < 5.0 and 0.0 < record.edge_strain_percent < 15.0


def test_skinning_by_heat_diffusion(tmp_path):
    # The options reach the skinning: heat diffusion gives other weights,
    # hence another first frame, just as plausible.
    surface = polyfit._drape.SkinSmoothing.SURFACE
    assert polyfit._drape.SkinTransferOptions().smoothing == polyfit._drape.SkinSmoothing.EDGE_STEPS
    steps = polyfit.onefit_simulate(SUIT, WALK, tmp_path / "steps", body_dir=BODY, **CLIP)
    heat = polyfit.onefit_simulate(SUIT, WALK, tmp_path / "heat", body_dir=BODY, skin__smoothing=surface, **CLIP)
    assert heat.all_finite
    assert np.abs(heat.positions[0] - steps.positions[0]).max() > 1e-4
    for record in heat.records:
        assert 0.0 <= record.inside_percent < 5.0 and 0.0 < record.edge_strain_percent < 15.0


def test_drape_with_the_shipped_model(tmp_path):
    model = os.path.join(SOURCE, "drape", "models", "onefit_default.pfonefit")
    if not os.path.exists(model):
        pytest.skip(f"no shipped model at {model}")
    summary = polyfit.onefit_drape(model, SUIT, WALK, tmp_path, body_dir=BODY, **CLIP)
    assert summary.all_finite and summary.frames == 2
    assert summary.mean_time_s < 0.1  # the network, not the solver (generous for a loaded machine)
    assert all(np.isfinite(p).all() for p in summary.positions)
    refined = polyfit.onefit_drape(model, SUIT, WALK, tmp_path / "refined", body_dir=BODY, refine_iterations=1,
                                   **CLIP)
    assert refined.records[-1].inside_percent <= summary.records[-1].inside_percent + 0.5
    # The relaxation (on by default) takes the strain the patches leave:
    # about 11% as predicted, about 6% relaxed.
    predicted = polyfit.onefit_drape(model, SUIT, WALK, tmp_path / "predicted", body_dir=BODY, relax_passes=0,
                                     **CLIP)
    assert predicted.all_finite
    assert summary.records[-1].edge_strain_percent < predicted.records[-1].edge_strain_percent - 2.0


def test_bad_inputs_are_named(tmp_path):
    with pytest.raises(polyfit.InputError, match="no_such_garment.mhclo"):
        polyfit.onefit_simulate(tmp_path / "no_such_garment.mhclo", WALK, tmp_path, body_dir=BODY, **CLIP)
    with pytest.raises(polyfit.Error, match="num_frames"):
        polyfit.onefit_simulate(SUIT, WALK, tmp_path, body_dir=BODY, num_frames=0)
    with pytest.raises(TypeError, match="no field 'frames'"):
        polyfit.onefit_simulate(SUIT, WALK, tmp_path, body_dir=BODY, frames=2)
