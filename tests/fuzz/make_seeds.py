#!/usr/bin/python3
"""Writes the fuzz targets' seed corpora into tests/fuzz/corpus/<target>/.

Small files, each a valid input or one step from one, written here by hand
or made by PolyFit's own generators and writers (a build's bin/ folder):
nothing from ../shared/data is copied. Deterministic; rerun after a format
changes, then commit the result.

    /usr/bin/python3 tests/fuzz/make_seeds.py build
"""
import gzip
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "corpus")
DATA = os.path.join(HERE, "..", "data")
# Read where it is, never copied (a clip on the CMU rig the procedural body shares).
SHARED_CLIP = os.path.join(HERE, "..", "..", "..", "shared", "data", "drape", "motion", "02_01.bvh")


def put(target, name, content):
    folder = os.path.join(CORPUS, target)
    os.makedirs(folder, exist_ok=True)
    if isinstance(content, str):
        content = content.encode()
    with open(os.path.join(folder, name), "wb") as f:
        f.write(content)


# A tetrahedron and a unit square, the shapes every mesh seed is made of.
TET_V = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
TET_F = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def obj_seeds(target):
    v = "".join("v %g %g %g\n" % p for p in TET_V)
    put(target, "tet.obj", v + "".join("f %d %d %d\n" % tuple(i + 1 for i in f) for f in TET_F))
    put(target, "tet_negative.obj", v + "".join("f %d %d %d\n" % tuple(i - 4 for i in f) for f in TET_F))
    put(target, "quad_uv_normals.obj",
        "# a square\nmtllib none.mtl\no sheet\ng part\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nusemtl cloth\ns 1\nf 1/1/1 2/2/1 3/3/1 4/4/1\n")
    put(target, "slashes.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1//1 2//1 3//1\nf 1/1 2/1 3/1\n")
    put(target, "bad_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    put(target, "nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")


def ply_header(fmt, n_vertices, n_faces, vertex_type="float", extra=""):
    return ("ply\nformat %s 1.0\ncomment seed\nelement vertex %d\nproperty %s x\nproperty %s y\n"
            "property %s z\n%selement face %d\nproperty list uchar int vertex_indices\nend_header\n"
            % (fmt, n_vertices, vertex_type, vertex_type, vertex_type, extra, n_faces))


def ply_seeds(target):
    ascii_body = "".join("%g %g %g\n" % p for p in TET_V) + "".join("3 %d %d %d\n" % f for f in TET_F)
    put(target, "tet_ascii.ply", ply_header("ascii", 4, 4) + ascii_body)
    little = b"".join(struct.pack("<fff", *p) for p in TET_V) + b"".join(struct.pack("<Biii", 3, *f) for f in TET_F)
    put(target, "tet_little.ply", ply_header("binary_little_endian", 4, 4).encode() + little)
    big = b"".join(struct.pack(">ddd", *p) for p in TET_V) + b"".join(struct.pack(">Biii", 3, *f) for f in TET_F)
    put(target, "tet_big_double.ply", ply_header("binary_big_endian", 4, 4, "double").encode() + big)
    extra = "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    colour = "".join("%g %g %g 200 10 10\n" % p for p in TET_V) + "".join("3 %d %d %d\n" % f for f in TET_F)
    put(target, "tet_colour.ply", ply_header("ascii", 4, 4, "float", extra) + colour)
    put(target, "huge_count.ply", ply_header("ascii", 10000000, 1) + "0 0 0\n")


def off_seeds(target):
    body = "".join("%g %g %g\n" % p for p in TET_V) + "".join("3 %d %d %d\n" % f for f in TET_F)
    put(target, "tet.off", "OFF\n4 4 6\n" + body)
    with open(os.path.join(DATA, "octahedron.off"), "rb") as f:
        put(target, "octahedron.off", f.read())
    put(target, "quad.off", "OFF\n# a square\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n")
    put(target, "coff.off", "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2\n")


def normal(f):
    a, b, c = (TET_V[i] for i in f)
    u = [b[k] - a[k] for k in range(3)]
    w = [c[k] - a[k] for k in range(3)]
    return (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])


def stl_seeds(target):
    text = "solid tet\n"
    for f in TET_F:
        text += " facet normal %g %g %g\n  outer loop\n" % normal(f)
        text += "".join("   vertex %g %g %g\n" % TET_V[i] for i in f)
        text += "  endloop\n endfacet\n"
    put(target, "tet_ascii.stl", text + "endsolid tet\n")
    binary = b"seed".ljust(80, b" ") + struct.pack("<I", len(TET_F))
    for f in TET_F:
        binary += struct.pack("<3f", *normal(f))
        for i in f:
            binary += struct.pack("<3f", *TET_V[i])
        binary += struct.pack("<H", 0)
    put(target, "tet_binary.stl", binary)


def ply_vertices_seeds(target):
    ply_seeds(target)
    put(target, "points_only.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\n"
        "property double y\nproperty double z\nproperty float confidence\nend_header\n0 0 0 1\n1 2 3 0.5\n")


def body_seeds(target):
    put(target, "0_groups.obj", b"\0" + b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\ng body\nf 1 2 3\n"
        b"g joint-hips\nf 1 2 4\nf 1/1/1 3/3/3 4/4/4\n")
    rig = {"Hips": {"head": {"strategy": "CUBE", "cube_name": "joint-pelvis"}, "parent": ""},
           "LHipJoint": {"head": {"strategy": "MEAN", "vertex_indices": [1, 2, 3]}, "parent": "Hips"}}
    put(target, "1_rig.json", b"\1" + json.dumps(rig, indent=1).encode())
    weights = {"weights": {"Hips": [[0, 1.0], [1, 0.5]], "LHipJoint": [[1, 0.5], [2, 1.0]]}}
    put(target, "2_weights.json", b"\2" + json.dumps(weights, indent=1).encode())
    put(target, "3_target.gz", b"\3" + gzip.compress(b"# seed\n0 0.1 0.2 0.3\n17 -0.5 0 1e-3\n", mtime=0))
    put(target, "3_target_bad.gz", b"\3" + gzip.compress(b"0 0.1 0.2\n", mtime=0))


def run(*args):
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def generated_seeds(build):
    bin_dir = os.path.join(build, "bin")
    with tempfile.TemporaryDirectory() as tmp:
        # .pfm: a fit of the octahedron into two low-order patches.
        run(os.path.join(bin_dir, "polyfit"), "fit", os.path.join(DATA, "octahedron.off"), "--out", tmp,
            "--patches", "2", "--order", "2", "--min-vertices-per-patch", "3", "--no-eval")
        shutil.copy(os.path.join(tmp, "octahedron.pfm"), os.path.join(CORPUS, "pfm_fuzzer", "octahedron.pfm"))
        # scene.json: a small generated scene's, with and without masks.
        for masks in (True, False):
            scene = os.path.join(tmp, "scene_%d" % masks)
            run(os.path.join(bin_dir, "polysft"), "generate", "--out", scene, "--frames", "3", "--width", "32",
                "--height", "24", "--grid-x", "6", "--grid-y", "4", *([] if masks else ["--no-masks"]))
            shutil.copy(os.path.join(scene, "scene.json"),
                        os.path.join(CORPUS, "scene_fuzzer", "scene%s.json" % ("" if masks else "_no_masks")))
        # polysft --config: every setting (a run's metrics.json), and the test's bad file.
        scene = os.path.join(tmp, "scene_1")
        out = os.path.join(tmp, "out")
        run(os.path.join(bin_dir, "polysft"), "--scene", scene, "--out", out, "--max-frames", "1")
        with open(os.path.join(out, "metrics.json")) as f:
            settings = json.load(f)["settings"]
        put("polysft_config_fuzzer", "settings.json", json.dumps(settings, indent=1))
        put("polysft_config_fuzzer", "metrics_like.json", json.dumps({"settings": {"pyramid_levels": 2}}))
        shutil.copy(os.path.join(DATA, "bad_sft_config.json"),
                    os.path.join(CORPUS, "polysft_config_fuzzer", "bad_sft_config.json"))
        # A tiny OneFit model: the procedural body, layers of width 4.
        model = os.path.join(tmp, "tiny.pfonefit")
        clip = SHARED_CLIP  # the seeds' own rig names no joint of the body's
        garment = os.path.join(tmp, "square.obj")
        with open(garment, "w") as f:
            f.write("v -0.1 1.0 0.2\nv 0.1 1.0 0.2\nv 0.1 1.2 0.2\nv -0.1 1.2 0.2\nf 1 2 3\nf 1 3 4\n")
        run(os.path.join(bin_dir, "onefit"), "train", "--garments", garment, "--motions", clip, "--out", model,
            "--batches", "1", "--batch-size", "1", "--decoder-hidden", "4", "--body-hidden", "4",
            "--patch-hidden", "4", "--validate-every", "0", "--patch-area", "1")
        shutil.copy(model, os.path.join(CORPUS, "onefit_model_fuzzer", "tiny.pfonefit"))
        # The same with a joint mask (file version 9's last header field set).
        run(os.path.join(bin_dir, "onefit"), "train", "--garments", garment, "--motions", clip, "--out", model,
            "--batches", "1", "--batch-size", "1", "--decoder-hidden", "4", "--body-hidden", "4",
            "--patch-hidden", "4", "--validate-every", "0", "--patch-area", "1", "--joint-mask-reach", "0.5")
        shutil.copy(model, os.path.join(CORPUS, "onefit_model_fuzzer", "tiny_joint_mask.pfonefit"))
        # A warp head of order 3 under a slide bound (file version 10's last header field set).
        run(os.path.join(bin_dir, "onefit"), "train", "--garments", garment, "--motions", clip, "--out", model,
            "--batches", "1", "--batch-size", "1", "--decoder-hidden", "4", "--body-hidden", "4",
            "--patch-hidden", "4", "--validate-every", "0", "--patch-area", "1", "--warp-order", "3",
            "--warp-slide-bound", "0.5")
        shutil.copy(model, os.path.join(CORPUS, "onefit_model_fuzzer", "tiny_slide_bound.pfonefit"))
        # The body proximity read by the decoder (the corpus keeps the file version 11 wrote).
        run(os.path.join(bin_dir, "onefit"), "train", "--garments", garment, "--motions", clip, "--out", model,
            "--batches", "1", "--batch-size", "1", "--decoder-hidden", "4", "--body-hidden", "4",
            "--patch-hidden", "4", "--validate-every", "0", "--patch-area", "1", "--body-proximity")
        shutil.copy(model, os.path.join(CORPUS, "onefit_model_fuzzer", "tiny_body_proximity.pfonefit"))
        # Nine probes (file version 12's last header field).
        run(os.path.join(bin_dir, "onefit"), "train", "--garments", garment, "--motions", clip, "--out", model,
            "--batches", "1", "--batch-size", "1", "--decoder-hidden", "4", "--body-hidden", "4",
            "--patch-hidden", "4", "--validate-every", "0", "--patch-area", "1", "--body-proximity",
            "--proximity-probes", "9")
        shutil.copy(model, os.path.join(CORPUS, "onefit_model_fuzzer", "tiny_rim_probes.pfonefit"))
        # A feedback decoder after the decoder (file version 13's last header field and a fourth MLP).
        run(os.path.join(bin_dir, "onefit"), "train", "--garments", garment, "--motions", clip, "--out", model,
            "--batches", "1", "--batch-size", "1", "--decoder-hidden", "4", "--body-hidden", "4",
            "--patch-hidden", "4", "--validate-every", "0", "--patch-area", "1", "--body-proximity",
            "--feedback", "--feedback-hidden", "4")
        shutil.copy(model, os.path.join(CORPUS, "onefit_model_fuzzer", "tiny_feedback.pfonefit"))


def main():
    build = sys.argv[1] if len(sys.argv) > 1 else "build"
    for fmt, seeds in (("obj", obj_seeds), ("ply", ply_seeds), ("off", off_seeds), ("stl", stl_seeds)):
        seeds("mesh_%s_fuzzer" % fmt)
    obj_seeds("obj_template_fuzzer")
    ply_vertices_seeds("ply_vertices_fuzzer")
    # The BVH and .mhclo seeds are written by tests/fuzz/CMakeLists.txt.
    body_seeds("makehuman_body_fuzzer")
    generated_seeds(build)


if __name__ == "__main__":
    main()
