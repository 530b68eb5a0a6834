// OneFit's network (the paper's Sec. 4, supplement 7.5, sized for a CPU):
//
//   Z_T = E_T(patch features)        per patch, once per garment
//   Z_B = E_B(body features)         per frame, shared by all patches
//   y_k = D(concat(Z_T,k, Z_B[, x_k][, p_k]))  per patch: (d alpha, d s, d T)
//
// where x_k, with local_pose, is the patch's skinning-weighted share of the
// body features (LocalPoseFeatures, onefit_features.h), and p_k, with
// body_proximity, where the skinned patch meets the posed body
// (BodyProximityFeatures, body_proximity.h): inputs, not learnt, so that
// each patch also sees its own joints and the body next to it directly.
//
// With feedback (needs the body proximity), a second decoder F reads the
// proximity p'_k where the patch D's outputs give sits (PlaceProbes) and
// corrects them:
//
//   y'_k = y_k + F(concat(Z_T,k, Z_B, x_k, p_k, y_k, p'_k))
//
// so that a patch sees where its own prediction, not only its skinned
// rest, meets the body. p'_k depends on y_k through the distances to the
// nearest body samples (their derivative is the samples' normals; which
// sample is nearest is held): the gradient flows through it
// (ChainProbesToPatchParameters).
//
// E_T, E_B, D (and F) are MLPs (mlp.h) with skip connections; their
// weights are one flat vector [E_T | E_B | D | F]. The output of patch k
// (F's, with feedback) turns its rest parameters (alpha_0, s_0, T_0,
// frame R_0) into the drape's:
//
//   alpha = alpha_0 + u_a b_a(d alpha),   s = s_0 exp(b_s(d s)),   T = T_0 + L R_0 b_T(d T)
//
// with per patch units (PatchOutputMap): in the patch's own units (L = s_0,
// u = 1: models before file version 8) or in units of its area (L = rho =
// sqrt(A / pi), u_c = (s_0 / rho)^(deg c - 1)), which a remeshing leaves
// alone where s_0, the patch's largest extent, grows with its faces,
// in the body's rest pose, which the garment's skinning then poses, as in
// the reference drape (drape/simulate/drape_solver.h). With a warp head
// (warp_order >= 0) each patch also gets its in-plane warp's coefficients
// (DrapeSlideOptions::warp_order), w = u_w b_w(d w): the slides that undo
// skinning's in-plane distortion, which patch parameters alone cannot.
// b_c(y) = c tanh(y / c) (about y near zero): the bounds (jet coefficients
// by 1, scale by e^(+-0.25), centre by half the patch's size, warp by a
// quarter of it, or, with a slide bound B, the warp as a whole so that no
// point slides further than B r: BoundWarpComponent)
// keep a pose far from training (a cartwheel) from throwing patches away. Inputs are normalised features
// (onefit_features.h).
#ifndef POLYFIT_DRAPE_NETWORK_ONEFIT_NETWORK_H_
#define POLYFIT_DRAPE_NETWORK_ONEFIT_NETWORK_H_

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "drape/network/mlp.h"

namespace polyfit {

struct OneFitNetworkOptions {
  std::vector<int> patch_hidden = {64, 64};
  int patch_embedding = 32;
  std::vector<int> body_hidden = {128, 128};
  int body_embedding = 32;
  std::vector<int> decoder_hidden = {128, 128, 128};
  // The last layers start scaled by this: a new network predicts about
  // the rest patches, posed by skinning alone.
  double initial_output_scale = 1e-3;
  // The warp head's polynomial order (-1: none).
  int warp_order = -1;
  // The decoder also reads each patch's local pose x_k (kLocalPoseSize
  // values); Forward then needs the patches' joint weights.
  bool local_pose = false;
  // The decoder also reads each patch's body proximity p_k
  // (ProximitySize(proximity_probes) values: body_proximity.h's layouts of
  // 5 or 9 probes); Forward then needs them.
  bool body_proximity = false;
  int proximity_probes = 5;
  // The feedback decoder F (needs body_proximity), its hidden layers and
  // how many times it is applied, each pass reading the proximity where
  // the last one's patches sit (1 to kMaxFeedbackPasses).
  bool feedback = false;
  std::vector<int> feedback_hidden = {64, 64};
  int feedback_passes = 1;
  std::uint64_t seed = 1;

  std::string Validate() const;
};

template <typename T>
using MatrixX = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic>;
template <typename T>
using VectorX = Eigen::Matrix<T, Eigen::Dynamic, 1>;

class OneFitNetwork {
 public:
  OneFitNetwork() = default;
  // num_coefficients: the jets' (NumJetCoefficients(order)).
  OneFitNetwork(int patch_features, int body_features, int num_coefficients, const OneFitNetworkOptions& options);
  // From its three MLPs (a saved model); throws std::invalid_argument when
  // their sizes do not chain or proximity_probes is not a layout (0: no
  // body proximity). The decoder's input, less the proximity's, tells
  // whether it reads the local pose.
  // feedback: F, or an MLP without layers (Mlp()) for none, applied
  // feedback_passes times.
  OneFitNetwork(Mlp patch_encoder, Mlp body_encoder, Mlp decoder, int num_coefficients, int warp_order = -1,
                int proximity_probes = 0, Mlp feedback = Mlp(), int feedback_passes = 1);

  int num_parameters() const { return feedback_offset() + (feedback() ? feedback_.num_parameters() : 0); }
  // Per patch: NumJetCoefficients + 4 + 2 NumJetCoefficients(warp_order).
  int num_outputs() const { return decoder_.output_size(); }
  int num_coefficients() const { return num_coefficients_; }
  int warp_order() const { return warp_order_; }
  bool local_pose() const { return local_size_ > 0; }
  bool body_proximity() const { return proximity_size_ > 0; }
  // Probes per patch of the body proximity (0 without).
  int proximity_probes() const;
  const Mlp& patch_encoder() const { return patch_encoder_; }
  const Mlp& body_encoder() const { return body_encoder_; }
  const Mlp& decoder() const { return decoder_; }
  bool feedback() const { return !feedback_.sizes().empty(); }
  const Mlp& feedback_decoder() const { return feedback_; }
  // F's passes (0 without F).
  int feedback_passes() const { return feedback() ? feedback_passes_ : 0; }
  // Offsets of E_B's, D's and F's weights in the flat vector (E_T's is 0).
  int body_encoder_offset() const { return patch_encoder_.num_parameters(); }
  int decoder_offset() const { return body_encoder_offset() + body_encoder_.num_parameters(); }
  int feedback_offset() const { return decoder_offset() + decoder_.num_parameters(); }

  void Initialize(std::uint64_t seed, double output_scale, double* weights) const;
  // Where the layers' matrices W_l sit in the flat vector, as (offset,
  // size) pairs over every MLP (biases excluded): what weight decay shrinks.
  std::vector<std::pair<int, int>> WeightMatrixRanges() const;

  struct Cache {
    MlpCache patch, body, decoder;
    std::vector<MlpCache> feedback;  // per pass of F
    int num_patches = 0;
  };
  // patch_features: #patch features by #patches; body_features: one frame.
  // joint_weights: #joints by #patches (PatchJointWeights), needed with the
  // local pose, else ignored; proximity: ProximitySize(proximity_probes()) by #patches
  // (BodyProximityFeatures), needed with the body proximity, else ignored.
  // outputs: num_outputs() by #patches.
  void Forward(const double* weights, const Eigen::MatrixXd& patch_features, const Eigen::VectorXd& body_features,
               const Eigen::MatrixXd* joint_weights, const Eigen::MatrixXd* proximity, Eigen::MatrixXd* outputs,
               Cache* cache = nullptr) const;
  // Inference with the garment's half precomputed (once per garment): the
  // decoder's first layer splits as W [z_T; z_B] + b = (W_T z_T + b) + W_B z_B,
  // so per frame only W_B z_B (and W_x x_k, W_p p_k) is new. GarmentHalf:
  // first-layer width by #patches; ForwardWithGarmentHalf gives Forward's
  // outputs.
  // The per-frame half runs in T = double (what training sees) or float
  // (inference: twice the SIMD lanes; weights and garment half cast once
  // per garment, OneFitDraper); the inputs read from the body stay double.
  Eigen::MatrixXd GarmentHalf(const double* weights, const Eigen::MatrixXd& patch_features) const;
  // body_embedding, patch_inputs (may be null): z_B, and [x_k; p_k] (the
  // local pose's and proximity's rows by #patches, in T), for
  // FeedbackWithGarmentHalf.
  template <typename T>
  void ForwardWithGarmentHalf(const T* weights, const MatrixX<T>& garment_half, const Eigen::VectorXd& body_features,
                              const Eigen::MatrixXd* joint_weights, const Eigen::MatrixXd* proximity,
                              MatrixX<T>* outputs, VectorX<T>* body_embedding = nullptr,
                              MatrixX<T>* patch_inputs = nullptr) const;
  // Adds dL/dweights to gradient given dL/doutputs, and, when given,
  // dL/d(decoder input) that reached it otherwise (FeedbackBackward's).
  void Backward(const double* weights, const Cache& cache, const Eigen::MatrixXd& d_outputs, double* gradient,
                const Eigen::MatrixXd* d_decoder_input = nullptr) const;

  // The feedback pass (feedback()): refined = outputs + F([decoder input;
  // outputs; proximity]), the decoder's input being the cache's (Forward
  // with a cache); proximity: where the outputs' patches
  // meet the body (ProximitySize by #patches). cache (may be null): the
  // same Cache as Forward's, for FeedbackBackward; pass: which of F's
  // passes (its outputs the last pass's refined ones).
  void Feedback(const double* weights, const Eigen::MatrixXd& decoder_input, const Eigen::MatrixXd& outputs,
                const Eigen::MatrixXd& proximity, Eigen::MatrixXd* refined, Cache* cache = nullptr, int pass = 0) const;
  // Given dL/drefined: adds F's dL/dweights to gradient, sets d_outputs
  // (dL/doutputs through the skip and F's input: add what flows through
  // the proximity, then give it to the pass before, or to Backward) and
  // d_proximity (dL/dproximity), and adds dL/d(decoder input) to
  // *d_decoder_input (set when empty; Backward's), for F's pass `pass`
  // (the last first).
  void FeedbackBackward(const double* weights, const Cache& cache, const Eigen::MatrixXd& d_refined, double* gradient,
                        Eigen::MatrixXd* d_outputs, Eigen::MatrixXd* d_proximity, Eigen::MatrixXd* d_decoder_input,
                        int pass = 0) const;
  // Inference with the feedback decoder's garment half precomputed, as
  // the decoder's: FeedbackGarmentHalf is W_F,T z_T + b_F (F's first-layer
  // width by #patches, once per garment); FeedbackWithGarmentHalf gives
  // Feedback's refined outputs from the frame's z_B and [x_k; p_k]
  // (ForwardWithGarmentHalf's body_embedding and patch_inputs), D's outputs
  // and the proximity at them.
  Eigen::MatrixXd FeedbackGarmentHalf(const double* weights, const Eigen::MatrixXd& patch_features) const;
  template <typename T>
  void FeedbackWithGarmentHalf(const T* weights, const MatrixX<T>& feedback_half, const VectorX<T>& body_embedding,
                               const MatrixX<T>& patch_inputs, const MatrixX<T>& outputs,
                               const Eigen::MatrixXd& output_proximity, MatrixX<T>* refined) const;

 private:
  void Check();
  Eigen::MatrixXd AssembleDecoderInput(const Eigen::MatrixXd& z_t, const Eigen::MatrixXd& z_b,
                                       const Eigen::VectorXd& body_features, const Eigen::MatrixXd* joint_weights,
                                       const Eigen::MatrixXd* proximity) const;
  void EncodersBackward(const double* weights, const Cache& cache, const Eigen::MatrixXd& d_decoder_input,
                        double* gradient) const;

  Mlp patch_encoder_, body_encoder_, decoder_;
  Mlp feedback_;       // F, or no layers
  Mlp feedback_tail_;  // F's layers after the first
  int feedback_passes_ = 1;
  Mlp decoder_tail_;  // the decoder's layers after the first
  int num_coefficients_ = 0;
  int warp_order_ = -1;
  int local_size_ = 0;      // 0 or kLocalPoseSize
  int proximity_size_ = 0;  // 0 or ProximitySize(probes)
};

// The output bounds b_c above (part of the model's meaning: changing them
// needs a new model version).
inline constexpr int kMaxFeedbackPasses = 4;
inline constexpr double kOutputBoundAlpha = 1.0;
inline constexpr double kOutputBoundLogScale = 0.25;
inline constexpr double kOutputBoundTranslation = 0.5;
inline constexpr double kOutputBoundWarp = 0.25;

// What a network's outputs are to one garment's patches: their rest
// parameters (DrapeSolver's layout, warps zero), frames R_0, per patch
// the unit of every output (num_outputs() by #patches: u_c for alpha's and
// the warp's rows, 1 for the scale's, L for the centre's three), and the
// warp's slide bound B (BoundWarpComponent).
struct PatchOutputMap {
  std::vector<double> rest;
  std::vector<Eigen::Matrix3d> frames;
  Eigen::MatrixXd units;
  double warp_slide_bound = 0.0;

  int num_patches() const { return static_cast<int>(frames.size()); }
};

// The units of a patch's outputs (num_outputs rows): with area_units,
// rho = sqrt(area / pi), u_c = (s_0 / rho)^(deg c - 1) for alpha's rows,
// (s_0 r / rho)^(deg c - 1) for the warp's (r: its radius, DrapeSolver::
// warp_radii), L = rho; without, u = 1 and L = s_0. The jet in metres is
// sum_c alpha_c s_0^(1 - deg c) x^i y^j: an alpha_c step of u_c is a step
// of 1 in the coefficient of the jet over (x, y) / rho, whatever s_0.
Eigen::VectorXd PatchOutputUnits(int jet_order, int warp_order, double s0, double area, double warp_radius,
                                 bool area_units);

// One component of a patch's warp (a or b: n coefficients) from its n
// outputs y and units u. slide_bound B = 0: each coefficient bounded,
// a_c = u_c b(y_c) with b(y) = 0.25 tanh(y / 0.25) (models before file
// version 10), which at orders above 2 lets the terms together carry points
// off their patch, where the 4-jet's extrapolation explodes. B > 0: the
// component as a whole, a = g(S) t with t_c = u_c y_c,
// S = sum_c sqrt(t_c^2 + 1e-12) >= sum_c |t_c| and g(S) = B tanh(S / B) / S
// (about 1 for S << B): the warp is (du, dv) = r sum_c a_c m_c(u/r, v/r)
// with |m_c| <= 1 on the patch, so |du|, |dv| <= r sum_c |a_c| < B r at
// any order, while any one coefficient may use the whole budget.
void BoundWarpComponent(const double* u, const double* y, int n, double slide_bound, double* a);
// d_y (n) = (da/dy)^T d_a at the same u, y.
void ChainWarpComponent(const double* u, const double* y, int n, double slide_bound, const double* d_a, double* d_y);

// alpha, s, T (and the warp) per patch, packed as DrapeSolver's patch
// parameters, from the network's outputs (num_outputs() by #patches, the
// first num_coefficients of each column alpha's).
// Without with_warps, the warps are left at rest (for what reads only the
// jets, scales and centres: OutputProximity's probes).
std::vector<double> PatchParametersFromOutputs(const PatchOutputMap& map, const Eigen::MatrixXd& outputs,
                                               int num_coefficients, bool with_warps = true);
// dL/doutputs from dL/d(patch parameters) at those outputs.
Eigen::MatrixXd ChainPatchParameterGradient(const PatchOutputMap& map, const Eigen::MatrixXd& outputs,
                                            int num_coefficients, const std::vector<double>& gradient);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_NETWORK_ONEFIT_NETWORK_H_
