#include "sft/solver/polysft_settings.h"

#include <fstream>
#include <functional>
#include <stdexcept>
#include <utility>

#include "polyfit/util/status.h"

namespace polyfit {
namespace {

using nlohmann::json;

struct Setting {
  const char* key;
  std::function<json(const PolySftOptions&)> get;
  std::function<void(const json&, PolySftOptions*)> set;
};

// An enum setting by its names.
template <typename Enum>
Setting EnumSetting(const char* key, Enum& (*field)(PolySftOptions&), std::vector<std::pair<Enum, const char*>> names) {
  return {key,
          [field, names](const PolySftOptions& o) {
            for (const auto& [value, name] : names) {
              if (field(const_cast<PolySftOptions&>(o)) == value) return json(name);
            }
            return json(nullptr);
          },
          [field, names](const json& j, PolySftOptions* o) {
            const std::string name = j.get<std::string>();
            std::string allowed;
            for (const auto& [value, n] : names) {
              if (name == n) {
                field(*o) = value;
                return;
              }
              allowed += (allowed.empty() ? "" : ", ") + std::string(n);
            }
            throw std::invalid_argument("expected one of " + allowed + ", got '" + name + "'");
          }};
}

#define POLYFIT_SETTING(key, field)                                  \
  Setting {                                                          \
    key, [](const PolySftOptions& o) { return json(o.field); },      \
        [](const json& j, PolySftOptions* o) { j.get_to(o->field); } \
  }

// One table, a line per key in metrics.json's order: long, but a list,
// not a procedure.
const std::vector<Setting>& Settings() {
  static const std::vector<Setting> settings = [] {
    std::vector<Setting> s = {
        POLYFIT_SETTING("jet_order", deformation.jet_order),
        POLYFIT_SETTING("uv_order", deformation.uv_order),
        POLYFIT_SETTING("texture_space", deformation.texture_space),
        POLYFIT_SETTING("keep_detail", deformation.keep_detail),
        POLYFIT_SETTING("window_size", window_size),
        POLYFIT_SETTING("coarse_levels_newest_only", coarse_levels_newest_only),
        POLYFIT_SETTING("check_coarse_levels", check_coarse_levels),
        POLYFIT_SETTING("pyramid_levels", pyramid_levels),
        POLYFIT_SETTING("max_image_width", max_image_width),
        POLYFIT_SETTING("max_iterations_per_level", max_iterations_per_level),
        POLYFIT_SETTING("tracked_finest_iterations", tracked_finest_iterations),
        POLYFIT_SETTING("patience", patience),
        POLYFIT_SETTING("improvement_tolerance", improvement_tolerance),
        POLYFIT_SETTING("iterative_min_patches", iterative_min_patches),
        POLYFIT_SETTING("iterative_eta", iterative_eta),
        POLYFIT_SETTING("photometric_weight", photometric_weight),
        POLYFIT_SETTING("silhouette_weight", silhouette_weight),
        POLYFIT_SETTING("inextensibility_weight", inextensibility_weight),
        POLYFIT_SETTING("inextensibility_robust_strain", inextensibility_robust_strain),
        POLYFIT_SETTING("bending_weight", bending_weight),
        POLYFIT_SETTING("new_crease_bending_weight", new_crease_bending_weight),
        POLYFIT_SETTING("new_crease_angle_deg", new_crease_angle_deg),
        POLYFIT_SETTING("mirror_new_creases", mirror_new_creases),
        POLYFIT_SETTING("flip_new_crease_bands", flip_new_crease_bands),
        POLYFIT_SETTING("new_crease_from_frame_before", new_crease_from_frame_before),
        POLYFIT_SETTING("new_crease_span_frames", new_crease_span_frames),
        POLYFIT_SETTING("temporal_weight", temporal_weight),
        POLYFIT_SETTING("temporal_order", temporal_order),
        POLYFIT_SETTING("gravity_prior", gravity_prior),
        POLYFIT_SETTING("occluded_temporal_weight", occluded_temporal_weight),
        POLYFIT_SETTING("occluded_velocity", occluded_velocity),
        POLYFIT_SETTING("silhouette_band", silhouette_band),
        POLYFIT_SETTING("relax_mask_border", relax_mask_border),
        POLYFIT_SETTING("silhouette_reach_weight", silhouette_reach_weight),
        POLYFIT_SETTING("feature_weight", feature_weight),
        POLYFIT_SETTING("feature_huber_px", feature_huber_px),
        POLYFIT_SETTING("feature_dead_zone_px", feature_dead_zone_px),
        POLYFIT_SETTING("features_on_finest", features_on_finest),
        POLYFIT_SETTING("flow_weight", flow_weight),
        POLYFIT_SETTING("flow_on_finest", flow_on_finest),
        POLYFIT_SETTING("flow_start", flow_start),
        POLYFIT_SETTING("keypoints_when_lost", keypoints_when_lost),
        POLYFIT_SETTING("relocalize", relocalize),
        POLYFIT_SETTING("mirrored_keypoints", features.mirrored),
        POLYFIT_SETTING("match_brightness", match_brightness),
        POLYFIT_SETTING("predict_motion", predict_motion),
        POLYFIT_SETTING("recover_lost_frames", recover_lost_frames),
        POLYFIT_SETTING("max_patches", atlas.max_patches),
        POLYFIT_SETTING("initial_patches", atlas.initial_patches),
        POLYFIT_SETTING("split_ratio", atlas.split_ratio),
        POLYFIT_SETTING("split_significance", atlas.split_significance),
        POLYFIT_SETTING("split_min_step_px", atlas.split_min_step_pixels),
        POLYFIT_SETTING("split_children", atlas.children),
        POLYFIT_SETTING("min_patch_vertices", atlas.min_vertices),
        POLYFIT_SETTING("min_split_children", atlas.min_children),
        POLYFIT_SETTING("seam_position_weight", atlas.seam_position_weight),
        POLYFIT_SETTING("coarse_seam_position_weight", atlas.coarse_seam_position_weight),
        POLYFIT_SETTING("seen_seam_position_weight", atlas.seen_seam_position_weight),
        POLYFIT_SETTING("seam_normal_weight", atlas.seam_normal_weight),
        POLYFIT_SETTING("seam_uv_weight", atlas.seam_uv_weight),
        POLYFIT_SETTING("coarse_seam_uv_weight", atlas.coarse_seam_uv_weight),
        POLYFIT_SETTING("seen_seam_uv_weight", atlas.seen_seam_uv_weight),
        POLYFIT_SETTING("seam_uv_robust", atlas.seam_uv_robust),
        POLYFIT_SETTING("seen_seam_uv_robust", atlas.seen_seam_uv_robust),
        POLYFIT_SETTING("hidden_split_share", atlas.hidden_split_share),
        POLYFIT_SETTING("max_hidden_patches", atlas.max_hidden_patches),
        POLYFIT_SETTING("min_hidden_vertices", atlas.min_hidden_vertices),
        POLYFIT_SETTING("sigma", rasterizer.sigma),
        POLYFIT_SETTING("gamma", rasterizer.gamma),
        POLYFIT_SETTING("depth_softness", depth_softness),
        POLYFIT_SETTING("finest_sigma", finest_sigma),
        POLYFIT_SETTING("depth_gradient", rasterizer.depth_gradient),
        POLYFIT_SETTING("mipmap", rasterizer.mipmap),
        POLYFIT_SETTING("finest_mipmap", finest_mipmap),
        POLYFIT_SETTING("mip_level_bias", rasterizer.mip_level_bias),
        POLYFIT_SETTING("analytic_derivatives", rasterizer.analytic_derivatives),
        POLYFIT_SETTING("robust_scale", robust_scale),
        POLYFIT_SETTING("max_frames", max_frames),
        POLYFIT_SETTING("num_threads", num_threads),
    };
    s.insert(s.begin() + 1,
             Setting{"uv_displacement",
                     [](const PolySftOptions& o) {
                       return json(o.deformation.uv_displacement == UvDisplacement::kCompactField ? "compact"
                                                                                                  : "per_vertex");
                     },
                     [](const json& j, PolySftOptions* o) {
                       const std::string mode = j.get<std::string>();
                       if (mode != "compact" && mode != "per_vertex") {
                         throw std::invalid_argument("expected compact or per_vertex, got '" + mode + "'");
                       }
                       o->deformation.uv_displacement =
                           mode == "compact" ? UvDisplacement::kCompactField : UvDisplacement::kPerVertex;
                     }});
    s.push_back(EnumSetting<RobustLoss>(
        "robust_loss", [](PolySftOptions& o) -> RobustLoss& { return o.robust_loss; },
        {{RobustLoss::kNone, "none"}, {RobustLoss::kHuber, "huber"}, {RobustLoss::kCauchy, "cauchy"}}));
    const std::vector<std::pair<Compositing, const char*>> compositing = {{Compositing::kSoftZ, "soft_z"},
                                                                           {Compositing::kOver, "over"},
                                                                           {Compositing::kOverBackground, "over_background"}};
    s.push_back(EnumSetting<Compositing>(
        "compositing", [](PolySftOptions& o) -> Compositing& { return o.rasterizer.compositing; }, compositing));
    s.push_back(EnumSetting<Compositing>(
        "finest_compositing", [](PolySftOptions& o) -> Compositing& { return o.finest_compositing; }, compositing));
    s.push_back(EnumSetting<GroundTruthStart>("ground_truth_start",
                                              [](PolySftOptions& o) -> GroundTruthStart& { return o.ground_truth_start; },
                                              {{GroundTruthStart::kNone, "none"},
                                               {GroundTruthStart::kThisFrame, "this_frame"},
                                               {GroundTruthStart::kFrameBefore, "frame_before"}}));
    return s;
  }();
  return settings;
}

#undef POLYFIT_SETTING

}  // namespace

json PolySftSettingsToJson(const PolySftOptions& options) {
  json j = json::object();
  for (const Setting& s : Settings()) j[s.key] = s.get(options);
  return j;
}

std::vector<std::string> PolySftSettingKeys() {
  std::vector<std::string> keys;
  for (const Setting& s : Settings()) keys.push_back(s.key);
  return keys;
}

void ApplyPolySftSettings(const json& settings, const std::string& source, PolySftOptions* options) {
  if (!settings.is_object()) throw Error(ErrorKind::kInvalidArgument, source + ": settings must be a JSON object");
  for (const auto& [key, value] : settings.items()) {
    const Setting* setting = nullptr;
    for (const Setting& s : Settings()) {
      if (key == s.key) setting = &s;
    }
    if (setting == nullptr) throw Error(ErrorKind::kInvalidArgument, source + ": key '" + key + "': unknown key");
    try {
      setting->set(value, options);
    } catch (const std::exception& e) {
      throw Error(ErrorKind::kInvalidArgument, source + ": key '" + key + "': " + e.what());
    }
  }
}

void ApplyPolySftSettingsFile(const std::string& path, PolySftOptions* options) {
  std::ifstream in(path);
  if (!in) throw Error(ErrorKind::kInput, path + ": cannot be opened");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw Error(ErrorKind::kInput, path + ": not valid JSON: " + e.what());
  }
  // A metrics.json of an earlier run: its settings.
  if (j.is_object() && j.contains("settings") && j["settings"].is_object()) j = j["settings"];
  ApplyPolySftSettings(j, path, options);
}

}  // namespace polyfit
