"""A killed `polysft` or `onefit simulate` leaves complete files or none.

Each command is killed (SIGKILL: no handler runs) at every file it writes,
at the worst moment (the file filled, not yet renamed: the crash injection
POLYFIT_KILL_AT_WRITE of polyfit/util/atomic_file.h), and at seeded random
moments. After every kill each file in the output folder must be complete
(every PLY as long as its header says, JSON that parses, CSV whose last
line ends) or be one of the atomic writer's temporaries; the next run must
say what the killed one left, remove those temporaries and finish with
complete outputs.
"""
import json
import os
import random
import re
import signal
import subprocess
import time

import pytest

BIN_DIR = os.environ.get("POLYFIT_BIN_DIR", "")
DRAPE = os.path.join(os.environ.get("POLYFIT_SHARED_DATA_DIR", "../shared/data"), "drape")
TEMPORARY = re.compile(r".+\.tmp[0-9]+_[0-9]+$")
KILLS = 8
PLY_TYPES = {"char": 1, "uchar": 1, "short": 2, "ushort": 2, "int": 4, "uint": 4, "float": 4, "double": 8}


def binary(name):
    path = os.path.join(BIN_DIR, name)
    if not os.path.exists(path):
        pytest.skip(f"{name} is not built at {BIN_DIR}")
    return path


def check_ply(path):
    """A binary little-endian PLY as PolyFit writes it: triangles only."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().split("\n")
    vertex_bytes, counts, element = 0, {}, None
    for line in header:
        words = line.split()
        if words[:1] == ["element"]:
            element = words[1]
            counts[element] = int(words[2])
        elif words[:1] == ["property"] and element == "vertex":
            vertex_bytes += PLY_TYPES[words[1]]
    expected = end + counts["vertex"] * vertex_bytes + counts.get("face", 0) * 13
    assert len(data) == expected, f"{path}: {len(data)} bytes, its header says {expected}"


def check_folder(folder):
    """Every file complete or a temporary; returns (files, temporaries)."""
    files, temporaries = 0, 0
    for root, _, names in os.walk(folder):
        for name in names:
            path = os.path.join(root, name)
            if TEMPORARY.match(name):
                temporaries += 1
                continue
            files += 1
            if name.endswith(".ply"):
                check_ply(path)
            elif name.endswith(".json"):
                json.load(open(path))
            elif name.endswith(".csv") or name.endswith(".md"):
                text = open(path).read()
                assert text.endswith("\n"), f"{path} ends mid-line"
    return files, temporaries


def kill_at_every_write(command, out, writes):
    """Kills `command` at its 1st, 2nd, ... write: each leaves one temporary."""
    for n in range(1, writes + 1):
        environment = dict(os.environ, POLYFIT_KILL_AT_WRITE=str(n))
        result = subprocess.run(command, env=environment, capture_output=True, text=True)
        assert result.returncode == -signal.SIGKILL, result.stdout + result.stderr
        files, temporaries = check_folder(out)
        assert temporaries == 1, f"killed at write {n}: {temporaries} temporaries"


def kill_at_random(command, out, seconds, seed):
    """Kills `command` after seeded random times, most near the end of a run."""
    rng = random.Random(seed)
    for k in range(KILLS):
        delay = seconds * (rng.uniform(0.0, 1.0) if k % 4 == 0 else rng.uniform(0.8, 1.1))
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(delay)
        process.send_signal(signal.SIGKILL)
        process.wait()
        check_folder(out)


def finish(command, out, marker):
    files_before, _ = check_folder(out)
    result = subprocess.run(command, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr
    if files_before:
        assert re.search(r"an earlier run (finished|was interrupted) here", result.stdout), result.stdout
    files, temporaries = check_folder(out)
    assert temporaries == 0
    assert os.path.exists(os.path.join(out, marker))
    return result.stdout


def timed(command, out):
    """Seconds a run takes, and how many files it writes."""
    start = time.monotonic()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.monotonic() - start, check_folder(out)[0]


def test_polysft_killed_at_random_leaves_complete_files(tmp_path):
    polysft = binary("polysft")
    scene = str(tmp_path / "scene")
    subprocess.run([polysft, "generate", "--out", scene, "--frames", "4", "--width", "96", "--height", "72",
                    "--focal", "86", "--grid-x", "8", "--grid-y", "6"], check=True, stdout=subprocess.DEVNULL)
    def command(out):
        return [polysft, "--scene", scene, "--out", out, "--threads", "1"]

    out = str(tmp_path / "out")
    seconds, writes = timed(command(str(tmp_path / "timing")), str(tmp_path / "timing"))
    kill_at_every_write(command(out), out, writes)
    finish(command(out), out, "metrics.json")
    kill_at_random(command(out), out, seconds, seed=1)
    stdout = finish(command(out), out, "metrics.json")
    assert "4 frames" in stdout
    assert len(os.listdir(os.path.join(out, "meshes"))) == 4


def test_onefit_simulate_killed_at_random_leaves_complete_files(tmp_path):
    onefit = binary("onefit")
    body = os.path.join(DRAPE, "body")
    if not os.path.isdir(body):
        pytest.skip(f"no MakeHuman body at {body} (../shared/data)")
    garment = os.path.join(DRAPE, "garments", "makehuman_cc0", "skirthelper.mhclo")

    def command(out):
        return [onefit, "simulate", "--body", body, "--garment", garment, "--motion",
                os.path.join(DRAPE, "motion", "02_01.bvh"), "--out", out, "--frames", "4", "--lead-in", "2",
                "--render-every", "2", "--threads", "1"]

    out = str(tmp_path / "out")
    seconds, writes = timed(command(str(tmp_path / "timing")), str(tmp_path / "timing"))
    kill_at_every_write(command(out), out, writes)
    finish(command(out), out, "metrics.json")
    kill_at_random(command(out), out, seconds, seed=2)
    finish(command(out), out, "metrics.json")
    assert len([n for n in os.listdir(os.path.join(out, "meshes")) if n.startswith("frame")]) == 4
