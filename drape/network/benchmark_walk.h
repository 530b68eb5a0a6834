// The case the drape benchmarks share: a garment (argv[2], default the
// male casual suit) on the neutral MakeHuman body walking (02_01), read
// from DATA_DIR (argv[1], default ../shared/data/drape).
#ifndef POLYFIT_DRAPE_NETWORK_BENCHMARK_WALK_H_
#define POLYFIT_DRAPE_NETWORK_BENCHMARK_WALK_H_

#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>

#include "drape/simulate/drape_inputs.h"

namespace polyfit {

struct BenchmarkWalk {
  std::string garment_path;
  DrapeCase walk;
};

// Empty, after saying why on stderr, when the body is not there.
inline std::optional<BenchmarkWalk> LoadBenchmarkWalk(int argc, char** argv) {
  const std::string data = argc > 1 ? argv[1] : "../shared/data/drape";
  const std::string garment = argc > 2 ? argv[2] : data + "/garments/makehuman_cc0/male_casualsuit02.mhclo";
  if (!std::filesystem::exists(data + "/body/makehuman/base.obj")) {
    std::fprintf(stderr, "%s: no MakeHuman body under %s/body\n", argv[0], data.c_str());
    return std::nullopt;
  }
  return BenchmarkWalk{garment, LoadMakeHumanDrapeCase(data + "/body", garment, data + "/motion/02_01.bvh", 30.0)};
}

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_NETWORK_BENCHMARK_WALK_H_
