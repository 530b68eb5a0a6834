// `onefit train`: loads a body, garments and motion clips, trains OneFit's
// network (onefit_trainer.h) and writes the model, checkpointed after every
// batch so that a killed run resumes (`resume`) where it stopped:
//   MODEL        the model file (docs/onefit-model-format.md), atomically
//                (with average_batches, the weights' average)
//   MODEL.adam   with Adam, its state (and with averaging the stepped
//                weights), for `resume`
//   MODEL.csv    batch, initial_loss_J, final_loss_J, iterations, time_s,
//                validation epsilon_c and epsilon_e (%, every few batches)
//                and the validation loss (J)
//   MODEL.best   with a validation motion: the model at the lowest
//                validation loss so far (early stopping without stopping)
//   MODEL.polish.csv  with a polish (OneFitPolishOptions), its steps; MODEL
//                is then the polished network
//   MODEL.teacher.csv  with a teacher (OneFitTeacherOptions), its batches
//                (the warm start runs before batch 0, not when resuming)
// Every input is checked before anything is written.
#ifndef POLYFIT_DRAPE_NETWORK_ONEFIT_TRAINING_RUN_H_
#define POLYFIT_DRAPE_NETWORK_ONEFIT_TRAINING_RUN_H_

#include <functional>
#include <string>
#include <vector>

#include "drape/body/body_shape.h"
#include "drape/garment/skin_transfer.h"
#include "drape/network/onefit_trainer.h"

namespace polyfit {

struct OneFitTrainingRunOptions {
  std::string body_dir;  // empty: the procedural body
  BodyShape shape;
  std::vector<std::string> garment_paths;
  std::vector<std::string> motion_paths;
  double bvh_units_to_metres = 0.056444;
  // Frames per clip, from its start (0: all).
  int max_frames_per_clip = 0;
  // Augmentation: each clip is also trained played at these speeds
  // (resampled at fps / speed, played at fps: faster motion, larger
  // inertia). {1}: as recorded.
  std::vector<double> speeds = {1.0};
  // Augmentation: each clip (at each speed) also mirrored left to right
  // (drape/motion/mirror_pose.h).
  bool mirror = false;
  // Augmentation: each of those clips also played with every joint's angle
  // perturbed smoothly by up to this many degrees per axis
  // (drape/motion/perturb_pose.h; seeded by trainer.seed); 0: none.
  double perturb_degrees = 0.0;
  // Augmentation: this many mixed clips (before the perturbation, which
  // then covers them too): each a recorded clip whose arms, neck and spine
  // move as other recorded clips' do, from seeded starts
  // (drape/motion/mix_pose.h; seeded by trainer.seed); 0: none.
  int mix_clips = 0;
  // Augmentation: this many more clips (after the mixed ones, before the
  // perturbation, which then covers them too), each a recorded or mixed
  // clip whose arms, legs and spine also swing between seeded key angles
  // far from any recording's: raised overhead, lunging, bent
  // (drape/motion/limb_excursion.h; seeded by trainer.seed); 0: none.
  int excursion_clips = 0;
  // Augmentation: each garment also trained decimated by edge collapse to
  // this fraction of its edges (polyfit/mesh/decimation.h; its skinning
  // transferred as a mesh file's is), so that the network sees more than
  // one meshing of it; 0: none.
  double decimate = 0.0;
  // Augmentation: each given garment also trained subdivided once at its
  // edges' midpoints (polyfit/mesh/subdivision.h: the same surface, four
  // times the faces), so that the loss's collision and strain terms also
  // see points between the given vertices, as a finer meshing has them.
  bool subdivide = false;
  // Augmentation: each given garment also moved along its vertex normals
  // by each of these distances (m; |d| <= 0.03): a looser (d > 0) or a
  // tighter (d < 0) garment of the same cut, its rest shape the moved one
  // (so a tighter copy must stretch where it meets the body), so that the
  // network sees more fits than the garments given; none by default.
  std::vector<double> garment_offsets;
  // Augmentation: each garment (decimated and offset ones too) also patched under this
  // many other clustering seeds, so that the network sees more than one
  // layout of patches on it (a network trained on one leaves more of the
  // same garment inside under another); 0: none.
  int repatch = 0;
  // Augmentation: this many tight garments cut from each body's own skin
  // (drape/garment/procedural_garment.h: a top, a bottom or a suit, sleeves
  // and legs of drawn lengths, 3-15 mm off the skin, about 2,000 vertices;
  // drawn with trainer.seed), after every other garment and not decimated,
  // offset or re-patched: more cuts and fits than the garments given, for
  // garments never seen (MakeHuman body only); 0: none.
  int procedural_garments = 0;
  // Augmentation: this many further body shapes, each macro value drawn
  // uniformly in [0, 1] (seeded by trainer.seed), each with the garments
  // fitted to it and the clips retargeted onto its rig, so that the
  // network learns what the shape features say (MakeHuman body only).
  int shape_samples = 0;
  // A motion held out of training for the validation drape (empty: the
  // first training clip's first frames are validated): its loss picks
  // MODEL.best.
  std::string validation_motion_path;
  std::string model_path;
  bool resume = false;
  // Fine-tuning: start from this model's network, normalisers and weights,
  // its garments skinned as the model's were (`skin` is then not read;
  // empty: a new network).
  std::string init_model_path;
  SkinTransferOptions skin;
  OneFitTrainerOptions trainer;

  std::string Validate() const;
};

// Called after every batch with its summary.
using OneFitProgress = std::function<void(const OneFitBatchSummary&)>;
// Called after every polish step (its number from 1) with it.
using OneFitPolishProgress = std::function<void(int, const OneFitPolishStep&)>;
// Called after every batch of the teacher's warm start with it.
using OneFitTeacherProgress = std::function<void(const OneFitTeacherBatch&)>;

// Throws an Error naming the file or option (kInput, kInvalidArgument)
// before anything is written; kOutput when the model cannot be written.
OneFitTrainingSummary RunOneFitTraining(const OneFitTrainingRunOptions& options,
                                        const OneFitProgress& progress = nullptr,
                                        const OneFitPolishProgress& polish_progress = nullptr,
                                        const OneFitTeacherProgress& teacher_progress = nullptr);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_NETWORK_ONEFIT_TRAINING_RUN_H_
