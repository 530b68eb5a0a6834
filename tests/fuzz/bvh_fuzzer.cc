// ReadBvh: motion clips (hierarchy, then frames).
#include "drape/motion/bvh_motion.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = polyfit::fuzz::Scratch::Get().Write("clip.bvh", data, size);
  polyfit::fuzz::ExpectCleanRejection([&] { polyfit::ReadBvh(path, 0.056444); }, "clip.bvh");
  return 0;
}
