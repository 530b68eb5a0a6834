// ReadTriangleMesh (assimp, then PolyFit's checks: welding, degenerate and
// non-finite input) on one format, chosen at build time by
// POLYFIT_FUZZ_EXTENSION (obj, ply, off, stl): one target per format, so
// that each corpus and dictionary stays in its own syntax.
#include "polyfit/mesh/mesh_io.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string name = std::string("input.") + POLYFIT_FUZZ_EXTENSION;
  const std::string path = polyfit::fuzz::Scratch::Get().Write(name, data, size);
  polyfit::fuzz::ExpectCleanRejection([&] { polyfit::ReadTriangleMesh(path); }, name);
  return 0;
}
