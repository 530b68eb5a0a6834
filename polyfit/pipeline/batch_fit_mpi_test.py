"""`mpirun -n N polyfit fit`: the batch shared over ranks gives the reports
and outputs of one process, names a bad input while the others finish,
and resumes across a different number of ranks."""
import csv
import os
import subprocess

import pytest

import polyfit

BIN_DIR = os.environ.get("POLYFIT_BIN_DIR", "")
MPIEXEC = os.environ.get("MPIEXEC", "mpirun")
TIMING = {"time_s", "cluster_s", "fit_s"}


def mpirun(n, *args):
    command = [MPIEXEC, "--oversubscribe", "-n", str(n)]
    if os.geteuid() == 0:
        command.append("--allow-run-as-root")
    return subprocess.run(command + [os.path.join(BIN_DIR, "polyfit")] + list(args), capture_output=True, text=True)


def report(directory):
    with open(os.path.join(directory, "report.csv")) as f:
        return {row["name"]: row for row in csv.DictReader(f)}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    if not os.path.exists(os.path.join(BIN_DIR, "polyfit")):
        pytest.skip(f"polyfit is not built at {BIN_DIR}")
    directory = tmp_path_factory.mktemp("mpi") / "in"
    directory.mkdir()
    polyfit.write_ply(str(directory / "ball.ply"), polyfit.make_icosphere(4))
    polyfit.write_ply(str(directory / "torus.ply"), polyfit.make_bumpy_torus(96, 48))
    polyfit.write_obj(str(directory / "grid.obj"), polyfit.make_grid(30, 30))
    polyfit.write_ply(str(directory / "small_torus.ply"), polyfit.make_bumpy_torus(32, 16))
    (directory / "bad.obj").write_text("v 0 0 0\nf 1 2 3\n")
    return directory


def test_three_ranks_match_one_process_and_name_the_bad_mesh(inputs, tmp_path):
    run = mpirun(3, "fit", str(inputs), "--out", str(tmp_path / "mpi"), "--patches", "20")
    assert run.returncode == 6, run.stderr  # a batch with a failed input
    assert "4 fitted, 0 skipped, 1 failed" in run.stdout and "on 3 ranks" in run.stdout
    # Each input taken by exactly one rank (which ones depends on timing).
    taken = sorted(line.split()[4].rstrip(":") if "FAILED" not in line else "bad"
                   for line in run.stderr.splitlines() if line.startswith("rank "))
    assert taken == ["bad", "ball", "grid", "small_torus", "torus"]
    single = subprocess.run([os.path.join(BIN_DIR, "polyfit"), "fit", str(inputs), "--out", str(tmp_path / "one"),
                             "--patches", "20", "--threads", "1"], capture_output=True, text=True)
    assert single.returncode == 6
    shared, alone = report(tmp_path / "mpi"), report(tmp_path / "one")
    assert sorted(shared) == sorted(alone) == ["bad", "ball", "grid", "small_torus", "torus"]
    assert shared["bad"]["status"] == "failed" and "bad.obj" in shared["bad"]["error"]
    for name, row in shared.items():
        for key, value in row.items():
            if key not in TIMING:
                assert value == alone[name][key], f"{name}.{key}"
    for name in ("ball", "grid", "small_torus", "torus"):
        m = polyfit.load_model(str(tmp_path / "mpi" / f"{name}.pfm"))
        assert m.num_patches == 20


def test_a_rerun_on_two_ranks_resumes(inputs, tmp_path):
    first = mpirun(3, "fit", str(inputs), "--out", str(tmp_path), "--patches", "12")
    assert first.returncode == 6, first.stderr
    again = mpirun(2, "fit", str(inputs), "--out", str(tmp_path), "--patches", "12")
    assert again.returncode == 6, again.stderr
    assert "0 fitted, 4 skipped, 1 failed" in again.stdout
    rows = report(tmp_path)
    assert rows["torus"]["status"] == "skipped" and rows["torus"]["patches"] == "12"
