#include "drape/simulate/drape_inputs.h"

#include <filesystem>

#include "drape/body/procedural_body.h"
#include "drape/garment/mhclo_garment.h"
#include "drape/motion/bvh_motion.h"
#include "polyfit/mesh/mesh_io.h"

namespace polyfit {

SkinnedBody LoadDrapeBody(const std::string& body_dir, const BodyShape& shape) {
  if (body_dir.empty()) {
    if (!shape.IsNeutral()) throw BodyError("a body shape needs the MakeHuman body", ErrorKind::kInvalidArgument);
    return MakeProceduralBody();
  }
  SkinnedBody body = LoadMakeHumanBody(body_dir);
  ApplyBodyShape(body_dir, shape, &body);
  return body;
}

TriangleMesh LoadDrapeGarment(const std::string& path, const SkinnedBody& body, bool makehuman_body) {
  if (!std::filesystem::exists(path)) throw GarmentError(path + ": no such garment file");
  if (std::filesystem::path(path).extension() != ".mhclo") return ReadTriangleMesh(path);
  if (!makehuman_body) throw GarmentError(path + ": a .mhclo garment needs the MakeHuman body");
  return LoadGarment(path, body.base_vertices, 0.1);
}

std::unique_ptr<MotionRetargeter> LoadRetargetedClip(const std::string& path, double units_to_metres, double fps,
                                                     const Skeleton& skeleton) {
  const MotionClip clip = ReadBvh(path, units_to_metres).Resampled(fps);
  try {
    return std::make_unique<MotionRetargeter>(clip, skeleton);
  } catch (const BvhError& e) {
    throw BvhError(path + ": " + e.what());
  }
}

DrapeCase LoadMakeHumanDrapeCase(const std::string& body_dir, const std::string& garment_path,
                                 const std::string& clip_path, double fps) {
  DrapeCase c;
  c.body = LoadDrapeBody(body_dir, BodyShape{});
  c.garment = LoadDrapeGarment(garment_path, c.body, true);
  c.weights = TransferSkinWeights(c.body, c.garment, SkinTransferOptions{});
  c.clip = LoadRetargetedClip(clip_path, 0.056444, fps, c.body.skeleton);
  return c;
}

}  // namespace polyfit
