#include "drape/network/onefit_training_run.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <random>
#include <sstream>
#include <utility>

#include "drape/garment/procedural_garment.h"
#include "drape/motion/limb_excursion.h"
#include "drape/motion/mirror_pose.h"
#include "drape/motion/mix_pose.h"
#include "drape/motion/perturb_pose.h"
#include "drape/network/onefit_draper.h"
#include "drape/simulate/drape_inputs.h"
#include "polyfit/eval/mesh_metrics.h"
#include "polyfit/mesh/decimation.h"
#include "polyfit/mesh/subdivision.h"
#include "polyfit/util/atomic_file.h"

namespace polyfit {
namespace {

constexpr char kDecimatedTag[] = "~decimated";
constexpr char kSubdividedTag[] = "~subdivided";
constexpr char kRepatchedTag[] = "~patched";
constexpr char kOffsetTag[] = "~offset";
constexpr char kProceduralTag[] = "~procedural";

// The garment moved `distance` along its vertex normals.
TriangleMesh OffsetAlongNormals(const TriangleMesh& mesh, double distance) {
  TriangleMesh moved = mesh;
  moved.vertices += distance * VertexNormals(mesh);
  return moved;
}

std::vector<OneFitTrainingGarment> LoadGarments(const OneFitTrainingRunOptions& options, const SkinnedBody& body) {
  std::vector<OneFitTrainingGarment> garments;
  for (const std::string& path : options.garment_paths) {
    OneFitTrainingGarment g;
    g.name = std::filesystem::path(path).stem().string();
    g.mesh = LoadDrapeGarment(path, body, !options.body_dir.empty());
    try {
      g.weights = TransferSkinWeights(body, g.mesh, options.skin);
    } catch (const std::invalid_argument& e) {
      throw Error(ErrorKind::kInput, path + ": " + e.what());
    }
    garments.push_back(std::move(g));
  }
  // After every original, so that garment 0 (the validation drape's) stays
  // the first one given.
  const size_t originals = garments.size();
  auto add_remeshed = [&](const char* tag, const char* flag, const auto& remesh) {
    for (size_t i = 0; i < originals; ++i) {
      OneFitTrainingGarment copy;
      copy.name = garments[i].name + tag;
      try {
        copy.mesh = remesh(garments[i].mesh);
        copy.weights = TransferSkinWeights(body, copy.mesh, options.skin);
      } catch (const std::invalid_argument& e) {
        throw Error(ErrorKind::kInput, options.garment_paths[i] + ": " + flag + ": " + e.what());
      }
      garments.push_back(std::move(copy));
    }
  };
  if (options.decimate > 0.0) {
    add_remeshed(kDecimatedTag, "--decimate",
                 [&](const TriangleMesh& mesh) { return DecimateMesh(mesh, options.decimate); });
  }
  if (options.subdivide) {
    add_remeshed(kSubdividedTag, "--subdivide", [](const TriangleMesh& mesh) { return SubdivideMidpoint(mesh); });
  }
  const size_t given = options.garment_paths.size();
  for (size_t i = 0; i < given; ++i) {
    for (double distance : options.garment_offsets) {
      OneFitTrainingGarment o;
      std::ostringstream name;
      name << garments[i].name << kOffsetTag << (distance > 0.0 ? "+" : "") << distance * 1e3 << "mm";
      o.name = name.str();
      try {
        o.mesh = OffsetAlongNormals(garments[i].mesh, distance);
        o.weights = TransferSkinWeights(body, o.mesh, options.skin);
      } catch (const std::invalid_argument& e) {
        throw Error(ErrorKind::kInput, options.garment_paths[i] + ": --garment-offsets: " + e.what());
      }
      garments.push_back(std::move(o));
    }
  }
  const size_t meshings = garments.size();
  for (int k = 1; k <= options.repatch; ++k) {
    for (size_t i = 0; i < meshings; ++i) {
      OneFitTrainingGarment r = garments[i];
      r.name += kRepatchedTag + std::to_string(k);
      r.patch_seed = garments[i].patch_seed + static_cast<std::uint64_t>(k);
      garments.push_back(std::move(r));
    }
  }
  // Cut from this body, so that a sampled shape's are fitted to it; the
  // same cuts for every body.
  for (int k = 0; k < options.procedural_garments; ++k) {
    const ProceduralGarmentOptions cut = DrawProceduralGarment(options.trainer.seed * 104729 + 17 + k);
    OneFitTrainingGarment p;
    p.name = std::string(kProceduralTag) + std::to_string(k) + " " + cut.Describe();
    try {
      p.mesh = MakeProceduralGarment(body, cut);
      p.weights = TransferSkinWeights(body, p.mesh, options.skin);
    } catch (const std::invalid_argument& e) {
      throw Error(ErrorKind::kInput, std::string("--procedural-garments: ") + e.what());
    }
    garments.push_back(std::move(p));
  }
  return garments;
}

// One clip retargeted onto the body, played at `speed`.
OneFitTrainingClip LoadClip(const std::string& path, double speed, const OneFitTrainingRunOptions& options,
                            const SkinnedBody& body) {
  const double fps = options.trainer.drape.physics.fps;
  const auto retargeter = LoadRetargetedClip(path, options.bvh_units_to_metres, fps / speed, body.skeleton);
  OneFitTrainingClip clip;
  clip.name = std::filesystem::path(path).stem().string();
  if (speed != 1.0) {
    std::ostringstream name;
    name << clip.name << "@" << speed << "x";
    clip.name = name.str();
  }
  clip.fps = fps;
  clip.shape = options.shape;
  const int frames = options.max_frames_per_clip > 0 ? std::min(options.max_frames_per_clip, retargeter->num_frames())
                                                     : retargeter->num_frames();
  for (int f = 0; f < frames; ++f) clip.poses.push_back(retargeter->Pose(f));
  return clip;
}

// What LoadClips appends to the names of the clips it makes.
constexpr char kMixedTag[] = "~mixed";
constexpr char kExcursionTag[] = "~excursion";
constexpr char kPerturbedTag[] = "~perturbed";

// How many of `items` have `first` in their name, and how many of the rest
// have `second` (the tags LoadClips and LoadGarments append).
template <typename T>
std::pair<long, long> CountTagged(const std::vector<T>& items, const char* first, const char* second) {
  long a = 0, b = 0;
  for (const T& item : items) {
    if (item.name.find(first) != std::string::npos) {
      ++a;
    } else if (item.name.find(second) != std::string::npos) {
      ++b;
    }
  }
  return {a, b};
}

// "N clips per body (R recorded, M mixed[, E with excursions][, each also perturbed])".
std::string ClipReport(const std::vector<OneFitTrainingClip>& clips) {
  const auto [perturbed, excursions] = CountTagged(clips, kPerturbedTag, kExcursionTag);
  const long mixed = std::count_if(clips.begin(), clips.end(), [](const OneFitTrainingClip& c) {
    return c.name.find(kMixedTag) != std::string::npos && c.name.find(kPerturbedTag) == std::string::npos &&
           c.name.find(kExcursionTag) == std::string::npos;
  });
  const long recorded = static_cast<long>(clips.size()) - perturbed - excursions - mixed;
  return std::to_string(clips.size()) + " clips per body (" + std::to_string(recorded) + " recorded, " +
         std::to_string(mixed) + " mixed" +
         (excursions > 0 ? ", " + std::to_string(excursions) + " with excursions" : "") +
         (perturbed > 0 ? ", each also perturbed)" : ")");
}

// "N garments per body (G given, D decimated[, S subdivided][, O offset], R re-patched[, P procedural])".
std::string GarmentReport(const std::vector<OneFitTrainingGarment>& garments) {
  const auto [repatched, decimated] = CountTagged(garments, kRepatchedTag, kDecimatedTag);
  const long offset = std::count_if(garments.begin(), garments.end(), [](const OneFitTrainingGarment& g) {
    return g.name.find(kOffsetTag) != std::string::npos && g.name.find(kRepatchedTag) == std::string::npos;
  });
  const long procedural = std::count_if(garments.begin(), garments.end(), [](const OneFitTrainingGarment& g) {
    return g.name.find(kProceduralTag) != std::string::npos;
  });
  const long subdivided = std::count_if(garments.begin(), garments.end(), [](const OneFitTrainingGarment& g) {
    return g.name.find(kSubdividedTag) != std::string::npos && g.name.find(kRepatchedTag) == std::string::npos;
  });
  const long given = static_cast<long>(garments.size()) - decimated - subdivided - repatched - offset - procedural;
  return std::to_string(garments.size()) + " garments per body (" + std::to_string(given) + " given, " +
         std::to_string(decimated) + " decimated, " +
         (subdivided > 0 ? std::to_string(subdivided) + " subdivided, " : "") +
         (offset > 0 ? std::to_string(offset) + " offset, " : "") + std::to_string(repatched) + " re-patched" +
         (procedural > 0 ? ", " + std::to_string(procedural) + " procedural)" : ")");
}

// Frame f of a clip played forth and back (a donor shorter than its base
// turns round rather than jumping back to its start).
int PingPong(int f, int length) {
  if (length <= 1) return 0;
  const int period = 2 * (length - 1);
  const int phase = f % period;
  return phase < length ? phase : period - phase;
}

// `count` clips, each a recorded one (its root, hips and legs) whose limb
// groups (DefaultMixGroups) move as other recorded clips do, each group
// from its own clip and seeded start: combinations of joint angles that
// no recorded clip has, each limb's motion still recorded and smooth.
void AppendMixedClips(const OneFitTrainingRunOptions& options, const Skeleton& skeleton,
                      std::vector<OneFitTrainingClip>* clips) {
  const std::vector<std::string> group_roots = DefaultMixGroups();
  std::vector<int> groups;
  try {
    groups = JointGroups(skeleton, group_roots);
  } catch (const std::invalid_argument& e) {
    throw Error(ErrorKind::kInput, std::string("--mix-clips: ") + e.what());
  }
  const int num_groups = static_cast<int>(group_roots.size());
  const int recorded = static_cast<int>(clips->size());
  std::mt19937_64 rng(options.trainer.seed * 7919 + 13);
  std::uniform_int_distribution<int> pick(0, recorded - 1);
  for (int m = 0; m < options.mix_clips; ++m) {
    OneFitTrainingClip mixed = (*clips)[pick(rng)];
    std::vector<int> donor(num_groups), start(num_groups);
    for (int g = 0; g < num_groups; ++g) {
      donor[g] = pick(rng);
      start[g] = std::uniform_int_distribution<int>(0, int((*clips)[donor[g]].poses.size()) - 1)(rng);
    }
    mixed.name += kMixedTag + std::to_string(m);
    std::vector<const JointTransforms*> donor_poses(num_groups);
    for (size_t f = 0; f < mixed.poses.size(); ++f) {
      for (int g = 0; g < num_groups; ++g) {
        const auto& poses = (*clips)[donor[g]].poses;
        donor_poses[g] = &poses[PingPong(start[g] + static_cast<int>(f), static_cast<int>(poses.size()))];
      }
      mixed.poses[f] = MixPoses(skeleton, mixed.poses[f], donor_poses, groups);
    }
    clips->push_back(std::move(mixed));
  }
}

// `count` clips, each a recorded or mixed one (seeded picks) whose limbs
// also make the excursions of DefaultLimbExcursions, seeded per clip.
void AppendExcursionClips(const OneFitTrainingRunOptions& options, const Skeleton& skeleton,
                          std::vector<OneFitTrainingClip>* clips) {
  const std::vector<JointExcursion> ranges = DefaultLimbExcursions();
  const int sources = static_cast<int>(clips->size());
  std::mt19937_64 rng(options.trainer.seed * 104729 + 17);
  std::uniform_int_distribution<int> pick(0, sources - 1);
  for (int e = 0; e < options.excursion_clips; ++e) {
    OneFitTrainingClip clip = (*clips)[pick(rng)];
    const double duration = static_cast<double>(clip.poses.size()) / clip.fps;
    const LimbExcursion excursion = [&] {
      try {
        return LimbExcursion(skeleton, ranges, duration, rng());
      } catch (const std::invalid_argument& error) {
        throw Error(ErrorKind::kInput, std::string("--limb-excursions: ") + error.what());
      }
    }();
    clip.name += kExcursionTag + std::to_string(e);
    for (size_t f = 0; f < clip.poses.size(); ++f) {
      clip.poses[f] = excursion.Apply(clip.poses[f], static_cast<double>(f) / clip.fps);
    }
    clips->push_back(std::move(clip));
  }
}

std::vector<OneFitTrainingClip> LoadClips(const OneFitTrainingRunOptions& options, const SkinnedBody& body) {
  std::vector<OneFitTrainingClip> clips;
  std::vector<int> mirror_map;
  if (options.mirror) {
    try {
      mirror_map = MirrorJointMap(body.skeleton);
    } catch (const std::invalid_argument& e) {
      throw Error(ErrorKind::kInput, std::string("--mirror: ") + e.what());
    }
  }
  for (const std::string& path : options.motion_paths) {
    for (const double speed : options.speeds) {
      // Without a validation motion the validation drape reads the first
      // clip as recorded.
      clips.push_back(LoadClip(path, speed, options, body));
      if (options.mirror) {
        OneFitTrainingClip mirrored = clips.back();
        mirrored.name += "~mirrored";
        for (auto& pose : mirrored.poses) pose = MirrorPose(pose, mirror_map);
        clips.push_back(std::move(mirrored));
      }
    }
  }
  if (options.mix_clips > 0) AppendMixedClips(options, body.skeleton, &clips);
  if (options.excursion_clips > 0) AppendExcursionClips(options, body.skeleton, &clips);
  if (options.perturb_degrees > 0.0) {
    const size_t recorded = clips.size();
    for (size_t c = 0; c < recorded; ++c) {
      OneFitTrainingClip perturbed = clips[c];
      perturbed.name += kPerturbedTag;
      const PosePerturbation perturbation(body.skeleton, options.perturb_degrees * M_PI / 180.0,
                                          options.trainer.seed * 1000 + c);
      for (size_t f = 0; f < perturbed.poses.size(); ++f) {
        perturbed.poses[f] = perturbation.Apply(perturbed.poses[f], static_cast<double>(f) / perturbed.fps);
      }
      clips.push_back(std::move(perturbed));
    }
  }
  return clips;
}

// The lowest validation loss (the last column) of a progress file's rows;
// infinity when none has one.
double BestValidationLoss(const std::string& csv) {
  double best = std::numeric_limits<double>::infinity();
  std::istringstream rows(csv);
  std::string row;
  std::getline(rows, row);  // the header: earlier runs' files had no loss column
  if (row.find("validation_loss_J") == std::string::npos) return best;
  while (std::getline(rows, row)) {
    const size_t comma = row.rfind(',');
    if (comma == std::string::npos || comma + 1 >= row.size()) continue;
    const double loss = std::strtod(row.c_str() + comma + 1, nullptr);
    if (std::isfinite(loss) && loss > 0.0) best = std::min(best, loss);
  }
  return best;
}

// Batches already done (the progress file's rows), for a resumed run.
int BatchesDone(const std::string& csv_path) {
  std::ifstream in(csv_path);
  int rows = -1;  // the header
  for (std::string line; std::getline(in, line);) rows += line.empty() ? 0 : 1;
  return std::max(rows, 0);
}

}  // namespace

std::string OneFitTrainingRunOptions::Validate() const {
  if (garment_paths.empty()) return "at least one garment is needed";
  if (motion_paths.empty()) return "at least one motion clip is needed";
  if (model_path.empty()) return "an output model path is needed";
  if (!(bvh_units_to_metres > 0.0)) return "bvh_units_to_metres must be positive";
  if (max_frames_per_clip < 0) return "max_frames_per_clip must be >= 0";
  if (speeds.empty()) return "speeds must not be empty";
  for (double speed : speeds) {
    if (!(speed >= 0.25 && speed <= 4.0)) return "speeds must be in [0.25, 4]";
  }
  if (!(perturb_degrees >= 0.0 && perturb_degrees <= 45.0)) return "perturb_degrees must be in [0, 45]";
  if (shape_samples < 0 || shape_samples > 64) return "shape_samples must be in [0, 64]";
  if (mix_clips < 0 || mix_clips > 1000) return "mix_clips must be in [0, 1000]";
  if (excursion_clips < 0 || excursion_clips > 1000) return "excursion_clips must be in [0, 1000]";
  if (!(decimate >= 0.0 && decimate < 1.0)) return "decimate must be in [0, 1)";
  if (repatch < 0 || repatch > 16) return "repatch must be in [0, 16]";
  for (double d : garment_offsets) {
    if (!(std::abs(d) <= 0.03) || d == 0.0) return "garment_offsets must be non-zero and within 0.03 m";
  }
  if (shape_samples > 0 && body_dir.empty()) return "shape_samples needs the MakeHuman body (a body folder)";
  if (procedural_garments < 0 || procedural_garments > 64) return "procedural_garments must be in [0, 64]";
  if (procedural_garments > 0 && body_dir.empty()) {
    return "procedural_garments needs the MakeHuman body (a body folder): they are cut from its skin";
  }
  if (std::string p = shape.Validate(); !p.empty()) return "shape: " + p;
  if (std::string p = trainer.Validate(); !p.empty()) return "trainer: " + p;
  return {};
}

namespace {

// The body shapes trained on: the given one, then shape_samples drawn
// uniformly in range.
std::vector<BodyShape> TrainingShapes(const OneFitTrainingRunOptions& options) {
  std::vector<BodyShape> shapes = {options.shape};
  std::mt19937_64 rng(options.trainer.seed * 7919 + 17);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int k = 0; k < options.shape_samples; ++k) {
    BodyShape s;
    for (double* value : {&s.gender, &s.muscle, &s.weight, &s.height, &s.proportions}) *value = unit(rng);
    shapes.push_back(s);
  }
  return shapes;
}

// Per shape: the body, the garments fitted to it and the clips on its rig
// (*data_report: GarmentReport and ClipReport of the first body's).
std::vector<OneFitTrainingBody> LoadTrainingBodies(const OneFitTrainingRunOptions& options, const SkinnedBody& body,
                                                   std::string* data_report) {
  std::vector<OneFitTrainingBody> bodies;
  for (const BodyShape& shape : TrainingShapes(options)) {
    OneFitTrainingBody b;
    b.body = bodies.empty() ? body : LoadDrapeBody(options.body_dir, shape);
    b.garments = LoadGarments(options, b.body);
    b.clips = LoadClips(options, b.body);
    for (OneFitTrainingClip& clip : b.clips) clip.shape = shape;
    if (bodies.empty()) *data_report = GarmentReport(b.garments) + ", " + ClipReport(b.clips);
    bodies.push_back(std::move(b));
  }
  return bodies;
}

// The trainer, its validation clip, and the weights to start from: new
// ones, or a model's when fine-tuning (which keeps the model's
// architecture: its warp head, local pose and frame alignment).
std::unique_ptr<OneFitTrainer> MakeTrainer(const OneFitTrainingRunOptions& options, const SkinnedBody& body,
                                           std::vector<double>* weights, std::string* data_report) {
  OneFitModel init;
  OneFitTrainerOptions trainer_options = options.trainer;
  // A fine-tune skins its garments as the model's training did.
  OneFitTrainingRunOptions data = options;
  if (!options.init_model_path.empty()) {
    init = LoadOneFitModel(options.init_model_path);
    data.skin = init.skin;
    trainer_options.network.warp_order = init.network.warp_order();
    trainer_options.network.local_pose = init.network.local_pose();
    trainer_options.network.body_proximity = init.network.body_proximity();
    if (init.network.body_proximity()) trainer_options.network.proximity_probes = init.network.proximity_probes();
    trainer_options.network.feedback = init.network.feedback();
    if (init.network.feedback()) trainer_options.network.feedback_passes = init.network.feedback_passes();
    trainer_options.root_rotation = init.root_rotation;
    trainer_options.area_units = init.area_units;
    trainer_options.joint_mask_reach = init.joint_mask_reach;
    trainer_options.warp_slide_bound = init.warp_slide_bound;
    PatchLikeModel(init, &trainer_options.drape);
  }
  trainer_options.skin = data.skin;
  auto trainer = std::make_unique<OneFitTrainer>(LoadTrainingBodies(data, body, data_report), trainer_options);
  if (!options.validation_motion_path.empty()) {
    trainer->SetValidationClip(LoadClip(options.validation_motion_path, 1.0, options, body));
  }
  *weights = trainer->InitialWeights();
  if (!options.init_model_path.empty()) {
    try {
      trainer->StartFrom(init);
    } catch (const std::invalid_argument& e) {
      throw Error(ErrorKind::kInput, options.init_model_path + ": " + e.what());
    }
    *weights = init.weights;
  }
  return trainer;
}

// Where a resumed run starts: the checkpoint's weights (into *weights), the
// batches done, the progress file so far and Adam's moments.
struct ResumePoint {
  int first_batch = 0;
  std::string csv;
  OneFitAdamState adam;
};

ResumePoint Resume(const OneFitTrainingRunOptions& options, const OneFitModel& fresh, std::vector<double>* weights) {
  ResumePoint point;
  const std::string csv_path = options.model_path + ".csv";
  if (options.resume && std::filesystem::exists(options.model_path)) {
    const OneFitModel saved = LoadOneFitModel(options.model_path);
    if (saved.weights.size() != weights->size() || saved.root_rotation != fresh.root_rotation ||
        saved.area_units != fresh.area_units || saved.joint_mask_reach != fresh.joint_mask_reach ||
        saved.warp_slide_bound != fresh.warp_slide_bound) {
      throw Error(ErrorKind::kInput, options.model_path + ": a model of another layout; cannot resume from it");
    }
    *weights = saved.weights;
    point.first_batch = BatchesDone(csv_path);
    std::ifstream in(csv_path);
    std::stringstream text;
    text << in.rdbuf();
    point.csv = text.str();
  }
  // Adam's moments: from the checkpoint when resuming (a run killed before
  // they were first written restarts them).
  const std::string adam_path = options.model_path + ".adam";
  if (point.first_batch > 0 && std::filesystem::exists(adam_path)) {
    point.adam = LoadOneFitAdamState(adam_path, weights->size());
    // Written before the model: a kill between the two leaves it a batch
    // ahead, and then it is not this checkpoint's.
    if (point.adam.steps != static_cast<long long>(point.first_batch) * options.trainer.iterations_per_batch) {
      point.adam = OneFitAdamState{};
    }
    // With averaging the model holds the average: Adam goes on from the
    // weights it stepped.
    if (!point.adam.stepped.empty()) *weights = std::move(point.adam.stepped);
    point.adam.stepped.clear();
  }
  if (point.csv.empty()) {
    point.csv =
        "batch,initial_loss_J,final_loss_J,iterations,time_s,validation_inside_percent,validation_edge_strain_"
        "percent,validation_loss_J\n";
  }
  return point;
}

std::string ProgressRow(const OneFitBatchSummary& batch) {
  std::ostringstream row;
  row.precision(8);
  row << batch.batch << ',' << batch.initial_loss << ',' << batch.final_loss << ',' << batch.iterations << ','
      << batch.time_s << ',';
  if (std::isfinite(batch.validation_inside_percent)) {
    row << batch.validation_inside_percent << ',' << batch.validation_edge_strain_percent << ','
        << batch.validation_loss;
  } else {
    row << ",,";
  }
  row << '\n';
  return row.str();
}

// MODEL.polish.csv: the start, then a row per step (rejected ones too).
void WritePolishProgress(const OneFitPolishSummary& polish, std::ostream& out) {
  out.precision(8);
  out << "step,loss_J,damping,accepted,time_s\n0," << polish.initial_loss << ",,1,0\n";
  for (size_t i = 0; i < polish.steps.size(); ++i) {
    const OneFitPolishStep& step = polish.steps[i];
    out << i + 1 << ',' << step.loss << ',' << step.damping << ',' << (step.accepted ? 1 : 0) << ',' << step.time_s
        << '\n';
  }
}

// MODEL.teacher.csv: a row per batch of the warm start, then the
// validation drape after it.
void WriteTeacherProgress(const OneFitTeacherSummary& teacher, std::ostream& out) {
  out.precision(8);
  out << "# " << teacher.frames << " reference frames in " << teacher.reference_time_s
      << " s; validation after: " << teacher.validation_inside_percent << " % inside, "
      << teacher.validation_edge_strain_percent << " % strain, loss " << teacher.validation_loss << " J\n";
  for (const OneFitTeacherDrape& d : teacher.drapes) {
    out << "# " << d.garment << " on " << d.clip << ": " << d.frames << " frames (" << d.dropped << " dropped), "
        << d.from_skinning_mm << " mm from skinning, " << d.inside_percent << " % inside, " << d.edge_strain_percent
        << " % strain\n";
  }
  out << "batch,initial_rms_mm,final_rms_mm,time_s\n";
  for (const OneFitTeacherBatch& b : teacher.batches) {
    out << b.batch << ',' << b.initial_rms_mm << ',' << b.final_rms_mm << ',' << b.time_s << '\n';
  }
}

}  // namespace

OneFitTrainingSummary RunOneFitTraining(const OneFitTrainingRunOptions& options, const OneFitProgress& progress,
                                        const OneFitPolishProgress& polish_progress,
                                        const OneFitTeacherProgress& teacher_progress) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw Error(ErrorKind::kInvalidArgument, "onefit train: " + problem);
  }
  const SkinnedBody body = LoadDrapeBody(options.body_dir, options.shape);
  std::vector<double> weights;
  std::string data_report;
  const std::unique_ptr<OneFitTrainer> trainer = MakeTrainer(options, body, &weights, &data_report);
  ResumePoint resume = Resume(options, trainer->MakeModel(weights), &weights);
  double best_loss = BestValidationLoss(resume.csv);
  // Shared over processes, every one holds the same weights: the first
  // writes them.
  const bool writer = options.trainer.distribution.process == 0;
  const auto checkpoint = [&](const OneFitBatchSummary& batch, const std::vector<double>& w,
                              const std::vector<double>& validated) {
    if (!writer) return;
    if (options.trainer.optimizer == OneFitOptimizer::kAdam) {
      // With averaging the model is the average and the stepped weights
      // go with Adam's state.
      if (options.trainer.average_batches > 0) resume.adam.stepped = w;
      SaveOneFitAdamState(options.model_path + ".adam", resume.adam);
      resume.adam.stepped.clear();
    }
    SaveOneFitModel(options.model_path, trainer->MakeModel(validated));
    // The model that generalises best to the held-out motion so far.
    if (!options.validation_motion_path.empty() && batch.validation_loss < best_loss) {
      best_loss = batch.validation_loss;
      SaveOneFitModel(options.model_path + ".best", trainer->MakeModel(validated));
    }
    resume.csv += ProgressRow(batch);
    WriteFileAtomically(options.model_path + ".csv", [&](std::ostream& out) { out << resume.csv; });
    if (progress) progress(batch);
  };
  OneFitTeacherSummary teacher;
  if (resume.first_batch == 0 && options.trainer.teacher.batches > 0) {
    teacher = trainer->Teach(&weights, writer ? teacher_progress : nullptr);
    if (writer) {
      WriteFileAtomically(options.model_path + ".teacher.csv",
                          [&](std::ostream& out) { WriteTeacherProgress(teacher, out); });
    }
  }
  OneFitTrainingSummary summary = trainer->Train(&weights, resume.first_batch, checkpoint, &resume.adam);
  summary.teacher = teacher;
  if (resume.first_batch > 0) summary.message += "; resumed at batch " + std::to_string(resume.first_batch);
  if (options.trainer.polish.iterations > 0 && summary.termination_type != TerminationType::kFailure) {
    summary.polish = trainer->PolishOutputLayer(&weights, writer ? polish_progress : nullptr);
    if (writer) {
      SaveOneFitModel(options.model_path, trainer->MakeModel(weights));
      WriteFileAtomically(options.model_path + ".polish.csv",
                          [&](std::ostream& out) { WritePolishProgress(summary.polish, out); });
    }
  }
  summary.message += "; " + data_report;
  if (const std::string mask = trainer->JointMaskReport(); !mask.empty()) summary.message += "; " + mask;
  if (options.shape_samples > 0) {
    summary.message += "; body shapes";
    for (const BodyShape& shape : TrainingShapes(options)) summary.message += " {" + shape.ToString() + "}";
  }
  return summary;
}

}  // namespace polyfit
