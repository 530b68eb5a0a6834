// Batch-fits generated patches with the installed PolyFit core library.
#include <cstdio>

#include "polyfit/patch/jet_fit.h"
#include "polyfit/synthetic/patch_families.h"

int main() {
  polyfit::SyntheticPatchOptions patch_options;
  patch_options.num_points = 64;
  const polyfit::SyntheticPatchSet set = polyfit::GenerateSyntheticPatchSet(patch_options, 1000, 1);
  std::vector<polyfit::JetPatch> patches;
  const polyfit::JetFitSummary summary =
      polyfit::FitJetPatches(polyfit::JetFitOptions{}, set.points_in_world, set.offsets, nullptr, &patches);
  std::printf("%s\n", summary.BriefReport().c_str());
  return summary.num_patches == 1000 && summary.rms_residual < 0.5 ? 0 : 1;
}
