"""polyfit (the _core module): values against closed forms and against the
C++ command line on the same inputs."""
import copy
import json
import os
import subprocess
import sys
import threading

import numpy as np
import pytest

import polyfit

BIN_DIR = os.environ.get("POLYFIT_BIN_DIR", "")


def monomial_sum(order, alpha, u, v):
    return sum(alpha[polyfit.jet_coefficient_index(a, d - a)] * u**a * v**(d - a)
               for d in range(order + 1) for a in range(d + 1))


# ------------------------------------------------------------------ jets

def test_jet_height_is_the_monomial_sum():
    rng = np.random.default_rng(1)
    order = 4
    alpha = rng.normal(size=polyfit.num_jet_coefficients(order))
    u, v = rng.uniform(-1, 1, 50), rng.uniform(-1, 1, 50)
    np.testing.assert_allclose(polyfit.jet_height(order, alpha, u, v), monomial_sum(order, alpha, u, v), rtol=1e-13)
    np.testing.assert_allclose(polyfit.jet_monomials(order, u, v) @ alpha, monomial_sum(order, alpha, u, v),
                               rtol=1e-13)
    assert polyfit.jet_height(order, alpha, 0.3, -0.2).shape == ()
    assert polyfit.num_jet_coefficients(4) == 15 and polyfit.num_jet_coefficients(8) == 45


def test_jet_derivatives_match_central_differences():
    rng = np.random.default_rng(2)
    order, h = 5, 1e-5
    alpha = rng.normal(size=polyfit.num_jet_coefficients(order))
    u, v = rng.uniform(-1, 1, 20), rng.uniform(-1, 1, 20)
    d = polyfit.jet_derivatives(order, alpha, u, v)

    def z(a, b):
        return polyfit.jet_height(order, alpha, a, b)

    np.testing.assert_allclose(d["z"], z(u, v), rtol=1e-14)
    np.testing.assert_allclose(d["z_u"], (z(u + h, v) - z(u - h, v)) / (2 * h), atol=1e-7)
    np.testing.assert_allclose(d["z_v"], (z(u, v + h) - z(u, v - h)) / (2 * h), atol=1e-7)
    zu = lambda a, b: polyfit.jet_derivatives(order, alpha, a, b)["z_u"]  # noqa: E731
    zv = lambda a, b: polyfit.jet_derivatives(order, alpha, a, b)["z_v"]  # noqa: E731
    np.testing.assert_allclose(d["z_uu"], (zu(u + h, v) - zu(u - h, v)) / (2 * h), atol=1e-6)
    np.testing.assert_allclose(d["z_uv"], (zu(u, v + h) - zu(u, v - h)) / (2 * h), atol=1e-6)
    np.testing.assert_allclose(d["z_vv"], (zv(u, v + h) - zv(u, v - h)) / (2 * h), atol=1e-6)


def test_jet_curvatures_of_a_paraboloid_at_its_apex():
    # z = (u^2 + v^2) / 2 has principal curvatures 1 and 1 at the origin.
    alpha = np.zeros(polyfit.num_jet_coefficients(2))
    alpha[polyfit.jet_coefficient_index(2, 0)] = 0.5
    alpha[polyfit.jet_coefficient_index(0, 2)] = 0.5
    gaussian, mean = polyfit.jet_curvatures(2, alpha, 0.0, 0.0)
    assert gaussian == pytest.approx(1.0, abs=1e-14)
    assert abs(mean) == pytest.approx(1.0, abs=1e-14)


def test_jet_arguments_are_checked_with_named_errors():
    with pytest.raises(ValueError, match="15 coefficients"):
        polyfit.jet_height(4, np.zeros(10), 0.0, 0.0)
    with pytest.raises(ValueError, match="differ in size"):
        polyfit.jet_height(1, np.zeros(3), np.zeros(3), np.zeros(4))
    with pytest.raises(ValueError, match="order must be in"):
        polyfit.jet_height(9, np.zeros(55), 0.0, 0.0)


# ------------------------------------------------------------------ fitting

def rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def test_fit_jet_patches_recovers_known_surfaces():
    # Surfaces even in u and in v over a symmetric grid: their principal
    # axes are the grid's, so PCA finds the generating frame and a 4-jet
    # holds them exactly, whatever the rigid motion and scale.
    rng = np.random.default_rng(3)
    u, v = [g.ravel() for g in np.meshgrid(np.linspace(-1, 1, 15), np.linspace(-0.7, 0.7, 11))]
    points, offsets, truths = [], [0], []
    for p in range(3):
        alpha = np.zeros(polyfit.num_jet_coefficients(4))
        for a, b in [(0, 0), (2, 0), (0, 2), (4, 0), (2, 2), (0, 4)]:
            alpha[polyfit.jet_coefficient_index(a, b)] = rng.normal(scale=0.1)
        local = np.stack([u, v, monomial_sum(4, alpha, u, v)], axis=1)
        r, t = rotation(rng.normal(size=3), 0.3 + p), rng.normal(size=3)
        world = (0.5 + p) * local @ r.T + t
        points.append(world)
        offsets.append(offsets[-1] + len(world))
        truths.append(world)
    patches, summary = polyfit.fit_jet_patches(np.concatenate(points), offsets, num_threads=2)
    assert summary.num_patches == 3 and summary.num_points == 3 * len(u)
    assert summary.rms_residual < 1e-9
    for patch, world in zip(patches, truths):
        in_patch = patch.frame.point_to_patch(world)
        np.testing.assert_allclose(patch.height(in_patch[:, 0], in_patch[:, 1]), in_patch[:, 2], atol=1e-9)
        np.testing.assert_allclose(patch.point_in_world(in_patch[:, 0], in_patch[:, 1]), world, atol=1e-9)
        assert patch.flag_names == "ok"
    with pytest.raises(ValueError, match="weights"):
        polyfit.fit_jet_patches(np.concatenate(points), offsets, weights=np.ones(5))
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        polyfit.fit_jet_patches(np.zeros((10, 2)), [0, 10])


def test_options_take_nested_keywords_and_name_unknown_ones():
    options = polyfit.make_options(polyfit.MeshFitOptions, jet_fit__order=3, **{"clustering.num_patches": 7})
    assert options.jet_fit.order == 3 and options.clustering.num_patches == 7
    assert polyfit.MeshFitOptions().jet_fit.order == 4  # the C++ default, untouched
    again = polyfit.make_options(polyfit.MeshFitOptions, options, evaluate=False)
    assert again.jet_fit.order == 3 and not again.evaluate and options.evaluate
    with pytest.raises(TypeError, match="no field 'odrer'"):
        polyfit.make_options(polyfit.MeshFitOptions, jet_fit__odrer=3)
    assert copy.deepcopy(options).clustering.num_patches == 7


# ------------------------------------------------------------------ meshes

def test_mesh_arrays_are_views_and_files_round_trip(tmp_path):
    mesh = polyfit.make_icosphere(2)
    vertices = mesh.vertices
    assert vertices.shape == (mesh.num_vertices, 3) and mesh.faces.shape == (mesh.num_faces, 3)
    assert mesh.faces.dtype == np.int32
    vertices[0, 0] = 2.0
    assert mesh.vertices[0, 0] == 2.0 and np.shares_memory(vertices, mesh.vertices)
    path = str(tmp_path / "sphere.ply")
    polyfit.write_ply(path, mesh)
    back = polyfit.read_mesh(path)
    # The reader may renumber vertices: compare the triangles' corners.
    assert back.num_faces == mesh.num_faces and back.num_vertices == mesh.num_vertices
    np.testing.assert_allclose(back.vertices[back.faces], mesh.vertices[mesh.faces], atol=1e-6)
    built = polyfit.TriangleMesh(back.vertices, back.faces)
    assert built.validate() == "" and built.surface_area() == pytest.approx(back.surface_area())
    with pytest.raises(ValueError, match="vertices"):
        polyfit.TriangleMesh(np.zeros((4, 2)), np.zeros((1, 3), np.int32))


def test_bad_files_raise_input_errors_naming_them(tmp_path):
    missing = str(tmp_path / "nothing_here.obj")
    with pytest.raises(polyfit.InputError, match="nothing_here.obj"):
        polyfit.read_mesh(missing)
    broken = tmp_path / "broken.obj"
    broken.write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    with pytest.raises(polyfit.Error, match="broken.obj"):
        polyfit.read_mesh(str(broken))
    with pytest.raises(polyfit.InputError, match="nope.pfm"):
        polyfit.load_model(str(tmp_path / "nope.pfm"))
    assert issubclass(polyfit.InvalidArgumentError, ValueError)


# ------------------------------------------------------------------ fit_mesh

@pytest.fixture(scope="module")
def torus_file(tmp_path_factory):
    path = str(tmp_path_factory.mktemp("torus") / "torus.ply")
    polyfit.write_ply(path, polyfit.make_bumpy_torus(48, 24))
    return path


def test_fit_mesh_equals_the_command_line(torus_file, tmp_path):
    cli = os.path.join(BIN_DIR, "polyfit")
    if not os.path.exists(cli):
        pytest.skip(f"the polyfit command line is not built at {cli}")
    model, recon, summary = polyfit.fit_mesh(torus_file, clustering__num_patches=24, num_threads=1)
    out = tmp_path / "cli"
    subprocess.run([cli, "fit", torus_file, "--out", str(out), "--patches", "24", "--threads", "1", "--force"],
                   check=True, capture_output=True)
    cli_model = polyfit.load_model(str(out / "torus.pfm"))
    cli_summary = json.loads((out / "torus.summary.json").read_text())
    assert model.num_patches == cli_model.num_patches == summary.clustering.num_patches == 24
    np.testing.assert_array_equal(model.face_patch, cli_model.face_patch)
    for a, b in zip(model.patches, cli_model.patches):
        assert a.order == b.order
        np.testing.assert_allclose(a.coefficients, b.coefficients, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(a.frame.rotation, b.frame.rotation, atol=1e-14)
    assert summary.chamfer == pytest.approx(cli_summary["chamfer"], rel=1e-12)
    assert summary.normal_error_deg == pytest.approx(cli_summary["normal_error_deg"], rel=1e-12)
    cli_recon = polyfit.read_mesh(str(out / "torus.recon.ply"))
    np.testing.assert_allclose(cli_recon.vertices, recon.vertices, atol=1e-6)
    # The model alone rebuilds the reconstruction, also after a save.
    model.save(str(tmp_path / "again.pfm"))
    vertices, rs = polyfit.load_model(str(tmp_path / "again.pfm")).reconstruct()
    np.testing.assert_allclose(vertices, recon.vertices, atol=1e-12)
    assert rs.num_boundary_vertices > 0


def test_fit_mesh_runs_in_threads_without_the_gil(torus_file):
    results = [None, None]

    def fit(i):
        results[i] = polyfit.fit_mesh(torus_file, clustering__num_patches=16, num_threads=1, evaluate=False)

    threads = [threading.Thread(target=fit, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    np.testing.assert_array_equal(results[0][1].vertices, results[1][1].vertices)


# ------------------------------------------------------------------ batch

def test_batch_fit_reports_a_bad_file_and_resumes(tmp_path):
    inputs = tmp_path / "in"
    inputs.mkdir()
    polyfit.write_ply(str(inputs / "a.ply"), polyfit.make_icosphere(2))
    polyfit.write_obj(str(inputs / "b.obj"), polyfit.make_bumpy_torus(24, 12))
    (inputs / "c.obj").write_text("this is not a mesh\n")
    seen = []
    summary = polyfit.fit_mesh_files(str(inputs), tmp_path / "out", progress=lambda d, t, item: seen.append((d, t)),
                                     fit__clustering__num_patches=10, fit__evaluation_samples=2000)
    assert (summary.num_fitted, summary.num_skipped, summary.num_failed) == (2, 0, 1)
    failed = [i for i in summary.items if i.status == polyfit.BatchItemStatus.FAILED]
    assert failed[0].name == "c" and "c.obj" in failed[0].error
    assert sorted(seen) == [(1, 3), (2, 3), (3, 3)]
    fitted = [i for i in summary.items if i.status == polyfit.BatchItemStatus.FITTED]
    assert all(i.summary.clustering.num_patches == 10 and i.summary.chamfer < 0.05 for i in fitted)
    assert (tmp_path / "out" / "report.csv").exists() and (tmp_path / "out" / "a.pfm").exists()
    again = polyfit.fit_mesh_files(str(inputs), tmp_path / "out", fit__clustering__num_patches=10)
    assert (again.num_fitted, again.num_skipped, again.num_failed) == (0, 2, 1)

    def stop(done, total, item):
        raise KeyboardInterrupt("stop")

    with pytest.raises(KeyboardInterrupt):
        polyfit.fit_mesh_files(str(inputs / "a.ply"), tmp_path / "out2", progress=stop)


def test_the_batch_fit_example_prints_its_table(tmp_path):
    script = os.path.join(os.environ.get("POLYFIT_SOURCE_DIR", ""), "examples", "python", "batch_fit.py")
    if not os.path.exists(script):
        pytest.skip(f"no example at {script}")
    inputs = tmp_path / "in"
    inputs.mkdir()
    polyfit.write_ply(str(inputs / "ball.ply"), polyfit.make_icosphere(3))
    (inputs / "junk.off").write_text("OFF\n3 1 0\n0 0 0\n")
    run = subprocess.run([sys.executable, script, str(inputs), "--out", str(tmp_path / "out"), "--patches", "12"],
                         capture_output=True, text=True)
    assert run.returncode == 1, run.stderr  # one input failed
    lines = {line.split()[0]: line.split() for line in run.stdout.splitlines() if line.strip()}
    assert lines["ball"][1] == "fitted" and int(lines["ball"][3]) == 12 and float(lines["ball"][4]) < 5.0
    assert lines["junk"][1] == "failed" and "junk.off" in run.stdout
    assert "[" in run.stderr and "2/2" in run.stderr  # the progress bar
