// Tight garments cut from the body's own skin: the torso with sleeves of a
// given length (a top), the hips with legs of a given length (a bottom), or
// both (a suit), moved out along the skin's normals and decimated to a
// garment's resolution. Training data for a network that must drape
// garments it has never seen: the MakeHuman assets give five garments, and
// the cuts and fits drawn here are as many more as a training asks for.
#ifndef POLYFIT_DRAPE_GARMENT_PROCEDURAL_GARMENT_H_
#define POLYFIT_DRAPE_GARMENT_PROCEDURAL_GARMENT_H_

#include <cstdint>
#include <string>

#include "drape/body/makehuman_body.h"
#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

enum class ProceduralGarmentKind { kTop, kBottom, kSuit };

struct ProceduralGarmentOptions {
  ProceduralGarmentKind kind = ProceduralGarmentKind::kTop;
  // Lengths along each limb's bone chain (shoulder -> elbow -> wrist, hip
  // -> knee -> ankle), as fractions of the chain: 0 ends at the shoulder
  // or hip joint, 1 at the wrist or ankle. Tops and suits read `sleeve`,
  // bottoms and suits `leg`.
  double sleeve = 0.5;
  double leg = 0.5;
  // A top's hem and a bottom's waist, as heights between the hip joints
  // (0) and the upper spine's joint (1).
  double hem = 0.2;
  double waist = 0.4;
  // How far the garment sits off the skin (m, along the skin's normals).
  double offset = 0.008;
  // The garment is decimated to about this many vertices (0: the skin's
  // own resolution).
  int target_vertices = 2000;

  // Empty when valid, else the first problem.
  std::string Validate() const;
  // "top (sleeve 0.42, hem 0.31, 7.5 mm)", for names and logs.
  std::string Describe() const;
};

// Options drawn uniformly: the kind, sleeve in [0, 1], leg in [0.15, 1],
// hem in [0, 0.6], waist in [0.2, 0.6], offset in [3, 15] mm.
ProceduralGarmentOptions DrawProceduralGarment(std::uint64_t seed);

// The garment in the body's rest pose: the skin's faces whose corners all
// belong to the cut (each vertex classified by the joints that skin it:
// arm, leg, head and neck, or torso), its largest connected piece, moved
// along the area-weighted vertex normals and decimated by edge collapse.
// The rig must have the CMU-named joints Hips, Spine1, Neck, Left/RightArm,
// Left/RightForeArm, Left/RightHand, Left/RightUpLeg, Left/RightLeg and
// Left/RightFoot (the MakeHuman body's). Throws std::invalid_argument for
// invalid options, a rig without those joints or an empty cut.
TriangleMesh MakeProceduralGarment(const SkinnedBody& body, const ProceduralGarmentOptions& options);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_GARMENT_PROCEDURAL_GARMENT_H_
