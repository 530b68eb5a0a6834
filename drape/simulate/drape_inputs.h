// What a drape reads from disk, each checked and named on failure: the
// body (MakeHuman, shaped, or the procedural one), a garment in the body's
// rest pose, and a motion clip retargeted onto the body's rig. Shared by
// `onefit simulate`, `onefit train` and `onefit drape`.
#ifndef POLYFIT_DRAPE_SIMULATE_DRAPE_INPUTS_H_
#define POLYFIT_DRAPE_SIMULATE_DRAPE_INPUTS_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "drape/body/body_shape.h"
#include "drape/body/makehuman_body.h"
#include "drape/garment/skin_transfer.h"
#include "drape/motion/retarget.h"
#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// body_dir empty: the procedural capsule body (then the shape must be
// neutral). Throws BodyError naming the file.
SkinnedBody LoadDrapeBody(const std::string& body_dir, const BodyShape& shape);

// A MakeHuman garment (.mhclo, fitted to the body by its binding; needs the
// MakeHuman body) or a mesh file in the body's rest pose (metres). Throws
// an Error (kInput) naming the file.
TriangleMesh LoadDrapeGarment(const std::string& path, const SkinnedBody& body, bool makehuman_body);

// A BVH clip resampled to fps and retargeted onto the body's rig. Throws
// an Error (kInput) naming the file.
std::unique_ptr<MotionRetargeter> LoadRetargetedClip(const std::string& path, double units_to_metres, double fps,
                                                     const Skeleton& skeleton);

// A garment on the neutral MakeHuman body with its transferred skinning, and
// a clip (BVH units of the CMU clips), as the benchmarks and stress tests
// load them. Throws what the loaders above throw.
struct DrapeCase {
  SkinnedBody body;
  TriangleMesh garment;
  SkinWeights weights;
  std::unique_ptr<MotionRetargeter> clip;
};
DrapeCase LoadMakeHumanDrapeCase(const std::string& body_dir, const std::string& garment_path,
                                 const std::string& clip_path, double fps);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_SIMULATE_DRAPE_INPUTS_H_
