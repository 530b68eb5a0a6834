"""`onefit train --average-batches N --resume`: a run extended from a
finished one (its model the weights' average, the stepped weights beside
Adam's moments) ends byte for byte where a straight run of as many batches
ends, given a schedule that does not depend on the number of batches (a
constant step, k_ext's allowance held)."""
import os
import subprocess

import pytest

BIN_DIR = os.environ.get("POLYFIT_BIN_DIR", "")
DRAPE = os.path.join(os.environ.get("POLYFIT_SHARED_DATA_DIR", ""), "drape")
SKIRT = os.path.join(DRAPE, "garments", "makehuman_cc0", "skirthelper.mhclo")
WALK = os.path.join(DRAPE, "motion", "02_01.bvh")

pytestmark = pytest.mark.skipif(not os.path.exists(SKIRT), reason=f"the shared drape data is not at {DRAPE}")


def train(out, batches, resume=False):
    command = [os.path.join(BIN_DIR, "onefit"), "train", "--body", os.path.join(DRAPE, "body"), "--garments", SKIRT,
               "--motions", WALK, "--frames-per-clip", "8", "--batches", str(batches), "--batch-size", "2",
               "--iterations-per-batch", "2", "--threads", "1", "--validate-every", "0", "--average-batches", "2",
               "--final-rate", "1", "--kext-final-epoch", "0", "--out", str(out)] + (["--resume"] if resume else [])
    run = subprocess.run(command, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return run.stdout


def read(path):
    with open(path, "rb") as f:
        return f.read()


def test_an_averaged_run_extended_ends_where_a_straight_run_ends(tmp_path):
    straight, split = tmp_path / "straight.pfonefit", tmp_path / "split.pfonefit"
    train(straight, 4)
    train(split, 2)
    assert "resumed at batch 2" in train(split, 4, resume=True)
    assert read(split) == read(straight)
    assert read(str(split) + ".adam") == read(str(straight) + ".adam")
