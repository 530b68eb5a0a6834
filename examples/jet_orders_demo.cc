// The README's first command: fit jets of orders 1 to 8 to a built-in
// surface and print error against time.
//
// The surface: 2,000 patches of the paper's summed family (4-jet + cosine +
// Gaussian + Bessel J0, see polyfit/synthetic/patch_families.h), 256 points
// each, under random rigid motion, noise sigma 0.01. Errors are against the
// noise-free surface.
#include <cstdio>
#include <vector>

#include "polyfit/eval/metrics.h"
#include "polyfit/patch/jet_fit.h"
#include "polyfit/synthetic/patch_families.h"

namespace {

void Report(const char* label, const polyfit::JetFitOptions& options, const polyfit::SyntheticPatchSet& set) {
  std::vector<polyfit::JetPatch> patches;
  const polyfit::JetFitSummary summary =
      polyfit::FitJetPatches(options, set.points_in_world, set.offsets, nullptr, &patches);
  const polyfit::SurfaceErrorAccumulator error = polyfit::EvaluatePatchSet(set, patches);
  std::printf("| %-15s | %9.2f | %9.4f | %11.4f | %9.2f |\n", label, summary.total_time_s / summary.num_patches * 1e6,
              summary.rms_residual, error.height_rmse(), error.normal_error_deg());
}

}  // namespace

int main() {
  polyfit::SyntheticPatchOptions surface;
  surface.num_points = 256;
  surface.noise_sigma = 0.01;
  const polyfit::SyntheticPatchSet set = polyfit::GenerateSyntheticPatchSet(surface, 2000, 2026);
  std::printf(
      "PolyFit: n-jets fitted to %zu patches x %d points (summed family, noise %.2g), "
      "all threads\n\n",
      set.patches.size(), surface.num_points, surface.noise_sigma);
  std::printf("| %-15s | %9s | %9s | %11s | %9s |\n", "fit", "us/patch", "residual", "height RMSE", "normal deg");
  std::printf("|-----------------|-----------|-----------|-------------|-----------|\n");
  polyfit::JetFitOptions options;
  char label[32];
  for (int order = 1; order <= polyfit::kMaxJetOrder; ++order) {
    options.order = order;
    std::snprintf(label, sizeof(label), "order %d", order);
    Report(label, options, set);
  }
  options.order = 4;
  options.refine_orientation = true;
  Report("order 4 refined", options, set);
  return 0;
}
