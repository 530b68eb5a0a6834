// A trained OneFit network as a file (docs/onefit-model-format.md): the
// MLPs' layouts, the feature normalisers and the weights, with the
// jet order and the rig's joint count it was trained for. Garment-agnostic:
// a garment's patch features are computed when it is draped.
#ifndef POLYFIT_DRAPE_NETWORK_ONEFIT_MODEL_H_
#define POLYFIT_DRAPE_NETWORK_ONEFIT_MODEL_H_

#include <string>
#include <vector>

#include "drape/garment/skin_transfer.h"
#include "drape/network/onefit_features.h"
#include "drape/network/onefit_network.h"
#include "polyfit/util/status.h"

namespace polyfit {

// Version 2 adds the warp head's order, version 3 whether the patch frames
// were aligned, version 4 whether the decoder reads the local pose, version
// 5 the patching's area and fit error, version 6 the root's rotation
// feature (RootRotation), version 7 whether the patches were fitted to
// curved faces, version 8 the output units (area_units), version 9 the
// joint mask's reach, version 10 the warp's slide bound, version 11 whether
// the decoder reads the body proximity, version 12 its probes per patch,
// version 13 whether a feedback decoder follows (and, if so, its layout
// after the decoder's), version 14 the skinning transfer, version 15 the
// loss's collision settings; earlier files still load.
inline constexpr int kOneFitModelVersion = 15;

class OneFitModelError : public Error {
 public:
  explicit OneFitModelError(const std::string& message, ErrorKind kind = ErrorKind::kInput) : Error(kind, message) {}
};

// The collision settings of the loss a network was trained with
// (DrapingWeights::collision and collision_margin, DrapePhysicsOptions::
// margin_floor): a drape that re-solves the network's output for that loss
// (DrapeSimulationOptions::warp_sweeps) solves under them.
struct OneFitLossCollision {
  bool recorded = false;  // before version 15, or a model not from training
  double weight = 1.0;    // k_c
  double margin = 4e-3;   // eps, m
  double margin_floor = -1.0;  // m; < 0: every vertex has `margin`

  // Empty when valid (finite, weight >= 0, margin in (0, 1] m, floor <=
  // margin), else the problem.
  std::string Problem() const;
  bool operator==(const OneFitLossCollision& o) const {
    return recorded == o.recorded && weight == o.weight && margin == o.margin && margin_floor == o.margin_floor;
  }
};

struct OneFitModel {
  int jet_order = 4;
  int num_joints = 0;
  // Trained on patches with aligned frames (GarmentPatchOptions::
  // align_frames): a garment is patched the same way to be draped.
  bool aligned_frames = false;
  // The patching it was trained on (GarmentPatchOptions::patch_area and
  // max_fit_error; before version 5, the defaults of then): a garment is
  // patched alike to be draped, so that its patches are the size the
  // network learnt to move.
  double patch_area = 0.04;
  double max_fit_error = 8e-3;
  // GarmentPatchOptions::curved_faces (before version 7: false).
  bool curved_faces = false;
  // Outputs and jet features in units of each patch's area rather than of
  // its scale (PatchOutputUnits; before version 8: false).
  bool area_units = true;
  // Each garment reads the rotations of the joints that move it by at
  // least this weight (BodyFeatureMask; before version 9: 0, all).
  double joint_mask_reach = 0.0;
  // The warp head's bound on each point's slide, in units of its patch's
  // radius (PatchWarpBound; 0, and before version 10: each coefficient's).
  double warp_slide_bound = 0.0;
  // The garments' skinning transfer it was trained with (before version
  // 14: the defaults): a garment is skinned alike to be draped.
  SkinTransferOptions skin;
  // Its loss's collision settings (before version 15: not recorded).
  OneFitLossCollision loss_collision;
  // How its body features hold the root's rotation (before version 6:
  // kAbsolute).
  RootRotation root_rotation = RootRotation::kHeadingFree;
  OneFitNetwork network;
  FeatureNormalizer patch_normalizer, body_normalizer;
  std::vector<double> weights;

  // Empty when consistent (sizes agree, numbers finite), else the problem.
  std::string Validate() const;
};

// Adam's moments and step count: a training checkpoint's optimiser state,
// kept beside the model (MODEL.adam: magic "PFADAM01", int64 size, int64
// steps, then size doubles of m and of v, then, with averaging, size
// doubles of the average and optionally size doubles of the stepped
// weights).
struct OneFitAdamState {
  std::vector<double> m, v;
  long long steps = 0;
  // With averaging (OneFitTrainerOptions::average_batches), the weights'
  // running average and, in a training run's checkpoint, the weights Adam
  // steps on (the model file holds their average); empty without.
  std::vector<double> average, stepped;
};
// Atomic; throws OneFitModelError (kOutput) naming the file.
void SaveOneFitAdamState(const std::string& path, const OneFitAdamState& state);
// Throws OneFitModelError naming the file for a missing, foreign or
// truncated file, or one of another size than `size`.
OneFitAdamState LoadOneFitAdamState(const std::string& path, size_t size);

// Atomic; throws OneFitModelError (kOutput) naming the file.
void SaveOneFitModel(const std::string& path, const OneFitModel& model);
// Throws OneFitModelError naming the file for a missing, foreign,
// truncated or inconsistent file, before allocating what it declares.
OneFitModel LoadOneFitModel(const std::string& path);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_NETWORK_ONEFIT_MODEL_H_
