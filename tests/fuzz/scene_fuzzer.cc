// LoadScene and LoadFrame: a scene folder (../shared/docs/sft-scene-format.md)
// whose scene.json is the input, beside a small valid scene's template,
// texture, frames, masks and ground truth (generated once per process), so
// that every key that names a file, a size or a range reaches the files.
#include "sft/scene/scene.h"
#include "sft/synthetic/sheet_scene.h"
#include "tests/fuzz/fuzz_input.h"

namespace {

std::string SceneDir() {
  static const std::string dir = [] {
    const std::string d = (polyfit::fuzz::Scratch::Get().dir() / "scene").string();
    polyfit::GenerateSheetScene(polyfit::SheetSceneOptions::Small(32, 6, 3), d);
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string dir = SceneDir();
  polyfit::fuzz::Scratch::Get().Write("scene/scene.json", data, size);
  polyfit::fuzz::ExpectCleanRejection(
      [&] {
        const polyfit::SftScene scene = polyfit::LoadScene(dir);
        for (int t = 0; t < scene.frame_count; ++t) polyfit::LoadFrame(scene, t);
      },
      "");
  return 0;
}
