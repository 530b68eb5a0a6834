"""`mpirun -n 2 onefit train`: each mini-batch shared over two ranks takes
the steps one process takes (the losses of every batch agree), and only
rank 0 prints and writes."""
import csv
import os
import subprocess

import pytest

BIN_DIR = os.environ.get("POLYFIT_BIN_DIR", "")
MPIEXEC = os.environ.get("MPIEXEC", "mpirun")
DRAPE = os.path.join(os.environ.get("POLYFIT_SHARED_DATA_DIR", ""), "drape")
SUIT = os.path.join(DRAPE, "garments", "makehuman_cc0", "male_casualsuit02.mhclo")
WALK = os.path.join(DRAPE, "motion", "02_01.bvh")

pytestmark = pytest.mark.skipif(not os.path.exists(SUIT), reason=f"the shared drape data is not at {DRAPE}")


def train(out, ranks=None):
    command = [os.path.join(BIN_DIR, "onefit"), "train", "--body", os.path.join(DRAPE, "body"), "--garments", SUIT,
               "--motions", WALK, "--frames-per-clip", "8", "--batches", "3", "--batch-size", "3",
               "--iterations-per-batch", "2", "--threads", "1", "--warmup", "1", "--out", str(out)]
    if ranks:
        launcher = [MPIEXEC, "--oversubscribe", "-n", str(ranks)] + (["--allow-run-as-root"] if os.geteuid() == 0
                                                                      else [])
        command = launcher + command
    run = subprocess.run(command, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    with open(str(out) + ".csv") as f:
        return run.stdout, list(csv.DictReader(f))


def test_two_ranks_take_the_steps_of_one_process(tmp_path):
    _, alone = train(tmp_path / "one.pfonefit")
    printed, shared = train(tmp_path / "two.pfonefit", ranks=2)
    assert printed.count("batch    2") == 1 and "training on 2 ranks" in printed  # rank 0 alone prints
    assert len(shared) == len(alone) == 3
    for a, b in zip(alone, shared):
        for key in ("initial_loss_J", "final_loss_J"):
            assert float(b[key]) == pytest.approx(float(a[key]), rel=1e-7), (a["batch"], key)
    assert os.path.getsize(tmp_path / "two.pfonefit") == os.path.getsize(tmp_path / "one.pfonefit")
