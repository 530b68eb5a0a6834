#include "drape/network/onefit_model.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "drape/network/body_proximity.h"
#include "polyfit/jet/jet_basis.h"
#include "polyfit/util/atomic_file.h"
#include "polyfit/util/binary_io.h"

namespace polyfit {
namespace {

constexpr char kMagic[8] = {'P', 'F', 'O', 'N', 'E', 'F', 'I', 'T'};
constexpr char kEndMagic[8] = {'O', 'N', 'E', 'F', 'I', 'T', 'E', 'N'};
// Bounds that no real model reaches: a header past them is corrupt.
constexpr std::uint32_t kMaxLayers = 64;
constexpr std::uint32_t kMaxWidth = 1 << 16;

using Writer = BinaryWriter;
using Reader = BinaryReader<OneFitModelError>;

void PutMlp(const Mlp& mlp, Writer* w) {
  w->Put<std::uint32_t>(static_cast<std::uint32_t>(mlp.sizes().size()));
  for (int n : mlp.sizes()) w->Put<std::uint32_t>(static_cast<std::uint32_t>(n));
  w->Put<std::uint8_t>(mlp.residual() ? 1 : 0);
  w->Put<double>(mlp.leaky_slope());
}

Mlp GetMlp(Reader* r, const char* what) {
  const auto count = r->Get<std::uint32_t>(what);
  if (count < 2 || count > kMaxLayers) r->Fail(std::string(what) + ": " + std::to_string(count) + " layer sizes");
  std::vector<int> sizes(count);
  for (auto& n : sizes) {
    const auto value = r->Get<std::uint32_t>(what);
    if (value < 1 || value > kMaxWidth) r->Fail(std::string(what) + ": a layer of " + std::to_string(value) + " units");
    n = static_cast<int>(value);
  }
  const bool residual = r->Get<std::uint8_t>(what) != 0;
  const double slope = r->Get<double>(what);
  if (!(slope >= 0.0 && slope < 1.0)) r->Fail(std::string(what) + ": bad LeakyReLU slope");
  try {
    return Mlp(sizes, residual, slope);
  } catch (const std::invalid_argument& e) {
    r->Fail(std::string(what) + ": " + e.what());
  }
}

void PutNormalizer(const FeatureNormalizer& n, Writer* w) {
  w->Put<std::uint32_t>(static_cast<std::uint32_t>(n.mean.size()));
  w->PutDoubles(n.mean.data(), n.mean.size());
  w->PutDoubles(n.inv_std.data(), n.inv_std.size());
}

FeatureNormalizer GetNormalizer(Reader* r, int expected, const char* what) {
  const auto size = r->Get<std::uint32_t>(what);
  if (static_cast<int>(size) != expected) {
    r->Fail(std::string(what) + ": " + std::to_string(size) + " features, the network reads " +
            std::to_string(expected));
  }
  FeatureNormalizer n;
  const std::vector<double> mean = r->GetDoubles(size, what), inv_std = r->GetDoubles(size, what);
  n.mean = Eigen::Map<const Eigen::VectorXd>(mean.data(), size);
  n.inv_std = Eigen::Map<const Eigen::VectorXd>(inv_std.data(), size);
  return n;
}

// Empty when the skinning options are in range, else the problem.
std::string SkinProblem(const SkinTransferOptions& skin) {
  if (!(skin.smoothing_length >= 0.0 && skin.smoothing_length <= 10.0)) return "skin smoothing length out of [0, 10] m";
  if (skin.smoothing_iterations < 0 || skin.smoothing_iterations > 100000) return "skin smoothing steps out of range";
  if (!(skin.anchor_distance >= 0.0 && skin.anchor_distance <= 1.0)) return "skin anchor distance out of [0, 1] m";
  if (!(skin.loose_distance >= 0.0 && skin.loose_distance <= 1.0)) return "skin loose distance out of [0, 1] m";
  if (!(skin.min_weight >= 0.0 && skin.min_weight < 1.0)) return "skin minimum weight out of [0, 1)";
  if (!(skin.resample_edge_length >= 0.0 && skin.resample_edge_length <= 1.0)) {
    return "skin resample edge length out of [0, 1] m";
  }
  return {};
}

// The skinning block (version 14): method, length, steps, anchor, loose
// distance, minimum weight, resample length.
void PutSkin(const SkinTransferOptions& skin, Writer* w) {
  w->Put<std::int32_t>(skin.smoothing == SkinSmoothing::kSurface ? 1 : 0);
  w->Put<double>(skin.smoothing_length);
  w->Put<std::int32_t>(skin.smoothing_iterations);
  w->Put<double>(skin.anchor_distance);
  w->Put<double>(skin.loose_distance);
  w->Put<double>(skin.min_weight);
  w->Put<double>(skin.resample_edge_length);
}

SkinTransferOptions GetSkin(Reader* r) {
  SkinTransferOptions skin;
  const int surface = r->Get<std::int32_t>("the header");
  if (surface != 0 && surface != 1) r->Fail("skin smoothing method out of range");
  skin.smoothing = surface == 1 ? SkinSmoothing::kSurface : SkinSmoothing::kEdgeSteps;
  skin.smoothing_length = r->Get<double>("the header");
  skin.smoothing_iterations = r->Get<std::int32_t>("the header");
  skin.anchor_distance = r->Get<double>("the header");
  skin.loose_distance = r->Get<double>("the header");
  skin.min_weight = r->Get<double>("the header");
  skin.resample_edge_length = r->Get<double>("the header");
  if (std::string problem = SkinProblem(skin); !problem.empty()) r->Fail(problem);
  return skin;
}

void PutLossCollision(const OneFitLossCollision& c, Writer* w) {
  w->Put<std::int32_t>(c.recorded ? 1 : 0);
  w->Put<double>(c.weight);
  w->Put<double>(c.margin);
  w->Put<double>(c.margin_floor);
}

OneFitLossCollision GetLossCollision(Reader* r) {
  OneFitLossCollision c;
  const int recorded = r->Get<std::int32_t>("the header");
  if (recorded != 0 && recorded != 1) r->Fail("loss collision flag out of range");
  c.recorded = recorded == 1;
  c.weight = r->Get<double>("the header");
  c.margin = r->Get<double>("the header");
  c.margin_floor = r->Get<double>("the header");
  if (std::string problem = c.Problem(); !problem.empty()) r->Fail("the loss's collision settings: " + problem);
  return c;
}

}  // namespace

std::string OneFitLossCollision::Problem() const {
  if (!(std::isfinite(weight) && weight >= 0.0)) return "collision weight not finite and >= 0";
  if (!(margin > 0.0 && margin <= 1.0)) return "collision margin not in (0, 1] m";
  if (!(std::isfinite(margin_floor) && margin_floor <= margin)) return "margin floor not finite or above the margin";
  return {};
}

std::string OneFitModel::Validate() const {
  if (jet_order < 1 || jet_order > kMaxJetOrder) return "jet order out of range";
  if (num_joints < 1) return "no joint";
  if (!(joint_mask_reach >= 0.0 && joint_mask_reach <= 1.0)) return "joint_mask_reach out of [0, 1]";
  if (!(warp_slide_bound >= 0.0 && warp_slide_bound <= 1.0)) return "warp_slide_bound out of [0, 1]";
  if (std::string problem = SkinProblem(skin); !problem.empty()) return problem;
  if (network.num_coefficients() != NumJetCoefficients(jet_order)) return "the decoder does not fit the jet order";
  if (network.patch_encoder().input_size() != PatchFeatureSize(jet_order, num_joints)) {
    return "the patch encoder does not read this rig's patch features";
  }
  if (network.body_encoder().input_size() != BodyFeatureSize(num_joints)) {
    return "the body encoder does not read this rig's body features";
  }
  if (patch_normalizer.mean.size() != network.patch_encoder().input_size() ||
      body_normalizer.mean.size() != network.body_encoder().input_size()) {
    return "the normalisers do not fit the network";
  }
  if (!(patch_area > 0.0) || !std::isfinite(patch_area)) return "patch area not positive";
  if (!(max_fit_error > 0.0) || !std::isfinite(max_fit_error)) return "patch fit error not positive";
  if (std::string problem = loss_collision.Problem(); !problem.empty()) return "the loss's collision: " + problem;
  if (static_cast<int>(weights.size()) != network.num_parameters()) return "the weights do not fit the network";
  for (double w : weights) {
    if (!std::isfinite(w)) return "non-finite weights";
  }
  if (!patch_normalizer.mean.allFinite() || !patch_normalizer.inv_std.allFinite() ||
      !body_normalizer.mean.allFinite() || !body_normalizer.inv_std.allFinite()) {
    return "non-finite normalisers";
  }
  return {};
}

void SaveOneFitModel(const std::string& path, const OneFitModel& model) {
  if (const std::string problem = model.Validate(); !problem.empty()) {
    throw OneFitModelError(path + ": refusing to save an invalid model: " + problem, ErrorKind::kInvalidArgument);
  }
  Writer w;
  w.PutBytes(kMagic, sizeof(kMagic));
  w.Put<std::uint32_t>(kOneFitModelVersion);
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(model.jet_order));
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(model.num_joints));
  w.Put<std::int32_t>(model.network.warp_order());
  w.Put<std::int32_t>(model.aligned_frames ? 1 : 0);
  w.Put<std::int32_t>(model.network.local_pose() ? 1 : 0);
  w.Put<double>(model.patch_area);
  w.Put<double>(model.max_fit_error);
  w.Put<std::int32_t>(model.root_rotation == RootRotation::kHeadingFree ? 1 : 0);
  w.Put<std::int32_t>(model.curved_faces ? 1 : 0);
  w.Put<std::int32_t>(model.area_units ? 1 : 0);
  w.Put<double>(model.joint_mask_reach);
  w.Put<double>(model.warp_slide_bound);
  w.Put<std::int32_t>(model.network.body_proximity() ? 1 : 0);
  w.Put<std::int32_t>(model.network.proximity_probes());
  w.Put<std::int32_t>(model.network.feedback_passes());
  PutSkin(model.skin, &w);
  PutLossCollision(model.loss_collision, &w);
  PutMlp(model.network.patch_encoder(), &w);
  PutMlp(model.network.body_encoder(), &w);
  PutMlp(model.network.decoder(), &w);
  if (model.network.feedback()) PutMlp(model.network.feedback_decoder(), &w);
  PutNormalizer(model.patch_normalizer, &w);
  PutNormalizer(model.body_normalizer, &w);
  w.Put<std::uint64_t>(model.weights.size());
  w.PutDoubles(model.weights.data(), model.weights.size());
  w.PutBytes(kEndMagic, sizeof(kEndMagic));
  try {
    WriteFileAtomically(path, [&](std::ostream& out) {
      out.write(w.buffer().data(), static_cast<std::streamsize>(w.buffer().size()));
    });
  } catch (const Error& e) {
    throw OneFitModelError(e.what(), ErrorKind::kOutput);
  }
}

namespace {

constexpr char kAdamMagic[8] = {'P', 'F', 'A', 'D', 'A', 'M', '0', '1'};

// The file's bytes, past its 8-byte magic (checked).
Reader OpenWithMagic(const std::string& path, const char (&magic)[8], const char* bad_magic) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw OneFitModelError(path + ": cannot be opened (missing?)");
  Reader r(std::vector<char>(std::istreambuf_iterator<char>(in), {}), path);
  char found[8];
  r.GetBytes(found, sizeof(found), "the header");
  if (std::memcmp(found, magic, sizeof(found)) != 0) r.Fail(bad_magic);
  return r;
}

}  // namespace

void SaveOneFitAdamState(const std::string& path, const OneFitAdamState& state) {
  if (state.m.size() != state.v.size() || (!state.average.empty() && state.average.size() != state.m.size()) ||
      (!state.stepped.empty() && state.stepped.size() != state.average.size())) {
    throw OneFitModelError(path + ": Adam's moments and the weights' average differ in size",
                           ErrorKind::kInvalidArgument);
  }
  Writer w;
  w.Reserve(sizeof(kAdamMagic) + 2 * sizeof(std::int64_t) +
            (2 * state.m.size() + state.average.size() + state.stepped.size()) * sizeof(double));
  w.PutBytes(kAdamMagic, sizeof(kAdamMagic));
  w.Put<std::int64_t>(static_cast<std::int64_t>(state.m.size()));
  w.Put<std::int64_t>(state.steps);
  w.PutDoubles(state.m.data(), state.m.size());
  w.PutDoubles(state.v.data(), state.v.size());
  w.PutDoubles(state.average.data(), state.average.size());
  w.PutDoubles(state.stepped.data(), state.stepped.size());
  WriteFileAtomically(path, [&](std::ostream& out) { out.write(w.buffer().data(), w.buffer().size()); });
}

OneFitAdamState LoadOneFitAdamState(const std::string& path, size_t size) {
  Reader r = OpenWithMagic(path, kAdamMagic, "not an Adam state (bad magic)");
  const auto count = r.Get<std::int64_t>("the header");
  OneFitAdamState state;
  state.steps = r.Get<std::int64_t>("the header");
  if (count < 0 || static_cast<size_t>(count) != size || state.steps < 0) {
    r.Fail("an Adam state for " + std::to_string(count) + " weights, the network has " + std::to_string(size));
  }
  state.m = r.GetDoubles(size, "the first moments");
  state.v = r.GetDoubles(size, "the second moments");
  if (r.remaining() != 0) state.average = r.GetDoubles(size, "the weights' average");
  if (r.remaining() != 0) state.stepped = r.GetDoubles(size, "the stepped weights");
  if (r.remaining() != 0) r.Fail("trailing bytes");
  return state;
}

OneFitModel LoadOneFitModel(const std::string& path) {
  Reader r = OpenWithMagic(path, kMagic, "not a OneFit model (bad magic)");
  const auto version = r.Get<std::uint32_t>("the header");
  if (version < 1 || version > kOneFitModelVersion) {
    r.Fail("version " + std::to_string(version) + ", this build reads 1 to " + std::to_string(kOneFitModelVersion));
  }
  OneFitModel model;
  model.jet_order = static_cast<int>(r.Get<std::uint32_t>("the header"));
  model.num_joints = static_cast<int>(r.Get<std::uint32_t>("the header"));
  const int warp_order = version >= 2 ? r.Get<std::int32_t>("the header") : -1;
  const int aligned = version >= 3 ? r.Get<std::int32_t>("the header") : 0;
  const int local_pose = version >= 4 ? r.Get<std::int32_t>("the header") : 0;
  if (version >= 5) {
    model.patch_area = r.Get<double>("the header");
    model.max_fit_error = r.Get<double>("the header");
  }
  const int heading_free = version >= 6 ? r.Get<std::int32_t>("the header") : 0;
  if (heading_free != 0 && heading_free != 1) r.Fail("root rotation flag out of range");
  model.root_rotation = heading_free == 1 ? RootRotation::kHeadingFree : RootRotation::kAbsolute;
  const int curved = version >= 7 ? r.Get<std::int32_t>("the header") : 0;
  if (curved != 0 && curved != 1) r.Fail("curved faces flag out of range");
  model.curved_faces = curved == 1;
  const int area_units = version >= 8 ? r.Get<std::int32_t>("the header") : 0;
  if (area_units != 0 && area_units != 1) r.Fail("output units flag out of range");
  model.area_units = area_units == 1;
  model.joint_mask_reach = version >= 9 ? r.Get<double>("the header") : 0.0;
  if (!(model.joint_mask_reach >= 0.0 && model.joint_mask_reach <= 1.0)) r.Fail("joint mask reach out of [0, 1]");
  model.warp_slide_bound = version >= 10 ? r.Get<double>("the header") : 0.0;
  if (!(model.warp_slide_bound >= 0.0 && model.warp_slide_bound <= 1.0)) r.Fail("warp slide bound out of [0, 1]");
  const int proximity = version >= 11 ? r.Get<std::int32_t>("the header") : 0;
  if (proximity != 0 && proximity != 1) r.Fail("body proximity flag out of range");
  // Version 11 had one layout of probes.
  const int probes = version >= 12 ? r.Get<std::int32_t>("the header") : (proximity == 1 ? kProximityProbes : 0);
  if (proximity == 0 ? probes != 0 : !IsProximityLayout(probes)) r.Fail("proximity probes out of range");
  const int feedback = version >= 13 ? r.Get<std::int32_t>("the header") : 0;
  if (feedback < 0 || feedback > kMaxFeedbackPasses || (feedback > 0 && proximity == 0)) {
    r.Fail("feedback passes out of range or without the proximity");
  }
  if (version >= 14) model.skin = GetSkin(&r);
  if (version >= 15) model.loss_collision = GetLossCollision(&r);
  if (aligned != 0 && aligned != 1) r.Fail("frame alignment flag out of range");
  if (local_pose != 0 && local_pose != 1) r.Fail("local pose flag out of range");
  model.aligned_frames = aligned == 1;
  if (model.jet_order < 1 || model.jet_order > kMaxJetOrder) r.Fail("jet order out of range");
  if (model.num_joints < 1 || model.num_joints > static_cast<int>(kMaxWidth)) r.Fail("joint count out of range");
  if (warp_order < -1 || warp_order > kMaxJetOrder) r.Fail("warp order out of range");
  Mlp patch = GetMlp(&r, "the patch encoder");
  Mlp body = GetMlp(&r, "the body encoder");
  Mlp decoder = GetMlp(&r, "the decoder");
  Mlp feedback_decoder = feedback > 0 ? GetMlp(&r, "the feedback decoder") : Mlp();
  try {
    model.network =
        OneFitNetwork(std::move(patch), std::move(body), std::move(decoder), NumJetCoefficients(model.jet_order),
                      warp_order, probes, std::move(feedback_decoder), std::max(feedback, 1));
  } catch (const std::invalid_argument& e) {
    r.Fail(e.what());
  }
  if (model.network.local_pose() != (local_pose == 1)) {
    r.Fail("the header's local pose flag disagrees with the decoder's input size");
  }
  model.patch_normalizer = GetNormalizer(&r, model.network.patch_encoder().input_size(), "the patch normaliser");
  model.body_normalizer = GetNormalizer(&r, model.network.body_encoder().input_size(), "the body normaliser");
  const auto count = r.Get<std::uint64_t>("the weights");
  if (count != static_cast<std::uint64_t>(model.network.num_parameters())) {
    r.Fail(std::to_string(count) + " weights, the network has " + std::to_string(model.network.num_parameters()));
  }
  model.weights = r.GetDoubles(count, "the weights");
  char end[8];
  r.GetBytes(end, sizeof(end), "the end marker");
  if (std::memcmp(end, kEndMagic, sizeof(end)) != 0) r.Fail("bad end marker (corrupt)");
  if (r.remaining() != 0) r.Fail("trailing bytes after the end marker");
  if (const std::string problem = model.Validate(); !problem.empty()) r.Fail(problem);
  return model;
}

}  // namespace polyfit
