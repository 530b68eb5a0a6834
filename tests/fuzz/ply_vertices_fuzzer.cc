// ReadPlyVertices: PolyFit's own PLY reader (ASCII and both binaries).
#include "polyfit/mesh/ordered_io.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = polyfit::fuzz::Scratch::Get().Write("points.ply", data, size);
  polyfit::fuzz::ExpectCleanRejection([&] { polyfit::ReadPlyVertices(path); }, "points.ply");
  return 0;
}
