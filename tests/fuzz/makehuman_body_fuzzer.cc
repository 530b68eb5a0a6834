// The MakeHuman body folder's files, one per input, the others the real
// ones (read once from POLYFIT_FUZZ_BODY, default ../shared/data/drape/body;
// without them only base.obj's parser is fuzzed). The first byte chooses the
// file the rest of the input replaces:
//   0: makehuman/base.obj (ReadMakeHumanObj)
//   1: mpfb2_rigs/rig.cmu_mb.json (with the real base.obj and weights)
//   2: mpfb2_rigs/weights.cmu_mb.json (with the real base.obj and rig)
//   3: a macro shape target, .target.gz (AddBodyShapeTarget)
#include <cstdlib>
#include <memory>

#include "drape/body/body_shape.h"
#include "drape/body/makehuman_files.h"
#include "tests/fuzz/fuzz_input.h"

namespace {

struct RealBody {
  std::string obj_path, rig_path, weights_path;
  polyfit::MakeHumanObj obj;
  nlohmann::json rig, weights;
};

// The real files, or null where they are absent.
const RealBody* Real() {
  static const std::unique_ptr<RealBody> real = []() -> std::unique_ptr<RealBody> {
    const char* env = std::getenv("POLYFIT_FUZZ_BODY");
    const std::string dir = env ? env : "../shared/data/drape/body";
    auto body = std::make_unique<RealBody>();
    body->obj_path = dir + "/makehuman/base.obj";
    body->rig_path = dir + "/mpfb2_rigs/rig.cmu_mb.json";
    body->weights_path = dir + "/mpfb2_rigs/weights.cmu_mb.json";
    try {
      body->obj = polyfit::ReadMakeHumanObj(body->obj_path);
      body->rig = polyfit::ReadBodyJson(body->rig_path);
      body->weights = polyfit::ReadBodyJson(body->weights_path);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "makehuman_body_fuzzer: %s; only base.obj's parser is fuzzed\n", e.what());
      return nullptr;
    }
    return body;
  }();
  return real.get();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using polyfit::fuzz::ExpectCleanRejection;
  if (size == 0) return 0;
  const polyfit::fuzz::Scratch& scratch = polyfit::fuzz::Scratch::Get();
  const RealBody* real = Real();
  const int file = data[0] % 4;
  ++data;
  --size;
  if (file == 0 || real == nullptr) {
    const std::string path = scratch.Write("base.obj", data, size);
    ExpectCleanRejection([&] { polyfit::ReadMakeHumanObj(path); }, "base.obj");
  } else if (file == 1) {
    const std::string path = scratch.Write("rig.cmu_mb.json", data, size);
    ExpectCleanRejection(
        [&] {
          polyfit::AssembleMakeHumanBody(real->obj, real->obj_path, polyfit::ReadBodyJson(path), path, real->weights,
                                         real->weights_path);
        },
        "");
  } else if (file == 2) {
    const std::string path = scratch.Write("weights.cmu_mb.json", data, size);
    ExpectCleanRejection(
        [&] {
          polyfit::AssembleMakeHumanBody(real->obj, real->obj_path, real->rig, real->rig_path,
                                         polyfit::ReadBodyJson(path), path);
        },
        "weights.cmu_mb.json");
  } else {
    const std::string path = scratch.Write("shape.target.gz", data, size);
    Eigen::Matrix3Xd base = Eigen::Matrix3Xd::Zero(3, 19158);
    ExpectCleanRejection([&] { polyfit::AddBodyShapeTarget(path, 0.5, &base); }, "shape.target.gz");
  }
  return 0;
}
