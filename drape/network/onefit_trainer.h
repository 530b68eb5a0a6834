// OneFit's self-supervised training as a Ceres problem over the network's
// weights. The loss of a sample (garment g, clip c, frame t) is the
// reference drape's energy (DrapeSolver::Evaluate: collision, edge and
// metric inextensibility, patch boundaries, gravity folded into inertia)
// at the patch parameters the network predicts for frame t, with inertia
// predicted from the network's own positions at t - 1 and t - 2 (held as
// data: no gradient flows into earlier frames). A mini-batch's loss is the
// mean over its samples; its gradient is the hand-written backward pass
// (onefit_network.h) chained onto the energy's gradient. Each batch is a
// ceres::GradientProblem solved by L-BFGS for a few iterations (L-BFGS
// restarts with each Solve), then the next batch is drawn.
#ifndef POLYFIT_DRAPE_NETWORK_ONEFIT_TRAINER_H_
#define POLYFIT_DRAPE_NETWORK_ONEFIT_TRAINER_H_

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "drape/body/makehuman_body.h"
#include "drape/garment/skin_transfer.h"
#include "drape/network/onefit_features.h"
#include "drape/network/onefit_model.h"
#include "drape/network/onefit_network.h"
#include "drape/simulate/drape_solver.h"
#include "polyfit/mesh/triangle_mesh.h"
#include "polyfit/util/status.h"

namespace polyfit {

class OutputProximity;
class PosedBodySamples;

struct OneFitTrainingGarment {
  std::string name;
  TriangleMesh mesh;  // in the body's rest pose
  SkinWeights weights;
  // Its patches' clustering seed (GarmentPatchOptions::seed): the same
  // garment under another seed is another layout of patches.
  std::uint64_t patch_seed = 1;
};

struct OneFitTrainingClip {
  std::string name;
  std::vector<JointTransforms> poses;  // one per frame, retargeted onto the body
  double fps = 30.0;
  BodyShape shape;
};

// One body shape's share of the training data: the body so shaped, the
// garments fitted to it and the clips retargeted onto its rig (their
// `shape` the body's). Samples pair a garment and a clip of the same body,
// so that a network trained on several learns what the shape does.
struct OneFitTrainingBody {
  SkinnedBody body;
  std::vector<OneFitTrainingGarment> garments;
  std::vector<OneFitTrainingClip> clips;
};

enum class OneFitOptimizer {
  kLbfgs,  // each batch a ceres::GradientProblem, L-BFGS (restarting per batch)
  kAdam    // the control: Adam steps, moments kept across batches
};

// A mini-batch shared over processes (MPI ranks; `mpirun -n N onefit
// train`): process p evaluates the batch's samples i with
// i % num_processes == p, and all_reduce sums a buffer over the processes in
// place (MPI_Allreduce with MPI_SUM), so that the batch's loss and gradient,
// and with them every step, are the same on each process. The library needs
// no MPI: the caller supplies the reduction.
struct OneFitDistribution {
  int process = 0;
  int num_processes = 1;
  std::function<void(double* values, int count)> all_reduce;
};

// The second-order polish of a trained network: its features frozen, the
// decoder's last layer (weights and biases: num_outputs() by width + 1,
// about 4k values) fitted by Levenberg-Marquardt on a fixed set of
// samples, with exact Gauss-Newton blocks. The layer is linear in its
// weights, so J^T J over them is each sample's J^T J in the patch
// parameters (DrapeSolver::EvaluateGaussNewton) chained through the output
// bounds and the patches' last hidden activations: no dense Jacobian over
// the weights is ever formed.
struct OneFitPolishOptions {
  int iterations = 0;  // Levenberg-Marquardt iterations (0: no polish)
  int samples = 128;   // drawn once, seeded, as batches are
  // lambda in (H + lambda diag(H)) step = -g: divided by 3 after a step
  // that lowers the loss, multiplied by 4 after one that does not.
  double initial_damping = 1e-3;
};

// A warm start from the reference drape (OneFitTrainer::Teach): the
// reference drape (DrapeSolver::Step: the training loss minimised over the
// patch parameters and every vertex's slide) runs on some training clips
// per garment, and the network is first fitted to its positions, by Adam on
// DrapeSolver::DistanceTo, before the self-supervised loss takes over.
// Training alone lands in a basin of the loss whose drapes keep skinning's
// strain, although the network's output space holds the reference drape's
// (docs/benchmarks.md, "its output space holds drapes with less strain").
struct OneFitTeacherOptions {
  // Per garment, this many of its body's training clips (drawn, seeded) the
  // reference drape runs on; 0: no teacher.
  int clips = 0;
  int max_frames = 0;  // per clip, from its start (0: all)
  int lead_in = 10;    // frames from rest into each clip's first pose (BlendFromRest)
  // A frame of the reference drape is a target only where the drape
  // holds: at most this share of its vertices inside the body and this
  // mean edge strain (%). The reference drape fails on some augmented
  // clips (the skirt falling through the body on a mirrored 131_01 at
  // 0.8x: 12.7% inside; a subdivided suit at 40% strain), and the squared
  // distance to such frames swamped the rest (the fit stalled at 38 mm).
  double max_inside_percent = 3.0;
  double max_edge_strain_percent = 15.0;
  // Adam batches (batch_size frames, iterations_per_batch steps each) on
  // the distance, the step warmed up and decayed as training's over them.
  int batches = 0;
  // Then, through training (Adam), each step's gradient also holds this
  // weight (J per m^2 of the distance) times the distance's gradient over
  // batch_size teacher frames, the weight falling linearly to 0 at the
  // last batch: the reference drape keeps pulling while the loss takes
  // over. 0: the warm start alone. Not after a resume (the reference
  // drapes are not kept).
  double weight = 0.0;
};

struct OneFitTrainerOptions {
  OneFitNetworkOptions network;
  // The loss: the reference drape's terms, weights and patches.
  DrapeSolverOptions drape;
  int batch_size = 8;
  int iterations_per_batch = 5;
  int num_batches = 20;
  int lbfgs_rank = 20;
  // The weights' unit for L-BFGS: its first step in a batch changes the
  // largest weight by about this much.
  double weight_step = 1e-2;
  // Adam measured better here (docs/benchmarks.md, "OneFit network").
  OneFitOptimizer optimizer = OneFitOptimizer::kAdam;
  // Adam's step size (weights' units), reached linearly over the first
  // warmup_batches batches (Adam's first steps move every weight by the
  // full rate: batch 0's loss rose from 42k to 100k J without a warm-up).
  // After the warm-up it follows a cosine down to learning_rate
  // final_rate_fraction at the last batch (1: constant): late batches'
  // steps then average out the mini-batches' noise instead of adding it.
  // 3e-4 down to 5%: on the shipped training an 8-13% lower loss than a
  // constant 1e-4, where the cosine alone at 1e-4 was 2-6% higher (the
  // training is limited by how far the weights get; docs/benchmarks.md).
  double learning_rate = 3e-4;
  int warmup_batches = 0;
  double final_rate_fraction = 0.05;
  // Polyak averaging (Adam only): the weights validated, kept in MODEL.best
  // and returned by Train are an exponential average of the weights after
  // each batch over about this many batches (decay 1 - 1 / N), while Adam
  // steps on the weights themselves; the average smooths the scatter of
  // the last batches' steps. 0: none (the last batch's weights).
  int average_batches = 0;
  // Decoupled weight decay (AdamW, Loshchilov and Hutter; Adam only): each
  // step also shrinks the layers' matrices (not the biases) by
  // rate * weight_decay, the rate following the schedule above. It holds
  // the weights near what the training data needs, against fitting the
  // training clips and garments at the cost of unseen ones. 0: none.
  double weight_decay = 0.0;
  std::uint64_t seed = 1;
  // k_ext's epoch (DrapePhysicsOptions::k_ext) over training: batches map
  // linearly onto [0, kext_final_epoch], so that the paper's 100-epoch
  // allowance is reached at the end of whatever budget is given.
  double kext_final_epoch = 100.0;
  // A curriculum on the collision weight: k_c is collision_start for the
  // first collision_ramp[0] of the batches, then rises linearly to the
  // loss's own (drape.physics.weights.collision) at collision_ramp[1] and
  // stays there; validation always weighs collisions at the loss's own.
  // Solved frame by frame in the output space, the suit's walk settles at
  // k_c 1 with 8% strain and, raised to 3 from there, keeps it (8.2%, 0.98%
  // inside) where the solve at 3 throughout lands at 10.8% (0.71% inside)
  // and a loss 60% higher; but a network trained so (from 1 over 0.4-0.7
  // of the shipped command's batches) ends where training at 3 throughout
  // does (docs/benchmarks.md). < 0: no curriculum, the default.
  double collision_start = -1.0;
  std::array<double, 2> collision_ramp = {0.4, 0.7};
  // How the body features hold the root's rotation (recorded in the
  // model): heading-free by default, so that which way the body faces
  // means nothing.
  RootRotation root_rotation = RootRotation::kHeadingFree;
  // Outputs and jet features in units of each patch's area (recorded in
  // the model; PatchOutputUnits): a remeshed garment's patches, whose
  // scales grow with their faces, are moved alike.
  bool area_units = true;
  // Each garment reads only the rotations of the joints that move it by
  // at least this skinning weight (BodyFeatureMask; recorded in the
  // model). 0: every joint's.
  double joint_mask_reach = 0.0;
  // The warp head's bound on each point's slide in units of its patch's
  // radius (PatchWarpBound; recorded in the model). 0: each coefficient is
  // bounded instead, which trains only up to kMaxTrainedWarpOrder.
  double warp_slide_bound = 0.0;
  // The garments' skinning transfer: the trainer takes garments already
  // skinned and only records it in the model (the training run sets it).
  SkinTransferOptions skin;
  // A validation drape every this many batches (0: none), over this many
  // frames (see OneFitBatchSummary).
  int validation_every = 25;
  int validation_frames = 30;
  int num_threads = 2;  // per process
  OneFitDistribution distribution;
  OneFitPolishOptions polish;
  OneFitTeacherOptions teacher;
  // The warps the network's own jets ask for as its warp head's target:
  // at each batch's start, per sample, the prediction's warps re-solved
  // (DrapeSolver::SolveWarps, warp_target_sweeps sweeps, under the loss's
  // collision settings), and every Adam step's gradient also holds this
  // weight (J per m^2) times the gradient, over the warps alone, of the
  // area-weighted squared distance to the positions they give
  // (DrapeSolver::DistanceTo). The target moves with the jets, unlike the
  // teacher's. 0: none. Needs a warp head and Adam.
  double warp_target_weight = 0.0;
  int warp_target_sweeps = 3;
  // The target re-solves each patch's translation with its warp
  // (SolveWarps' move_translations), and pulls the translation head too.
  bool warp_target_translations = false;

  std::string Validate() const;
};

struct OneFitBatchSummary {
  int batch = 0;
  double initial_loss = 0.0;  // the batch's mean energy (J) before its solve
  double final_loss = 0.0;    // and after
  int iterations = 0;
  // The loss grew over kSpikeRatio-fold within the batch (its steps threw
  // the patches off, as a warp head of order 3 or 4 did): the batch was
  // undone, weights and optimiser state restored (final_loss is what it
  // reached).
  bool undone = false;
  double time_s = 0.0;  // since training started
  // The validation drape (every validation_every batches, else NaN; on
  // process 0 only): the network alone on the first garment over frames
  // spread through the validation clip, epsilon_c and epsilon_e (%).
  double validation_inside_percent = std::numeric_limits<double>::quiet_NaN();
  double validation_edge_strain_percent = std::numeric_limits<double>::quiet_NaN();
  // With it, the mean loss (J) over the validation frames, at k_ext's final
  // epoch so that batches compare (the training loss's allowance changes
  // with the epoch).
  double validation_loss = std::numeric_limits<double>::quiet_NaN();
};

struct OneFitPolishStep {
  // J, mean over the polish's samples after the step (kept or not), with
  // the frames before predicted as at its start (as its model holds them):
  // kept when lower than the loss there.
  double loss = 0.0;
  double damping = 0.0;  // the step's lambda
  bool accepted = false;
  double time_s = 0.0;  // since the polish started
};

struct OneFitPolishSummary {
  TerminationType termination_type = TerminationType::kNoConvergence;
  std::string message;
  double initial_loss = 0.0, final_loss = 0.0;  // J, mean over the samples
  std::vector<OneFitPolishStep> steps;
  // The validation drape (as in OneFitBatchSummary) before and after.
  double validation_inside_before = 0.0, validation_strain_before = 0.0, validation_loss_before = 0.0;
  double validation_inside_after = 0.0, validation_strain_after = 0.0, validation_loss_after = 0.0;
  double total_time_s = 0.0;

  std::string BriefReport() const;
};

struct OneFitTeacherBatch {
  int batch = 0;
  // The root of the batch's mean squared distance to the reference drape
  // (area-weighted over vertices, mm) before its steps and after.
  double initial_rms_mm = 0.0, final_rms_mm = 0.0;
  double time_s = 0.0;  // since the teacher started (its reference drapes included)
};

// One reference drape of the teacher (a garment through a clip), over its
// frames kept: how far it is from the garment's rest patches skinned (what
// a new network predicts; RMS over vertices, mm), epsilon_c and epsilon_e
// (%), means.
struct OneFitTeacherDrape {
  std::string garment, clip;
  int frames = 0;   // kept as targets
  int dropped = 0;  // over the bounds (OneFitTeacherOptions), not kept
  double from_skinning_mm = 0.0, inside_percent = 0.0, edge_strain_percent = 0.0;
};

struct OneFitTeacherSummary {
  int frames = 0;  // the reference drape's frames kept as targets
  std::vector<OneFitTeacherDrape> drapes;
  double reference_time_s = 0.0;  // the reference drapes' time
  std::vector<OneFitTeacherBatch> batches;
  // The validation drape (OneFitBatchSummary's) after the warm start (on
  // process 0 only; NaN without validation).
  double validation_inside_percent = std::numeric_limits<double>::quiet_NaN();
  double validation_edge_strain_percent = std::numeric_limits<double>::quiet_NaN();
  double validation_loss = std::numeric_limits<double>::quiet_NaN();
  double total_time_s = 0.0;

  std::string BriefReport() const;
};

struct OneFitTrainingSummary {
  TerminationType termination_type = TerminationType::kConvergence;
  std::string message;
  std::vector<OneFitBatchSummary> batches;
  int undone_batches = 0;  // OneFitBatchSummary::undone
  double total_time_s = 0.0;
  OneFitPolishSummary polish;    // its steps empty without a polish
  OneFitTeacherSummary teacher;  // its batches empty without a teacher

  std::string BriefReport() const;
};

// The highest warp order (OneFitNetworkOptions::warp_order) a network
// trains at: its warp bounds each coefficient, not the slide, and at
// orders 3 and 4 the terms summed carry points off their patches, where
// the jets' extrapolation threw the loss to 1e20 J within 25 batches
// (docs/benchmarks.md).
inline constexpr int kMaxTrainedWarpOrder = 2;

// A batch whose loss ends more than this many times where it began is
// undone (OneFitBatchSummary::undone): no batch of a healthy run comes near
// it (the shipped runs stay under 3-fold).
inline constexpr double kSpikeRatio = 10.0;

// Adam's step size at its step `step` (counted over the whole run, from 0):
// linear over the warm-up, then learning_rate, or a cosine from it down to
// learning_rate final_rate_fraction at the last batch's last iteration.
double AdamStepSize(const OneFitTrainerOptions& options, long long step);

// The clip frame of the i-th of `count` validation frames spread evenly
// through a clip of clip_frames frames (count <= clip_frames).
int ValidationFrame(int i, int count, int clip_frames);

// One sample of the loss.
struct OneFitSample {
  int garment = 0;
  int clip = 0;
  int frame = 0;
};

class OneFitTrainer {
 public:
  // Throws std::invalid_argument for invalid options, no garment or clip,
  // or a garment the drape cannot patch (naming it).
  OneFitTrainer(const SkinnedBody& body, std::vector<OneFitTrainingGarment> garments,
                std::vector<OneFitTrainingClip> clips, const OneFitTrainerOptions& options);
  // Several body shapes (the first is the validation drape's); every body
  // needs a garment and a clip, and all share one rig's joints.
  OneFitTrainer(std::vector<OneFitTrainingBody> bodies, const OneFitTrainerOptions& options);
  ~OneFitTrainer();

  const OneFitNetwork& network() const { return network_; }
  int num_parameters() const { return network_.num_parameters(); }
  // New weights (seeded).
  std::vector<double> InitialWeights() const;
  // Per garment, how many joints' rotations it reads and which it does
  // not ("name 29/31 (not LeftToeBase RightToeBase)"), when
  // joint_mask_reach is set; else empty.
  std::string JointMaskReport() const;

  // The mean loss over `samples` and, if gradient is not null, its gradient
  // (num_parameters()); with a distribution, this process's share summed
  // over the processes (every process must call it with the same samples).
  // Thread-safe across distinct trainers only.
  double Loss(const double* weights, const std::vector<OneFitSample>& samples, double* gradient);

  // The trained network as a model file holds it.
  OneFitModel MakeModel(const std::vector<double>& weights) const;
  // Fine-tuning: the network and feature normalisers become the model's
  // (its weights are the caller's to start from). Throws
  // std::invalid_argument when the model's jets, rig or feature sizes differ
  // from this trainer's.
  void StartFrom(const OneFitModel& model);

  // Trains `weights` in place, batches first_batch .. num_batches - 1 (the
  // earlier ones are drawn and skipped, so that a resumed run sees the same
  // data order); after each batch, on_batch (when given) sees its summary,
  // the weights (to checkpoint them) and the weights its validation drape
  // ran on (their average with average_batches, else the weights). With
  // average_batches, *weights ends as the average.
  // adam: Adam's moments and the weights' average, carried in and out (a
  // resumed run passes the checkpointed ones, so that it ends where a
  // straight run ends); null: fresh ones.
  using BatchCallback = std::function<void(const OneFitBatchSummary&, const std::vector<double>& weights,
                                           const std::vector<double>& validated)>;
  OneFitTrainingSummary Train(std::vector<double>* weights, int first_batch = 0,
                              const BatchCallback& on_batch = nullptr, OneFitAdamState* adam = nullptr);

  // The warm start (OneFitTeacherOptions) of `weights`, in place: the
  // reference drapes, then Adam on the distance to them (fresh moments:
  // Train starts its own). With a distribution, every process runs every
  // reference drape (they are deterministic) and the batches' gradients are
  // summed as Train's. Nothing to do without teacher clips or batches.
  using TeacherCallback = std::function<void(const OneFitTeacherBatch&)>;
  OneFitTeacherSummary Teach(std::vector<double>* weights, const TeacherCallback& on_batch = nullptr);
  // The mean of DrapeSolver::DistanceTo over teacher frames (indices into
  // the frames Teach's reference drapes kept) and its gradient.
  double TeacherLoss(const double* weights, const std::vector<int>& frames, double* gradient);
  int num_teacher_frames() const { return static_cast<int>(teacher_.size()); }
  // The warp target's distance (OneFitTrainerOptions::warp_target_weight)
  // over given samples: the mean of DrapeSolver::DistanceTo from each
  // prediction to its own warps re-solved (m^2).
  double WarpTargetDistance(const double* weights, const std::vector<OneFitSample>& samples);

  // The second-order polish (OneFitPolishOptions) of `weights`, in place:
  // only the decoder's last layer changes, and only by steps that lower
  // the mean loss over the polish's samples. With a distribution, every
  // process must call it (the blocks are summed over processes).
  // on_step (when given) sees each step as it ends.
  using PolishCallback = std::function<void(int step, const OneFitPolishStep&)>;
  OneFitPolishSummary PolishOutputLayer(std::vector<double>* weights, const PolishCallback& on_step = nullptr);
  // Loss with the frames before predicted by other weights: the loss a
  // gradient (or a Gauss-Newton model) describes, which holds them as data.
  double LossWithHistory(const double* weights, const double* history_weights, const std::vector<OneFitSample>& samples,
                         double* gradient);
  // The mean loss over `samples` and its Gauss-Newton blocks over the
  // output layer's weights (num_output_layer_parameters() square, and the
  // gradient), at k_ext's current epoch.
  double OutputLayerGaussNewton(const double* weights, const std::vector<OneFitSample>& samples,
                                Eigen::MatrixXd* gauss_newton, Eigen::VectorXd* gradient);
  // The output layer's offset in the weights, and its size.
  int output_layer_offset() const;
  int num_output_layer_parameters() const;

  // A clip the validation drape runs on instead of the first training
  // clip, never trained on (nor read by the feature normalisers): a motion
  // held out, so that validation measures what training does to unseen
  // motion. The batches drawn stay those without it. It is the first
  // body's (retargeted onto its rig).
  void SetValidationClip(OneFitTrainingClip clip);

  // The collision weight of batch b (OneFitTrainerOptions::collision_start),
  // and every solver's set to a weight.
  double CollisionWeightAt(int batch) const;
  void SetCollisionWeight(double weight);

  // epsilon_c and epsilon_e (%) of the network's drape of a garment over
  // `frames` frames spread evenly through a clip (ValidationFrame) and,
  // when `loss` is not null, the mean loss over those frames at k_ext's
  // final epoch.
  void ValidationDrape(const double* weights, int garment, int clip, int frames, double* inside_percent,
                       double* edge_strain_percent, double* loss = nullptr);

  // The patch parameters the network predicts for a garment at a clip's
  // frame (the network alone, as DrapeSolver lays them out).
  std::vector<double> Predict(const double* weights, int garment, int clip, int frame);

 private:
  struct GarmentData;
  struct ProximityCache;
  using AdamState = OneFitAdamState;
  OneFitBatchSummary LbfgsBatch(const std::vector<OneFitSample>& batch, int index, std::vector<double>* weights);
  OneFitBatchSummary AdamBatch(const std::vector<OneFitSample>& batch, int index, AdamState* state,
                               std::vector<double>* weights);
  // iterations_per_batch Adam steps on `loss` (weights, gradient -> mean
  // loss) at the step sizes `rate` gives for Adam's step count; returns
  // the loss before the first step.
  double AdamSteps(const std::function<double(const double*, double*)>& loss,
                   const std::function<double(long long)>& rate, AdamState* state, std::vector<double>* weights);
  // The mean of sample_loss(i, thread, gradient) over count samples, this
  // process's share (i % num_processes == process) dealt to threads in a
  // fixed pattern, summed over the processes, and its gradient (added to
  // per thread by sample_loss) when not null.
  double MeanOverSamples(int count, const std::function<double(int, int, double*)>& sample_loss, double* gradient);
  // The network's outputs (num_outputs() by #patches) for a garment at a
  // clip's frame, after the feedback decoder's passes (their proximity in
  // *at); cache: the backward pass's (null: none, without feedback).
  void Outputs(const double* weights, int garment, int clip, int frame, int thread, Eigen::MatrixXd* outputs,
               OneFitNetwork::Cache* cache, std::vector<OutputProximity>* at);
  // Adds d(loss)/d(weights) into gradient from d(loss)/d(patch parameters)
  // at the outputs Outputs gave.
  void BackPropagate(const double* weights, const GarmentData& g, const Eigen::MatrixXd& outputs,
                     const OneFitNetwork::Cache& cache, const std::vector<OutputProximity>& at,
                     const std::vector<double>& d_params, double* gradient);
  // A reference drape's frame and the garment's positions there (3 by #V).
  struct TeacherFrame {
    int garment = 0, clip = 0, frame = 0;
    Eigen::Matrix3Xd target;
  };
  std::vector<TeacherFrame> teacher_;
  // The reference drape of a garment through a clip (lead-in from rest
  // included) on a thread's solver; its usable frames appended to *out,
  // and what they measure.
  OneFitTeacherDrape ReferenceDrape(int garment, int clip, int thread, std::vector<TeacherFrame>* out);
  // warps_only: the gradient over each patch's warp alone (and its
  // translation with translations; the rest held).
  double TeacherSampleLoss(const double* weights, const TeacherFrame& frame, int thread, double* gradient,
                           bool warps_only = false, bool translations = false);
  // The warp target (OneFitTrainerOptions::warp_target_weight): per
  // sample of a batch, the positions of its prediction with the warps
  // re-solved, and the mean distance to them with its gradient.
  std::vector<TeacherFrame> WarpTargets(const double* weights, const std::vector<OneFitSample>& batch);
  double WarpTargetLoss(const double* weights, const std::vector<TeacherFrame>& targets, double* gradient);
  void RunReferenceDrapes(std::mt19937_64* rng, OneFitTeacherSummary* summary);
  void AddGarment(const SkinnedBody& body, const OneFitTrainingGarment& garment, int body_index,
                  const DrapeSolverOptions& drape);
  Eigen::MatrixXd ClipBodyFeatures(int clip) const;
  // A frame's normalised body features as garment g reads them (its
  // BodyFeatureMask applied).
  Eigen::VectorXd GarmentBodyFeatures(const GarmentData& g, int clip, int frame) const;
  // With the body proximity, its features (kProximitySize by #patches) of
  // a garment at a clip's frame, posed on the thread's copy of the body;
  // else null. Valid until the thread's next call.
  const Eigen::MatrixXd* ProximityAt(int garment, int clip, int frame, int thread);
  // The thread's copy of a body posed at a clip's frame (posed again only
  // when another frame was posed last).
  PosedBodySamples& BodyPosedAt(int body, int clip, int frame, int thread);
  // With the feedback decoder: *outputs (D's, with the Forward's cache)
  // become F's refinement after its passes, the proximity each pass read
  // kept in *at (one per pass).
  void ApplyFeedback(const double* weights, int garment, int clip, int frame, int thread,
                     std::vector<OutputProximity>* at, OneFitNetwork::Cache* cache, Eigen::MatrixXd* outputs);
  // Predict on a thread's drape and body.
  std::vector<double> PredictOn(const double* weights, int garment, int clip, int frame, int thread);
  OneFitSample DrawSample(std::mt19937_64* rng) const;
  // A sample's history and pose set on its thread's drape, and the
  // network's outputs (num_outputs() by #patches) for its frame.
  // history_weights: the network that predicts the frames before (the
  // inertia's data), usually `weights` itself.
  void PrepareSample(const double* weights, const double* history_weights, const OneFitSample& sample, int thread,
                     double epoch, Eigen::MatrixXd* outputs, OneFitNetwork::Cache* cache);
  double SampleLoss(const double* weights, const double* history_weights, const OneFitSample& sample, int thread,
                    double* gradient, double epoch);
  // The polish's Gauss-Newton blocks of one sample over the output layer
  // (onefit_polish.cc), added into *gauss_newton and *gradient.
  // scratch: per thread, its large matrices' allocations reused.
  struct PolishScratch {
    Eigen::MatrixXd h_y, by_output, by_patch;
  };
  double SampleGaussNewton(const double* weights, const OneFitSample& sample, int thread, PolishScratch* scratch,
                           Eigen::MatrixXd* gauss_newton, Eigen::VectorXd* gradient);

  // Per body: its rig (the features read it) and its training clips.
  std::vector<Skeleton> skeletons_;
  std::vector<std::vector<int>> body_clips_;
  std::vector<OneFitTrainingClip> clips_;
  std::vector<int> clip_body_;  // per clip, its body
  OneFitTrainerOptions options_;
  std::vector<std::unique_ptr<GarmentData>> garments_;
  std::vector<std::unique_ptr<ProximityCache>> proximity_;  // per thread, with the body proximity
  FeatureNormalizer patch_normalizer_, body_normalizer_;
  OneFitNetwork network_;
  double epoch_ = 0.0;          // k_ext's, of the current batch
  int num_training_clips_ = 0;  // clips_ beyond these are for validation only
  int validation_clip_ = 0;
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_NETWORK_ONEFIT_TRAINER_H_
