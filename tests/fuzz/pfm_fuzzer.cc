// LoadPolyFitModel: the .pfm model file (docs/model-format.md).
#include "polyfit/model/polyfit_model.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = polyfit::fuzz::Scratch::Get().Write("model.pfm", data, size);
  polyfit::fuzz::ExpectCleanRejection([&] { polyfit::LoadPolyFitModel(path); }, "model.pfm");
  return 0;
}
