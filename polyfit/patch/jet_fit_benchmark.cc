// Jet fitting against CGAL's Monge_via_jet_fitting (d_fitting = d_monge = 4)
// on the same generated patches (summed family, random rigid motion):
// microseconds per patch on one thread, patches per second on two, height
// RMSE and normal error against the noise-free surface. Prints Markdown.
//
//   jet_fit_benchmark [--scale F] [--no-ceres]
//
// --scale multiplies the patch counts (default 1: 20,000 patches at M <= 64).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <CGAL/Monge_via_jet_fitting.h>
#include <CGAL/Simple_cartesian.h>

#include "polyfit/eval/metrics.h"
#include "polyfit/patch/jet_fit.h"
#include "polyfit/synthetic/patch_families.h"

namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Monge = CGAL::Monge_via_jet_fitting<Kernel>;

double Seconds(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// CGAL's Monge form as a JetPatch: z = 1/2 (k1 x^2 + k2 y^2)
// + 1/6 (b0 x^3 + 3 b1 x^2 y + 3 b2 x y^2 + b3 y^3)
// + 1/24 (c0 x^4 + 4 c1 x^3 y + 6 c2 x^2 y^2 + 4 c3 x y^3 + c4 y^4)
// in the frame (origin; d1, d2, n).
polyfit::JetPatch MongeToJetPatch(const Monge::Monge_form& monge) {
  using polyfit::JetCoefficientIndex;
  polyfit::JetPatch patch;
  patch.order = 4;
  const auto o = monge.origin();
  const auto d1 = monge.maximal_principal_direction();
  const auto d2 = monge.minimal_principal_direction();
  const auto n = monge.normal_direction();
  patch.frame.translation = Eigen::Vector3d(o.x(), o.y(), o.z());
  patch.frame.rotation.col(0) = Eigen::Vector3d(d1.x(), d1.y(), d1.z());
  patch.frame.rotation.col(1) = Eigen::Vector3d(d2.x(), d2.y(), d2.z());
  patch.frame.rotation.col(2) = Eigen::Vector3d(n.x(), n.y(), n.z());
  const std::vector<double> c = monge.coefficients();
  auto& a = patch.coefficients;
  a[JetCoefficientIndex(2, 0)] = c[0] / 2;
  a[JetCoefficientIndex(0, 2)] = c[1] / 2;
  a[JetCoefficientIndex(3, 0)] = c[2] / 6;
  a[JetCoefficientIndex(2, 1)] = c[3] / 2;
  a[JetCoefficientIndex(1, 2)] = c[4] / 2;
  a[JetCoefficientIndex(0, 3)] = c[5] / 6;
  a[JetCoefficientIndex(4, 0)] = c[6] / 24;
  a[JetCoefficientIndex(3, 1)] = c[7] / 6;
  a[JetCoefficientIndex(2, 2)] = c[8] / 4;
  a[JetCoefficientIndex(1, 3)] = c[9] / 6;
  a[JetCoefficientIndex(0, 4)] = c[10] / 24;
  return patch;
}

// CGAL's own least-squares jet, before its Monge re-expansion: the same
// PCA, matrix fill and SVD solve as Monge_via_jet_fitting::operator(), read
// out through the protected members. Basis x^a y^b / (a! b!) in the PCA
// frame with the first point as origin.
class CgalInternalJet : public Monge {
 public:
  template <typename It>
  polyfit::JetPatch Fit(It begin, It end, int d) {
    deg = d;
    deg_monge = d;
    nb_d_jet_coeff = (d + 1) * (d + 2) / 2;
    nb_input_pts = static_cast<int>(end - begin);
    LAMatrix m(nb_input_pts, nb_d_jet_coeff);
    LAVector z(nb_input_pts);
    compute_PCA(begin, end);
    fill_matrix(begin, end, d, m, z);
    solve_linear_system(m, z);
    polyfit::JetPatch patch;
    patch.order = d;
    const auto& p0 = *begin;
    patch.frame.translation = Eigen::Vector3d(p0.x(), p0.y(), p0.z());
    for (int c = 0; c < 3; ++c) {
      const auto axis = pca_basis(c).second;
      patch.frame.rotation.col(c) = Eigen::Vector3d(axis.x(), axis.y(), axis.z());
    }
    double factorial[9] = {1, 1, 2, 6, 24, 120, 720, 5040, 40320};
    for (int k = 0; k <= d; ++k) {
      for (int i = 0; i <= k; ++i) {
        patch.coefficients[polyfit::JetCoefficientIndex(k - i, i)] =
            z(k * (k + 1) / 2 + i) / (factorial[i] * factorial[k - i]);
      }
    }
    return patch;
  }
};

struct Row {
  std::string method;
  double us_per_patch = 0, patches_per_s_2t = 0, height_rmse = 0, normal_deg = 0;
};

// Two rows: CGAL's call (timed) and its internal least-squares jet.
std::vector<Row> RunCgal(const polyfit::SyntheticPatchSet& set, int repeats) {
  const int n = static_cast<int>(set.patches.size());
  std::vector<std::vector<Kernel::Point_3>> inputs(n);
  for (int p = 0; p < n; ++p) {
    const auto& pts = set.patches[p].points_in_world;
    for (int i = 0; i < pts.cols(); ++i) inputs[p].emplace_back(pts(0, i), pts(1, i), pts(2, i));
  }
  std::vector<polyfit::JetPatch> patches(n), internal(n);
  for (int p = 0; p < n; ++p) internal[p] = CgalInternalJet().Fit(inputs[p].begin(), inputs[p].end(), 4);
  const auto internal_acc = polyfit::EvaluatePatchSet(set, internal);
  double best = 1e30;
  for (int r = 0; r < repeats; ++r) {
    const auto start = std::chrono::steady_clock::now();
    for (int p = 0; p < n; ++p) {
      Monge fitter;
      const Monge::Monge_form form = fitter(inputs[p].begin(), inputs[p].end(), 4, 4);
      if (r == 0) patches[p] = MongeToJetPatch(form);
    }
    best = std::min(best, Seconds(start));
  }
  const auto acc = polyfit::EvaluatePatchSet(set, patches);
  return {
      {"CGAL Monge_via_jet_fitting (4,4)", best / n * 1e6, 0.0, acc.height_rmse(), acc.normal_error_deg()},
      {"CGAL internal LS jet (accuracy only)", 0.0, 0.0, internal_acc.height_rmse(), internal_acc.normal_error_deg()}};
}

Row RunPolyFit(const std::string& name, polyfit::JetFitOptions options, const polyfit::SyntheticPatchSet& set,
               int repeats) {
  const int n = static_cast<int>(set.patches.size());
  std::vector<polyfit::JetPatch> patches;
  Row row;
  row.method = name;
  double best1 = 1e30, best2 = 1e30;
  for (int r = 0; r < repeats; ++r) {
    options.num_threads = 1;
    best1 = std::min(best1,
                     polyfit::FitJetPatches(options, set.points_in_world, set.offsets, nullptr, &patches).total_time_s);
    options.num_threads = 2;
    best2 = std::min(best2,
                     polyfit::FitJetPatches(options, set.points_in_world, set.offsets, nullptr, &patches).total_time_s);
  }
  const auto acc = polyfit::EvaluatePatchSet(set, patches);
  row.us_per_patch = best1 / n * 1e6;
  row.patches_per_s_2t = n / best2;
  row.height_rmse = acc.height_rmse();
  row.normal_deg = acc.normal_error_deg();
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  double scale = 1.0;
  bool with_ceres = true;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--scale") && i + 1 < argc) {
      scale = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--no-ceres")) {
      with_ceres = false;
    } else {
      std::fprintf(stderr, "usage: %s [--scale F] [--no-ceres]\n", argv[0]);
      return 2;
    }
  }
  std::printf(
      "| M | noise | method | us/patch (1 thread) | patches/s (2 threads) | height RMSE | normal error (deg) |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (int m : {32, 64, 256, 1024}) {
    const int count = std::max(100, static_cast<int>(scale * (m <= 64 ? 20000 : m == 256 ? 5000 : 2000)));
    for (double noise : {0.0, 0.01}) {
      polyfit::SyntheticPatchOptions sopt;
      sopt.num_points = m;
      sopt.noise_sigma = noise;
      const auto set = polyfit::GenerateSyntheticPatchSet(sopt, count, 1000 + m);
      std::vector<Row> rows = RunCgal(set, 1);
      polyfit::JetFitOptions options;
      rows.push_back(RunPolyFit("PolyFit", options, set, 3));
      options.refine_orientation = true;
      rows.push_back(RunPolyFit("PolyFit + refinement (var-pro LM)", options, set, 3));
      if (with_ceres) {
        options.refinement.solver = polyfit::OrientationSolver::kCeres;
        rows.push_back(RunPolyFit("PolyFit + refinement (Ceres)", options, set, 1));
      }
      for (const Row& r : rows) {
        std::printf("| %d | %.2g | %s | %s | %s | %.4f | %.2f |\n", m, noise, r.method.c_str(),
                    r.us_per_patch > 0 ? std::to_string(r.us_per_patch).substr(0, 6).c_str() : "-",
                    r.patches_per_s_2t > 0 ? std::to_string(static_cast<long>(r.patches_per_s_2t)).c_str() : "-",
                    r.height_rmse, r.normal_deg);
      }
      std::fflush(stdout);
    }
  }
  return 0;
}
