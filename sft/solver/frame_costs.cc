#include "sft/solver/frame_costs.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include <ceres/jet.h>

#include "cost_functions/patch_boundary_residual.h"
#include "cost_functions/pseudo_huber.h"
#include "cost_functions/temporal_consistency.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {

RenderCost::RenderCost(Data data)
    : data_(std::move(data)), render_(data_.render_scratch != nullptr ? data_.render_scratch : &own_render_) {
  channels_ = data_.mask.empty() ? 3 : 4;
  set_num_residuals(data_.roi.area() * channels_);
  for (int p = 0; p < data_.model->num_patches(); ++p) {
    mutable_parameter_block_sizes()->push_back(data_.model->block_size());
  }
  screen_ = data_.mesh;
}

bool RenderCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const int b = data_.model->block_size(), K = data_.model->num_patches();
  theta_.resize(static_cast<size_t>(b) * K);
  for (int p = 0; p < K; ++p) std::copy(parameters[p], parameters[p] + b, theta_.begin() + static_cast<size_t>(b) * p);
  bool want = jacobians != nullptr;
  for (int p = 0; want && p < K; ++p) want = jacobians[p] != nullptr;
  return Compute(theta_.data(), residuals, want ? jacobians : nullptr, false, want, nullptr);
}

bool RenderCost::EvaluateNormalEquations(const double* theta, double* squared_norm, Eigen::MatrixXd* jtj,
                                         Eigen::VectorXd* jtr) const {
  const bool want_jacobian = jtj != nullptr;
  const bool ok = Compute(theta, nullptr, nullptr, true, want_jacobian, nullptr);
  *squared_norm = 0.0;
  for (const PartState& part : parts_) *squared_norm += part.squared_norm;
  if (!want_jacobian) return ok;
  const int P = data_.model->num_parameters();
  jtj->setZero(P, P);
  jtr->setZero(P);
  ReduceParts(nullptr, jtj, jtr);
  return ok;
}

bool RenderCost::EvaluateSlottedNormalEquations(const double* theta, const PatchGroups& groups,
                                                const std::vector<int>& slot, bool want_jacobian,
                                                double* squared_norm, Eigen::MatrixXd* jtj, Eigen::VectorXd* jtr,
                                                RenderReuse render) const {
  const int b = data_.model->block_size();
  jtr->setZero(static_cast<Eigen::Index>(b) * data_.model->num_patches());
  const bool ok = Compute(theta, nullptr, nullptr, true, want_jacobian, &groups, render);
  *squared_norm = 0.0;
  for (const PartState& part : parts_) *squared_norm += part.squared_norm;
  if (want_jacobian) ReduceParts(&slot, jtj, jtr);
  return ok;
}

namespace {

// Robust loss per pixel (iteratively reweighted least squares): the RGB
// residual r scaled by sqrt(rho(s) / s), its Jacobian by sqrt(rho'(s)),
// s = |r|^2, b the loss's scale.
void ApplyRobustLoss(RobustLoss loss, double b, double* r, double* jacobian_scale) {
  if (loss == RobustLoss::kNone) return;
  const double s = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
  const double b2 = b * b;
  double rho = s, rho1 = 1.0;
  if (loss == RobustLoss::kHuber && s > b2) {
    rho = 2.0 * std::sqrt(s * b2) - b2;
    rho1 = std::sqrt(b2 / s);
  } else if (loss == RobustLoss::kCauchy) {
    rho = b2 * std::log1p(s / b2);
    rho1 = 1.0 / (1.0 + s / b2);
  }
  const double residual_scale = s > 0.0 ? std::sqrt(rho / s) : 1.0;
  for (int ch = 0; ch < 3; ++ch) r[ch] *= residual_scale;
  *jacobian_scale *= std::sqrt(rho1);
}

}  // namespace

void RenderCost::PixelResiduals(int y, int x, double* r, double* jacobian_scale, bool* in_band) const {
  const cv::Vec3f rendered = render_->color.at<cv::Vec3f>(y, x), observed = data_.image.at<cv::Vec3f>(y, x);
  for (int ch = 0; ch < 3; ++ch) r[ch] = data_.photometric_weight * (rendered[ch] - observed[ch]);
  *jacobian_scale = data_.photometric_weight;
  *in_band = false;
  ApplyRobustLoss(data_.robust_loss, data_.robust_scale, r, jacobian_scale);
  if (channels_ == 4) {
    const double s = render_->silhouette.at<float>(y, x), lo = data_.mask.at<float>(y, x);
    const double hi = data_.mask_upper.empty() ? lo : data_.mask_upper.at<float>(y, x);
    *in_band = s > lo && s < hi;  // (lo < hi only in a band)
    r[3] = data_.silhouette_weight * (s - std::clamp(s, lo, hi));
  }
}

void RenderCost::GatherPatches(int pixel, PixelPatches* out) const {
  constexpr int kMaxSeen = 4 * kMaxPatchesPerPixel;
  int seen[kMaxSeen];
  int size = 0;
  const std::vector<int>& vertex_patch = data_.model->vertex_patches();
  for (int k = render_->begin[pixel]; k < render_->end[pixel]; ++k) {
    const VertexGradient& g = render_->gradients[k];
    // A vertex that does not pull (beyond a soft edge's reach) does not
    // choose the pixel's group.
    if (std::all_of(&g.d[0][0], &g.d[0][0] + 12, [](float d) { return d == 0.0f; })) continue;
    const int p = vertex_patch[g.vertex];
    if (size < kMaxSeen && std::find(seen, seen + size, p) == seen + size) seen[size++] = p;
  }
  // More patches than a pixel's block holds (layers of a crumpled fold):
  // those that pull it most (the sum of their vertices' |derivatives|)
  // keep their pull, the others lose it (the cost is kept).
  if (size > kMaxPatchesPerPixel) {
    double pull[kMaxSeen] = {};
    for (int k = render_->begin[pixel]; k < render_->end[pixel]; ++k) {
      const VertexGradient& g = render_->gradients[k];
      const int j = static_cast<int>(std::find(seen, seen + size, vertex_patch[g.vertex]) - seen);
      if (j == size) continue;
      for (int a = 0; a < 4; ++a) {
        for (int c = 0; c < 3; ++c) pull[j] += std::abs(g.d[a][c]);
      }
    }
    for (int i = 0; i < kMaxPatchesPerPixel; ++i) {
      const int best = static_cast<int>(std::max_element(pull + i, pull + size) - pull);
      std::swap(seen[i], seen[best]);
      std::swap(pull[i], pull[best]);
    }
    size = kMaxPatchesPerPixel;
  }
  std::sort(seen, seen + size);
  std::copy(seen, seen + size, out->patches);
  out->size = size;
}

unsigned RenderCost::ChoosePatches(PartState* state, const PixelPatches& patches, const PatchGroups* groups) const {
  const unsigned all = (1u << patches.size) - 1u;
  if (groups == nullptr) return all;
  auto same = [&](const PatchChoice& c) {
    return c.patches.size == patches.size &&
           std::equal(patches.patches, patches.patches + patches.size, c.patches.patches);
  };
  std::vector<PatchChoice>& choices = state->choices;
  if (state->last_choice < static_cast<int>(choices.size()) && same(choices[state->last_choice])) {
    return choices[state->last_choice].kept;
  }
  for (size_t k = 0; k < choices.size(); ++k) {
    if (same(choices[k])) {
      state->last_choice = static_cast<int>(k);
      return choices[k].kept;
    }
  }
  PatchChoice choice;
  choice.patches = patches;
  bool whole = false;
  const int g = groups->Find(patches.patches, patches.size, &whole);
  if (g >= 0) {
    const std::vector<int>& members = groups->groups[g];
    for (int i = 0; i < patches.size; ++i) {
      if (whole || std::binary_search(members.begin(), members.end(), patches.patches[i])) choice.kept |= 1u << i;
    }
  }
  choices.push_back(choice);
  state->last_choice = static_cast<int>(choices.size()) - 1;
  return choice.kept;
}

void RenderCost::ChainPixelJacobian(int pixel, const PixelPatches& patches, int block, double* local) const {
  // local (4 by |patches| block) = sum over the pixel's vertices of d (4 by
  // 3) times their 3 by block rows, at their patch's columns; written out,
  // as Eigen's dynamic-size product costs more than the arithmetic here.
  const int n = patches.size * block;
  std::fill(local, local + 4 * n, 0.0);
  const std::vector<int>& vertex_patch = data_.model->vertex_patches();
  for (int k = render_->begin[pixel]; k < render_->end[pixel]; ++k) {
    const VertexGradient& g = render_->gradients[k];
    const int slot = static_cast<int>(
        std::find(patches.patches, patches.patches + patches.size, vertex_patch[g.vertex]) - patches.patches);
    if (slot == patches.size) continue;  // a patch past kMaxPatchesPerPixel
    const double* s0 = screen_theta_.data() + static_cast<size_t>(3 * g.vertex) * block;
    const double* s1 = s0 + block;
    const double* s2 = s1 + block;
    for (int a = 0; a < 4; ++a) {
      const double d0 = g.d[a][0], d1 = g.d[a][1], d2 = g.d[a][2];
      double* out = local + static_cast<size_t>(a) * n + static_cast<size_t>(slot) * block;
      for (int c = 0; c < block; ++c) out[c] += d0 * s0[c] + d1 * s1[c] + d2 * s2[c];
    }
  }
}

int RenderCost::FindVertexBlock(PartState* state, int v, int w) {
  for (int e = state->head[v]; e >= 0; e = state->blocks[e].next) {
    if (state->blocks[e].w == w) return e;
  }
  if (state->head[v] < 0) state->touched.push_back(v);
  VertexBlock block;
  block.w = w;
  block.next = state->head[v];
  state->blocks.push_back(block);
  state->head[v] = static_cast<int>(state->blocks.size()) - 1;
  return state->head[v];
}

void RenderCost::ReduceParts(const std::vector<int>* slot, Eigen::MatrixXd* jtj, Eigen::VectorXd* jtr) const {
  using Rows = Eigen::Map<const Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor>>;
  using Block3 = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>;
  const int b = data_.model->block_size();
  const std::vector<int>& vertex_patch = data_.model->vertex_patches();
  const auto at = [&](int p) { return static_cast<Eigen::Index>(slot != nullptr ? (*slot)[p] : p) * b; };
  for (const PartState& part : parts_) {
    for (const int v : part.touched) {
      const int p = vertex_patch[v];
      const Rows s_v(screen_theta_.data() + static_cast<size_t>(3 * v) * b, 3, b);
      jtr->segment(at(p), b).noalias() += s_v.transpose() * Eigen::Map<const Eigen::Vector3d>(&part.gradient[3 * v]);
      // Per patch q that v's blocks reach: T_q = sum over w in q of H_vw
      // S_w (H_vv halved: the diagonal block's M + M^T below adds it once).
      reach_patches_.clear();
      for (int e = part.head[v]; e >= 0; e = part.blocks[e].next) {
        const VertexBlock& block = part.blocks[e];
        const int q = vertex_patch[block.w];
        size_t k = std::find(reach_patches_.begin(), reach_patches_.end(), q) - reach_patches_.begin();
        if (k == reach_patches_.size()) {
          reach_patches_.push_back(q);
          if (reach_.rows() < 3 * static_cast<Eigen::Index>(k + 1)) reach_.conservativeResize(3 * (k + 1), b);
          reach_.middleRows(3 * k, 3).setZero();
        }
        const Rows s_w(screen_theta_.data() + static_cast<size_t>(3 * block.w) * b, 3, b);
        const double half = block.w == v ? 0.5 : 1.0;
        reach_.middleRows(3 * k, 3).noalias() += (half * Block3(block.h)) * s_w;
      }
      // M = S_v^T T_q added as M to block (p, q) or as M^T to (q, p):
      // each a column at a time, three axpys (Eigen's product would pack
      // its 3-deep operands first).
      const double* s0 = s_v.data();
      const double* s1 = s0 + b;
      const double* s2 = s1 + b;
      for (size_t k = 0; k < reach_patches_.size(); ++k) {
        const int q = reach_patches_[k];
        const double* t0 = reach_.data() + 3 * k * b;
        const double* t1 = t0 + b;
        const double* t2 = t1 + b;
        const bool plain = q == p || slot == nullptr || at(p) < at(q);
        const bool transposed = q == p || slot == nullptr || at(p) > at(q);
        for (int j = 0; j < b; ++j) {
          if (plain) {  // column j of M: sum over a of T(a, j) S_v(a, :)
            double* column = jtj->data() + (at(q) + j) * jtj->rows() + at(p);
            const double c0 = t0[j], c1 = t1[j], c2 = t2[j];
            for (int i = 0; i < b; ++i) column[i] += s0[i] * c0 + s1[i] * c1 + s2[i] * c2;
          }
          if (transposed) {  // column j of M^T: sum over a of S_v(a, j) T(a, :)
            double* column = jtj->data() + (at(p) + j) * jtj->rows() + at(q);
            const double c0 = s0[j], c1 = s1[j], c2 = s2[j];
            for (int i = 0; i < b; ++i) column[i] += t0[i] * c0 + t1[i] * c1 + t2[i] * c2;
          }
        }
      }
    }
  }
}

bool RenderCost::Prepare(const double* theta, bool model_jacobian, bool render_gradients) const {
  const JetDeformationModel& model = *data_.model;
  if (model_jacobian) {
    model.EvaluateLocal(theta, &vertices_, &model_jacobian_);
  } else {
    model.Evaluate(theta, &vertices_);
  }
  if (!ProjectVertices(data_.camera, vertices_, &screen_, model_jacobian ? &screen_jacobian_ : nullptr)) return false;
  data_.rasterizer->Render(screen_, data_.camera.width, data_.camera.height,
                           data_.background.empty() ? data_.image : data_.background, render_gradients, render_,
                           data_.roi);
  if (!model_jacobian) return true;
  const int n = model.num_vertices();
  screen_theta_.resize(3 * n, model.block_size());
  for (int i = 0; i < n; ++i) {
    screen_theta_.middleRows(3 * i, 3).noalias() =
        screen_jacobian_.middleRows(3 * i, 3) * model_jacobian_.middleRows(3 * i, 3);
  }
  return true;
}

void RenderCost::ResetParts(int parts, double** jacobians, bool normal) const {
  const int b = data_.model->block_size(), V = data_.model->num_vertices();
  parts_.resize(parts);
  for (PartState& part : parts_) {
    part.squared_norm = 0.0;
    part.rows.resize(static_cast<size_t>(4) * kMaxPatchesPerPixel * b);
    if (!normal) continue;
    if (static_cast<int>(part.head.size()) != V) {
      part.head.assign(V, -1);
      part.local.assign(V, -1);
      part.gradient.assign(3 * static_cast<size_t>(V), 0.0);
      part.touched.clear();
    }
    for (const int v : part.touched) {
      part.head[v] = -1;
      std::fill(&part.gradient[3 * v], &part.gradient[3 * v] + 3, 0.0);
    }
    part.touched.clear();
    part.blocks.clear();
    part.last_vertices.clear();
    part.choices.clear();  // the groups may have changed
    part.last_choice = 0;
  }
  if (jacobians == nullptr) return;
  for (int p = 0; p < data_.model->num_patches(); ++p) {
    std::fill(jacobians[p], jacobians[p] + static_cast<size_t>(num_residuals()) * b, 0.0);
  }
}

void RenderCost::AddPixelJacobian(PartState* state, int pixel, int r0, double jacobian_scale, bool in_band,
                                  double** jacobians) const {
  const int b = data_.model->block_size();
  PixelPatches patches;
  GatherPatches(pixel, &patches);
  const int m = patches.size * b;
  double* local = state->rows.data();
  ChainPixelJacobian(pixel, patches, b, local);
  for (int c = 0; c < 3 * m; ++c) local[c] *= jacobian_scale;
  const double silhouette_scale = in_band ? 0.0 : data_.silhouette_weight;
  for (int c = 3 * m; c < 4 * m; ++c) local[c] *= silhouette_scale;
  for (int ch = 0; ch < channels_; ++ch) {
    for (int j = 0; j < patches.size; ++j) {
      std::copy(local + ch * m + j * b, local + ch * m + (j + 1) * b,
                jacobians[patches.patches[j]] + static_cast<size_t>(r0 + ch) * b);
    }
  }
}

void RenderCost::AddPixelNormal(PartState* state, int pixel, const double* r, double jacobian_scale, bool in_band,
                                const PatchGroups* groups) const {
  PixelPatches patches;
  GatherPatches(pixel, &patches);
  const unsigned kept = ChoosePatches(state, patches, groups);
  if (kept == 0) return;
  const std::vector<int>& vertex_patch = data_.model->vertex_patches();
  const double scale[4] = {jacobian_scale, jacobian_scale, jacobian_scale, in_band ? 0.0 : data_.silhouette_weight};
  // The pixel's vertices, each once (a vertex is an entry per triangle),
  // with their derivatives summed and scaled.
  std::vector<int>& vertices = state->pixel_vertices;
  std::vector<double>& d = state->pixel_d;
  vertices.clear();
  for (int k = render_->begin[pixel]; k < render_->end[pixel]; ++k) {
    const VertexGradient& g = render_->gradients[k];
    const int slot = static_cast<int>(
        std::find(patches.patches, patches.patches + patches.size, vertex_patch[g.vertex]) - patches.patches);
    if (slot == patches.size || !(kept >> slot & 1u)) continue;  // a column dropped
    int i = state->local[g.vertex];
    if (i < 0) {
      i = static_cast<int>(vertices.size());
      state->local[g.vertex] = i;
      vertices.push_back(g.vertex);
      if (d.size() < 12 * vertices.size()) d.resize(24 * vertices.size());
      std::fill(&d[12 * i], &d[12 * i] + 12, 0.0);
    }
    for (int row = 0; row < channels_; ++row) {
      for (int c = 0; c < 3; ++c) d[12 * i + 3 * row + c] += scale[row] * g.d[row][c];
    }
  }
  const int m = static_cast<int>(vertices.size());
  for (const int v : vertices) state->local[v] = -1;
  for (int i = 0; i < m; ++i) {
    double* g = &state->gradient[3 * vertices[i]];
    for (int row = 0; row < channels_; ++row) {
      for (int c = 0; c < 3; ++c) g[c] += d[12 * i + 3 * row + c] * r[row];
    }
  }
  // Neighbouring pixels mostly depend on the same vertices: their blocks
  // are looked up once.
  const bool same = vertices == state->last_vertices;
  if (!same) state->last_blocks.resize(static_cast<size_t>(m) * (m + 1) / 2);
  int pair = 0;
  for (int i = 0; i < m; ++i) {
    for (int j = i; j < m; ++j, ++pair) {
      int v = vertices[i], w = vertices[j];
      const double* a = &d[12 * i];
      const double* c = &d[12 * j];
      if (v > w) {
        std::swap(v, w);
        std::swap(a, c);
      }
      if (!same) state->last_blocks[pair] = FindVertexBlock(state, v, w);
      double* h = state->blocks[state->last_blocks[pair]].h;
      for (int row = 0; row < channels_; ++row) {
        const double* ar = a + 3 * row;
        const double* cr = c + 3 * row;
        for (int x = 0; x < 3; ++x) {
          for (int y = 0; y < 3; ++y) h[3 * x + y] += ar[x] * cr[y];
        }
      }
    }
  }
  if (!same) state->last_vertices = vertices;
}

bool RenderCost::Compute(const double* theta, double* residuals, double** jacobians, bool normal, bool want_jacobian,
                         const PatchGroups* groups, RenderReuse render) const {
  // The values are the same with the gradients or without (the model's,
  // the projection's and the render's), so a kept render gives the cost
  // a fresh one would, to the bit.
  const size_t size = static_cast<size_t>(data_.model->block_size()) * data_.model->num_patches();
  const bool reuse = render == RenderReuse::kReuse && kept_theta_.size() == size &&
                     std::equal(kept_theta_.begin(), kept_theta_.end(), theta);
  const bool gradients = want_jacobian || render == RenderReuse::kKeep;
  kept_theta_.clear();
  if (!reuse && !Prepare(theta, gradients, gradients)) return false;
  if (render == RenderReuse::kKeep) kept_theta_.assign(theta, theta + size);
  const cv::Rect& roi = data_.roi;
  const int threads = std::max(1, std::min(ResolveNumThreads(data_.rasterizer->options().num_threads), roi.height));
  // The rows in a fixed number of contiguous parts, each summed into its
  // own state and the states reduced in order: the sums, and so the
  // solver's path, are the same however the threads share the parts (a
  // row handed to whichever thread is free changed them in the last bits,
  // which a frame that is nearly lost magnifies).
  const int parts = threads == 1 ? 1 : std::min(roi.height, 4 * threads);
  ResetParts(parts, jacobians, normal && want_jacobian);
  ParallelFor(
      parts, threads,
      [&](int, int index) {
        PartState& state = parts_[index];
        const int row_end = static_cast<int>(static_cast<int64_t>(roi.height) * (index + 1) / parts);
        for (int row = static_cast<int>(static_cast<int64_t>(roi.height) * index / parts); row < row_end; ++row) {
          const int y = roi.y + row;
          double r[4];
          for (int col = 0; col < roi.width; ++col) {
            const int x = roi.x + col;
            const int r0 = (row * roi.width + col) * channels_;
            double jacobian_scale;
            bool in_band;
            PixelResiduals(y, x, r, &jacobian_scale, &in_band);
            if (residuals != nullptr) {
              for (int ch = 0; ch < channels_; ++ch) residuals[r0 + ch] = r[ch];
            }
            for (int ch = 0; ch < channels_; ++ch) state.squared_norm += r[ch] * r[ch];
            const int pixel = y * data_.camera.width + x;
            if (!want_jacobian || render_->end[pixel] == render_->begin[pixel]) continue;  // a zero row
            if (normal) {
              AddPixelNormal(&state, pixel, r, jacobian_scale, in_band, groups);
            } else if (jacobians != nullptr) {
              AddPixelJacobian(&state, pixel, r0, jacobian_scale, in_band, jacobians);
            }
          }
        }
      },
      1);
  return true;
}
bool RenderCost::VertexResiduals(const double* theta, Eigen::VectorXd* squared_residuals,
                                 Eigen::VectorXd* pixels) const {
  const JetDeformationModel& model = *data_.model;
  if (!Prepare(theta, false, true)) return false;
  squared_residuals->setZero(model.num_vertices());
  pixels->setZero(model.num_vertices());
  const cv::Rect& roi = data_.roi;
  for (int y = roi.y; y < roi.y + roi.height; ++y) {
    for (int x = roi.x; x < roi.x + roi.width; ++x) {
      const int pixel = y * data_.camera.width + x;
      const int begin = render_->begin[pixel], end = render_->end[pixel];
      if (end == begin) continue;
      double r[4], jacobian_scale;
      bool in_band;
      PixelResiduals(y, x, r, &jacobian_scale, &in_band);
      double squared = 0.0;
      for (int ch = 0; ch < channels_; ++ch) squared += r[ch] * r[ch];
      // A vertex may appear once per triangle: shares by entry.
      const double share = 1.0 / (end - begin);
      for (int k = begin; k < end; ++k) {
        const int v = render_->gradients[k].vertex;
        (*squared_residuals)[v] += share * squared;
        (*pixels)[v] += share;
      }
    }
  }
  return true;
}

CompressedRenderCost::CompressedRenderCost(RenderCost::Data data)
    : NormalEquationsCost(std::vector<int32_t>(data.model->num_patches(), data.model->block_size())),
      cost_(std::move(data)) {}

bool CompressedRenderCost::EvaluateNormalEquations(double const* const* parameters, double* squared_norm,
                                                   Eigen::MatrixXd* jtj, Eigen::VectorXd* jtr) const {
  const std::vector<int32_t>& sizes = parameter_block_sizes();
  theta_.clear();
  for (size_t p = 0; p < sizes.size(); ++p) theta_.insert(theta_.end(), parameters[p], parameters[p] + sizes[p]);
  return cost_.EvaluateNormalEquations(theta_.data(), squared_norm, jtj, jtr);
}

int PatchGroups::Find(const int* patches, int size, bool* whole) const {
  int best = -1, best_common = 0, best_size = 0;
  for (int g = 0; g < static_cast<int>(groups.size()); ++g) {
    const std::vector<int>& members = groups[g];
    int common = 0;
    for (int i = 0; i < size; ++i) common += std::binary_search(members.begin(), members.end(), patches[i]);
    const int n = static_cast<int>(members.size());
    if (common > best_common || (common == best_common && common > 0 && n < best_size)) {
      best = g;
      best_common = common;
      best_size = n;
    }
  }
  *whole = best >= 0 && best_common == size;
  return best;
}

PatchGroups MakePatchGroups(const JetDeformationModel& model, const Eigen::Matrix3Xi& faces) {
  const std::vector<int>& vertex_patch = model.vertex_patches();
  std::vector<std::vector<int>> vertex_faces(model.num_vertices());
  for (int f = 0; f < faces.cols(); ++f) {
    for (int c = 0; c < 3; ++c) vertex_faces[faces(c, f)].push_back(f);
  }
  std::vector<std::vector<int>> sets;
  for (int f = 0; f < faces.cols(); ++f) {
    std::vector<int> set;
    for (int c = 0; c < 3; ++c) {
      for (const int g : vertex_faces[faces(c, f)]) {
        for (int k = 0; k < 3; ++k) set.push_back(vertex_patch[faces(k, g)]);
      }
    }
    std::sort(set.begin(), set.end());
    set.erase(std::unique(set.begin(), set.end()), set.end());
    sets.push_back(std::move(set));
  }
  for (int p = 0; p < model.num_patches(); ++p) sets.push_back({p});  // a patch without faces still has a group
  std::sort(sets.begin(), sets.end());
  sets.erase(std::unique(sets.begin(), sets.end()), sets.end());
  // Larger first, so that a set inside one kept is dropped.
  std::stable_sort(sets.begin(), sets.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
  PatchGroups out;
  for (const std::vector<int>& set : sets) {
    const bool inside = std::any_of(out.groups.begin(), out.groups.end(), [&](const std::vector<int>& kept) {
      return std::includes(kept.begin(), kept.end(), set.begin(), set.end());
    });
    if (!inside) out.groups.push_back(set);
  }
  return out;
}

namespace {

// A residual block of a SplitRenderTerm: its row block i.
class RenderRowBlockCost : public ceres::CostFunction {
 public:
  RenderRowBlockCost(const SplitRenderTerm* term, int i, int block_size) : term_(term), i_(i) {
    for (size_t k = 0; k < term->row_block_patches(i).size(); ++k) {
      mutable_parameter_block_sizes()->push_back(block_size);
    }
    set_num_residuals(block_size + (i + 1 == term->num_row_blocks() ? 1 : 0));
  }
  bool Evaluate(double const* const*, double* residuals, double** jacobians) const override {
    return term_->Write(i_, residuals, jacobians);
  }

 private:
  const SplitRenderTerm* term_;
  int i_;
};

// Greedy minimum degree on a graph of a few dozen nodes (adjacent:
// symmetric): the elimination order, ties to the lower index.
std::vector<int> MinimumDegreeOrder(std::vector<std::vector<char>> adjacent) {
  const int n = static_cast<int>(adjacent.size());
  std::vector<char> done(n, 0);
  std::vector<int> order;
  for (int step = 0; step < n; ++step) {
    int best = -1, best_degree = n + 1;
    for (int v = 0; v < n; ++v) {
      if (done[v]) continue;
      int degree = 0;
      for (int u = 0; u < n; ++u) degree += u != v && !done[u] && adjacent[v][u];
      if (degree < best_degree) {
        best = v;
        best_degree = degree;
      }
    }
    done[best] = 1;
    order.push_back(best);
    for (int u = 0; u < n; ++u) {  // its neighbours become a clique
      if (done[u] || !adjacent[best][u]) continue;
      for (int w = 0; w < n; ++w) {
        if (!done[w] && adjacent[best][w] && w != u) adjacent[u][w] = 1;
      }
    }
  }
  return order;
}

}  // namespace

SplitRenderTerm::SplitRenderTerm(RenderCost::Data data, PatchGroups groups, const double* theta)
    : cost_(std::move(data)),
      groups_(std::move(groups)),
      theta_(theta),
      block_size_(cost_.parameter_block_sizes()[0]) {
  const int n = static_cast<int>(cost_.parameter_block_sizes().size());
  adjacent_.assign(n, std::vector<char>(n, 0));
  for (const std::vector<int>& members : groups_.groups) {
    for (const int p : members) {
      for (const int q : members) adjacent_[p][q] = 1;
    }
  }
}

void SplitRenderTerm::Attach(ceres::CostFunction* term, std::vector<int> patches) {
  if (planned_) throw std::logic_error("SplitRenderTerm::Attach after its row blocks were read");
  for (const int p : patches) {
    for (const int q : patches) adjacent_[p][q] = 1;
  }
  attached_.push_back({std::unique_ptr<ceres::CostFunction>(term), std::move(patches)});
}

void SplitRenderTerm::Plan() const {
  if (planned_) return;
  const int n = static_cast<int>(adjacent_.size());
  const std::vector<int> order = MinimumDegreeOrder(adjacent_);
  slot_.assign(n, 0);
  for (int i = 0; i < n; ++i) slot_[order[i]] = i;
  std::vector<std::vector<int>> by_slot(n);
  for (int p = 0; p < n; ++p) {
    for (int q = 0; q < n; ++q) {
      if (p != q && adjacent_[p][q]) by_slot[slot_[p]].push_back(slot_[q]);
    }
  }
  later_ = BlockFill(by_slot);
  row_patches_.clear();
  for (int i = 0; i < n; ++i) {
    row_patches_.push_back({order[i]});
    for (const int k : later_[i]) row_patches_.back().push_back(order[k]);
  }
  sizes_.assign(n, block_size_);
  planned_ = true;
}

int SplitRenderTerm::num_row_blocks() const {
  Plan();
  return static_cast<int>(row_patches_.size());
}

const std::vector<int>& SplitRenderTerm::row_block_patches(int i) const {
  Plan();
  return row_patches_[i];
}

bool SplitRenderTerm::Prepare(bool jacobians, bool new_point) {
  if (!new_point && (have_jacobians_ || !jacobians)) return ok_;
  Plan();
  const int n = num_row_blocks(), b = block_size_;
  if (jacobians) {
    if (jtj_.rows() != n * b) jtj_.resize(n * b, n * b);
    for (int i = 0; i < n; ++i) {  // the pattern's upper blocks, the rest never read
      jtj_.block(i * b, i * b, b, b).setZero();
      for (const int k : later_[i]) jtj_.block(i * b, k * b, b, b).setZero();
    }
  }
  // A trial point's cost is rendered with its gradients too: most steps
  // are taken (nine in ten on the flags), and Ceres then asks for the
  // normal equations at the same point (new_point false), which reuse
  // that render instead of making it again. A render with gradients
  // costs 4.7 ms on a flag, 2.1 without; flag 7 on two threads 0.81 ->
  // 0.75 s a frame, solved to the same bit (docs/benchmarks.md).
  using Reuse = RenderCost::RenderReuse;
  const Reuse render = !jacobians ? Reuse::kKeep : new_point ? Reuse::kNone : Reuse::kReuse;
  ok_ = cost_.EvaluateSlottedNormalEquations(theta_, groups_, slot_, jacobians, &squared_norm_, &jtj_, &jtr_, render);
  ok_ = AddAttached(jacobians) && ok_;
  have_jacobians_ = jacobians;
  // Factorised here, where the callback prepares the window's frames side
  // by side: Write only copies its row block (no lock, no lazy state).
  if (ok_ && jacobians) Factorize();
  return ok_;
}

void SplitRenderTerm::Factorize() {
  const int b = block_size_;
  double largest = 0.0;
  for (int k = 0; k < num_row_blocks(); ++k) {
    largest = std::max(largest, jtj_.block(k * b, k * b, b, b).diagonal().maxCoeff());
  }
  // In place: the normal equations are read once per point.
  CompressBlockSparse(sizes_, later_, squared_norm_, 1e-12 * std::max(largest, 1e-300), &jtj_, &jtr_, &rows_,
                      &residuals_);
}

bool SplitRenderTerm::AddAttached(bool jacobians) {
  const int b = block_size_;
  std::vector<const double*>& parameters = attached_parameters_;
  std::vector<double*>& blocks = attached_blocks_;
  for (const Attached& a : attached_) {
    const int m = a.term->num_residuals(), k = static_cast<int>(a.patches.size());
    parameters.clear();
    for (const int p : a.patches) parameters.push_back(theta_ + static_cast<size_t>(b) * p);
    attached_residuals_.resize(m);
    blocks.clear();
    if (jacobians) {
      attached_jacobian_.resize(static_cast<size_t>(m) * b * k);
      for (int i = 0; i < k; ++i) blocks.push_back(attached_jacobian_.data() + static_cast<size_t>(m) * b * i);
    }
    if (!a.term->Evaluate(parameters.data(), attached_residuals_.data(), jacobians ? blocks.data() : nullptr)) {
      return false;
    }
    const Eigen::Map<const Eigen::VectorXd> r(attached_residuals_.data(), m);
    squared_norm_ += r.squaredNorm();
    if (!jacobians) continue;
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    for (int i = 0; i < k; ++i) {
      const Eigen::Map<const RowMajor> ji(blocks[i], m, b);
      const Eigen::Index si = static_cast<Eigen::Index>(slot_[a.patches[i]]) * b;
      jtr_.segment(si, b).noalias() += ji.transpose() * r;
      for (int j = 0; j < k; ++j) {
        const Eigen::Index sj = static_cast<Eigen::Index>(slot_[a.patches[j]]) * b;
        if (sj < si) continue;
        jtj_.block(si, sj, b, b).noalias() += ji.transpose() * Eigen::Map<const RowMajor>(blocks[j], m, b);
      }
    }
  }
  return true;
}

ceres::CostFunction* SplitRenderTerm::NewRowBlockCost(int i) const {
  return new RenderRowBlockCost(this, i, block_size_);
}

bool SplitRenderTerm::Write(int i, double* residuals, double** jacobians) const {
  if (!ok_ || (jacobians != nullptr && !have_jacobians_)) return false;
  const int b = block_size_;
  const bool last = i + 1 == num_row_blocks();
  Eigen::Map<Eigen::VectorXd> out(residuals, b + (last ? 1 : 0));
  if (jacobians == nullptr) {  // the cost alone: all of it in the last row
    out.setZero();
    if (last) out[b] = std::sqrt(std::max(0.0, squared_norm_));
    return true;
  }
  out = residuals_.segment(static_cast<Eigen::Index>(i) * b, out.size());
  const Eigen::MatrixXd& row = rows_[i];
  for (size_t k = 0; k < row_patches_[i].size(); ++k) {
    if (jacobians[k] == nullptr) continue;
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(jacobians[k], out.size(), b);
    jac.topRows(b) = row.middleCols(static_cast<Eigen::Index>(k) * b, b);
    if (last) jac.row(b).setZero();
  }
  return true;
}

void RenderTermCallback::PrepareForEvaluation(bool evaluate_jacobians, bool new_evaluation_point) {
  ParallelFor(
      static_cast<int>(terms_.size()), num_threads_,
      [&](int, int i) { terms_[i]->Prepare(evaluate_jacobians, new_evaluation_point); }, 1);
}

template <int N, typename Functor>
VertexTupleCost<N, Functor>::VertexTupleCost(const JetDeformationModel* model, const std::vector<int>& patches,
                                             const std::vector<std::array<int, N>>& tuples,
                                             std::vector<Functor> functors)
    : model_(model), patches_(patches), functors_(std::move(functors)) {
  if (functors_.size() != tuples.size()) throw std::invalid_argument("VertexTupleCost: one functor per tuple");
  std::vector<int> local(model->num_vertices(), -1);
  for (const std::array<int, N>& tuple : tuples) {
    std::array<int, N> mapped;
    for (int k = 0; k < N; ++k) {
      if (local[tuple[k]] < 0) {
        local[tuple[k]] = static_cast<int>(vertices_.size());
        vertices_.push_back(tuple[k]);
        const auto slot = std::find(patches.begin(), patches.end(), model->patch_of_vertex(tuple[k]));
        if (slot == patches.end()) throw std::invalid_argument("VertexTupleCost: a vertex outside the patches");
        slots_.push_back(static_cast<int>(slot - patches.begin()));
      }
      mapped[k] = local[tuple[k]];
    }
    tuples_.push_back(mapped);
  }
  set_num_residuals(static_cast<int>(tuples_.size()));
  for (size_t p = 0; p < patches.size(); ++p) mutable_parameter_block_sizes()->push_back(model->block_size());
}

namespace {

template <typename Functor, typename T, size_t... k>
void CallOnPoints(const Functor& functor, const T (&points)[sizeof...(k)][3], T* residual,
                  std::index_sequence<k...>) {
  functor(points[k]..., residual);
}

}  // namespace

template <int N, typename Functor>
bool VertexTupleCost<N, Functor>::Evaluate(double const* const* parameters, double* residuals,
                                           double** jacobians) const {
  const bool want_jacobian = jacobians != nullptr;
  const int b = model_->block_size(), n = static_cast<int>(vertices_.size());
  positions_.resize(3, n);
  if (want_jacobian) jacobian_.resize(3 * n, b);
  for (int v = 0; v < n; ++v) {
    const int i = vertices_[v];
    model_->EvaluateVertex(i, model_->patch_of_vertex(i), parameters[slots_[v]], positions_.col(v).data(),
                           want_jacobian ? jacobian_.data() + static_cast<size_t>(3 * v) * b : nullptr);
  }
  if (want_jacobian) {
    for (size_t p = 0; p < patches_.size(); ++p) {
      if (jacobians[p] != nullptr) std::fill(jacobians[p], jacobians[p] + tuples_.size() * b, 0.0);
    }
  }
  using J = ceres::Jet<double, 3 * N>;
  const auto order = std::make_index_sequence<N>();
  for (size_t t = 0; t < tuples_.size(); ++t) {
    const std::array<int, N>& tuple = tuples_[t];
    if (!want_jacobian) {
      double points[N][3];
      for (int end = 0; end < N; ++end) {
        for (int k = 0; k < 3; ++k) points[end][k] = positions_(k, tuple[end]);
      }
      CallOnPoints(functors_[t], points, &residuals[t], order);
      continue;
    }
    J points[N][3], r;
    for (int end = 0; end < N; ++end) {
      for (int k = 0; k < 3; ++k) points[end][k] = J(positions_(k, tuple[end]), 3 * end + k);
    }
    CallOnPoints(functors_[t], points, &r, order);
    residuals[t] = r.a;
    for (int end = 0; end < N; ++end) {
      double* out = jacobians[slots_[tuple[end]]];
      if (out == nullptr) continue;
      Eigen::Map<Eigen::RowVectorXd> row(out + t * b, b);
      row.noalias() += r.v.template segment<3>(3 * end).transpose() * jacobian_.middleRows(3 * tuple[end], 3);
    }
  }
  return true;
}

template class VertexTupleCost<2, EdgeInextensibilityResidual>;
template class VertexTupleCost<4, HingeBendingResidual>;

namespace {

std::vector<std::array<int, 2>> AsArrays(const std::vector<Eigen::Vector2i>& edges) {
  std::vector<std::array<int, 2>> out;
  out.reserve(edges.size());
  for (const Eigen::Vector2i& e : edges) out.push_back({e[0], e[1]});
  return out;
}

std::vector<EdgeInextensibilityResidual> EdgeFunctors(const std::vector<double>& rest_lengths, double weight,
                                                      double robust_strain) {
  std::vector<EdgeInextensibilityResidual> out;
  out.reserve(rest_lengths.size());
  for (double length : rest_lengths) out.emplace_back(length, weight, robust_strain);
  return out;
}

std::vector<HingeBendingResidual> HingeFunctors(const std::vector<double>& rest_angles,
                                                const std::vector<double>& weights) {
  if (rest_angles.size() != weights.size()) throw std::invalid_argument("BendingCost: one weight per hinge");
  std::vector<HingeBendingResidual> out;
  out.reserve(rest_angles.size());
  for (size_t h = 0; h < rest_angles.size(); ++h) out.emplace_back(rest_angles[h], weights[h]);
  return out;
}

}  // namespace

InextensibilityCost::InextensibilityCost(const JetDeformationModel* model, const std::vector<int>& patches,
                                         const std::vector<Eigen::Vector2i>& edges,
                                         const std::vector<double>& rest_lengths, double weight,
                                         double robust_strain)
    : VertexTupleCost(model, patches, AsArrays(edges), EdgeFunctors(rest_lengths, weight, robust_strain)) {}

BendingCost::BendingCost(const JetDeformationModel* model, const std::vector<int>& patches,
                         const std::vector<std::array<int, 4>>& hinges, const std::vector<double>& rest_angles,
                         const std::vector<double>& weights)
    : VertexTupleCost(model, patches, hinges, HingeFunctors(rest_angles, weights)) {}

TemporalCost::TemporalCost(const JetDeformationModel* model, int patch, double length_scale, double weight, int order,
                           const std::vector<const Eigen::Matrix3Xd*>& fixed, const Eigen::Vector3d& shift,
                           const std::vector<int>& only, double velocity)
    : model_(model), patch_(patch), scale_(weight / length_scale) {
  if (order != 1 && order != 2) throw std::invalid_argument("TemporalCost: the order must be 1 or 2");
  if (order != 2 && !shift.isZero()) throw std::invalid_argument("TemporalCost: a shift needs the order 2");
  if (!shift.allFinite()) throw std::invalid_argument("TemporalCost: the shift must be finite");
  if (!std::isfinite(velocity)) throw std::invalid_argument("TemporalCost: the velocity must be finite");
  if (fixed.size() > static_cast<size_t>(order))
    throw std::invalid_argument("TemporalCost: more fixed frames than the order");
  coefficients_ = order == 1 ? std::vector<double>{1.0, -1.0} : std::vector<double>{1.0, -1.0 - velocity, velocity};
  num_free_ = order + 1 - static_cast<int>(fixed.size());
  if (only.empty()) {
    for (int i = 0; i < model->num_vertices(); ++i) {
      if (model->patch_of_vertex(i) == patch) vertices_.push_back(i);
    }
  } else {
    for (int i : only) {
      if (i < 0 || i >= model->num_vertices() || model->patch_of_vertex(i) != patch) {
        throw std::invalid_argument("TemporalCost: vertex " + std::to_string(i) + " is not of patch " +
                                    std::to_string(patch));
      }
    }
    vertices_ = only;
  }
  // The target -sum_{f >= 1} c_f x_f + shift: the shift enters as a
  // fixed frame would.
  fixed_sum_ = (-shift).replicate(1, vertices_.size());
  for (size_t f = 0; f < fixed.size(); ++f) {
    const double c = coefficients_[num_free_ + f];
    for (size_t v = 0; v < vertices_.size(); ++v) fixed_sum_.col(v) += c * fixed[f]->col(vertices_[v]);
  }
  set_num_residuals(3 * static_cast<int>(vertices_.size()));
  for (int f = 0; f < num_free_; ++f) mutable_parameter_block_sizes()->push_back(model->block_size());
}

TemporalCost::TemporalCost(const JetDeformationModel* model, int patch, double length_scale, double weight,
                           const Eigen::Matrix3Xd* previous)
    : TemporalCost(model, patch, length_scale, weight, 1,
                   previous != nullptr ? std::vector<const Eigen::Matrix3Xd*>{previous}
                                       : std::vector<const Eigen::Matrix3Xd*>{}) {}

bool TemporalCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const int b = model_->block_size();
  // TemporalConsistencyResidual of x_t against what the frames before
  // predict, -sum_{f >= 1} c_f x_f (x_t-1, or 2 x_t-1 - x_t-2), with the
  // length scale / weight folded into scale_: dr/dx_f = scale_ c_f.
  const TemporalConsistencyResidual functor(1.0 / scale_, 1.0);
  for (size_t v = 0; v < vertices_.size(); ++v) {
    Eigen::Vector3d now, predicted = -fixed_sum_.col(v);
    for (int f = 0; f < num_free_; ++f) {
      double* jacobian = jacobians != nullptr && jacobians[f] != nullptr ? jacobians[f] + 3 * v * b : nullptr;
      Eigen::Vector3d x;
      model_->EvaluateVertex(vertices_[v], patch_, parameters[f], x.data(), jacobian);
      if (f == 0) {
        now = x;
      } else {
        predicted -= coefficients_[f] * x;
      }
    }
    functor(now.data(), predicted.data(), residuals + 3 * v);
  }
  const size_t size = 3 * vertices_.size() * b;
  for (int f = 0; f < num_free_; ++f) {
    if (jacobians != nullptr && jacobians[f] != nullptr) {
      Eigen::Map<Eigen::VectorXd>(jacobians[f], size) *= scale_ * coefficients_[f];
    }
  }
  return true;
}

namespace {

// The seam's residual (PatchBoundaryResidual::Difference, linear in the
// two points and normals) per edge, each side's Jacobian its point's and
// normal's (EdgeMidpointJacobian) scaled, that of b negated.
class SeamCost : public ceres::CostFunction {
 public:
  SeamCost(const JetDeformationModel* model, int a, int b, std::vector<Eigen::Vector2i> edges, double position_scale,
           double normal_weight)
      : model_(model), patches_{a, b}, edges_(std::move(edges)), position_scale_(position_scale),
        normal_weight_(normal_weight) {
    set_num_residuals(6 * static_cast<int>(edges_.size()));
    mutable_parameter_block_sizes()->push_back(model->block_size());
    mutable_parameter_block_sizes()->push_back(model->block_size());
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const int b = model_->block_size();
    for (size_t e = 0; e < edges_.size(); ++e) {
      double x[2][3], n[2][3];
      for (int side = 0; side < 2; ++side) {
        double* jacobian = jacobians != nullptr && jacobians[side] != nullptr ? jacobians[side] + 6 * e * b : nullptr;
        model_->EdgeMidpointJacobian(edges_[e][0], edges_[e][1], patches_[side], parameters[side], x[side], n[side],
                                     jacobian);
        if (jacobian == nullptr) continue;
        const double sign = side == 0 ? 1.0 : -1.0;
        for (int row = 0; row < 6; ++row) {
          const double scale = sign * (row < 3 ? position_scale_ : normal_weight_);
          for (int c = 0; c < b; ++c) jacobian[row * b + c] *= scale;
        }
      }
      PatchBoundaryResidual::Difference(x[0], n[0], x[1], n[1], position_scale_, normal_weight_, residuals + 6 * e);
    }
    return true;
  }

 private:
  const JetDeformationModel* model_;
  int patches_[2];
  std::vector<Eigen::Vector2i> edges_;
  double position_scale_, normal_weight_;
};

}  // namespace

ceres::CostFunction* CreateSeamCost(const JetDeformationModel* model, int patch_a, int patch_b,
                                    const std::vector<Eigen::Vector2i>& seam_edges, double length_scale,
                                    double position_weight, double normal_weight) {
  return new SeamCost(model, patch_a, patch_b, seam_edges, position_weight / length_scale, normal_weight);
}

namespace {

class SharedUv : public ceres::CostFunction {
 public:
  SharedUv(const JetDeformationModel* model, double weight, double robust)
      : offset_(model->num_dalpha()), count_(model->num_duv()), weight_(weight), robust_(robust) {
    set_num_residuals(count_);
    mutable_parameter_block_sizes()->push_back(model->block_size());
    mutable_parameter_block_sizes()->push_back(model->block_size());
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const int b = parameter_block_sizes()[0];
    for (int k = 0; k < count_; ++k) residuals[k] = weight_ * (parameters[0][offset_ + k] - parameters[1][offset_ + k]);
    for (int j = 0; jacobians != nullptr && j < 2; ++j) {
      if (jacobians[j] == nullptr) continue;
      std::fill(jacobians[j], jacobians[j] + count_ * b, 0.0);
      for (int k = 0; k < count_; ++k) jacobians[j][k * b + offset_ + k] = j == 0 ? weight_ : -weight_;
    }
    if (robust_ > 0.0) Robustify(b, residuals, jacobians);
    return true;
  }

 private:
  // r' = phi(x) r, x = |r| / (w b) (the fields' difference in units of b):
  // the pseudo-Huber penalty; dr' = phi dr + phi'(x) / (x w^2 b^2) r r^T dr,
  // over the uv columns only (r's Jacobian is zero elsewhere).
  void Robustify(int b, double* residuals, double** jacobians) const {
    double norm2 = 0.0;
    for (int k = 0; k < count_; ++k) norm2 += residuals[k] * residuals[k];
    const double x = std::sqrt(norm2) / (weight_ * robust_);
    const ceres::Jet<double, 1> phi = PseudoHuberFactor(ceres::Jet<double, 1>(x, 0));
    const double slope = x > 0.0 ? phi.v[0] / (x * weight_ * weight_ * robust_ * robust_) : 0.0;
    for (int j = 0; jacobians != nullptr && j < 2; ++j) {
      if (jacobians[j] == nullptr) continue;
      for (int c = offset_; c < offset_ + count_; ++c) {
        double dot = 0.0;
        for (int k = 0; k < count_; ++k) dot += residuals[k] * jacobians[j][k * b + c];
        for (int k = 0; k < count_; ++k) {
          jacobians[j][k * b + c] = phi.a * jacobians[j][k * b + c] + slope * residuals[k] * dot;
        }
      }
    }
    for (int k = 0; k < count_; ++k) residuals[k] *= phi.a;
  }

  int offset_, count_;
  double weight_, robust_;
};

}  // namespace

ceres::CostFunction* CreateSharedUvCost(const JetDeformationModel* model, double weight, double robust_scale) {
  if (!(weight > 0.0) || !std::isfinite(weight)) throw std::invalid_argument("CreateSharedUvCost: weight must be > 0");
  if (!(robust_scale >= 0.0) || !std::isfinite(robust_scale)) {
    throw std::invalid_argument("CreateSharedUvCost: robust_scale must be finite and >= 0");
  }
  return new SharedUv(model, weight, robust_scale);
}

double SampleOutsideDistance(const cv::Mat& distance, double x, double y, Eigen::Vector2d* gradient) {
  const double max_x = distance.cols - 1.0, max_y = distance.rows - 1.0;
  const double cx = std::clamp(x, 0.0, max_x), cy = std::clamp(y, 0.0, max_y);
  const int x0 = std::min(static_cast<int>(cx), std::max(0, distance.cols - 2));
  const int y0 = std::min(static_cast<int>(cy), std::max(0, distance.rows - 2));
  const int x1 = std::min(x0 + 1, distance.cols - 1), y1 = std::min(y0 + 1, distance.rows - 1);
  const double ax = cx - x0, ay = cy - y0;
  const double d00 = distance.at<float>(y0, x0), d01 = distance.at<float>(y0, x1);
  const double d10 = distance.at<float>(y1, x0), d11 = distance.at<float>(y1, x1);
  double value = (1 - ay) * ((1 - ax) * d00 + ax * d01) + ay * ((1 - ax) * d10 + ax * d11);
  Eigen::Vector2d g((1 - ay) * (d01 - d00) + ay * (d11 - d10), (1 - ax) * (d10 - d00) + ax * (d11 - d01));
  // Beyond the image: straight out.
  const Eigen::Vector2d beyond(x - cx, y - cy);
  if (beyond.x() != 0.0) g.x() = beyond.x() > 0.0 ? 1.0 : -1.0;
  if (beyond.y() != 0.0) g.y() = beyond.y() > 0.0 ? 1.0 : -1.0;
  value += std::abs(beyond.x()) + std::abs(beyond.y());
  if (gradient != nullptr) *gradient = g;
  return value;
}

SilhouetteReachCost::SilhouetteReachCost(const JetDeformationModel* model, int patch, const PinholeCamera& camera,
                                         const cv::Mat& outside_distance, int margin, double tolerance, double weight)
    : model_(model),
      patch_(patch),
      camera_(camera),
      distance_(outside_distance),
      margin_(margin),
      tolerance_(tolerance),
      weight_(weight / std::sqrt(static_cast<double>(model->num_vertices()))) {
  for (int i = 0; i < model->num_vertices(); ++i) {
    if (model->patch_of_vertex(i) == patch) vertices_.push_back(i);
  }
  set_num_residuals(static_cast<int>(vertices_.size()));
  mutable_parameter_block_sizes()->push_back(model->block_size());
}

bool SilhouetteReachCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const int b = model_->block_size();
  double* jacobian = jacobians != nullptr ? jacobians[0] : nullptr;
  Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor> d_position(3, b);
  for (size_t k = 0; k < vertices_.size(); ++k) {
    Eigen::Vector3d x;
    model_->EvaluateVertex(vertices_[k], patch_, parameters[0], x.data(),
                           jacobian != nullptr ? d_position.data() : nullptr);
    Eigen::Vector2d pixel, gradient;
    Eigen::Matrix3d d_pixel;
    if (!camera_.ProjectWithJacobian(x, &pixel, &d_pixel)) return false;
    const double outside =
        SampleOutsideDistance(distance_, pixel.x() + margin_, pixel.y() + margin_, &gradient) - tolerance_;
    residuals[k] = weight_ * std::max(0.0, outside);
    if (jacobian == nullptr) continue;
    Eigen::Map<Eigen::RowVectorXd> row(jacobian + k * b, b);
    if (outside <= 0.0) {
      row.setZero();
      continue;
    }
    row.noalias() = (weight_ * gradient.transpose() * d_pixel.topRows<2>()) * d_position;
  }
  return true;
}

FeatureCost::FeatureCost(const JetDeformationModel* model, std::vector<Point> points, const PinholeCamera& camera,
                         double weight, double dead_zone, double huber)
    : model_(model),
      points_(std::move(points)),
      camera_(camera),
      weight_(weight),
      dead_zone_(dead_zone),
      huber_(huber) {
  for (const Point& p : points_) {
    for (int k = 0; k < 3; ++k) patches_.push_back(model->patch_of_vertex(p.corners[k]));
  }
  std::sort(patches_.begin(), patches_.end());
  patches_.erase(std::unique(patches_.begin(), patches_.end()), patches_.end());
  for (const Point& p : points_) {
    Eigen::Vector3i blocks;
    for (int k = 0; k < 3; ++k) {
      blocks[k] = static_cast<int>(
          std::lower_bound(patches_.begin(), patches_.end(), model->patch_of_vertex(p.corners[k])) - patches_.begin());
    }
    corner_blocks_.push_back(blocks);
  }
  set_num_residuals(2 * static_cast<int>(points_.size()));
  for (size_t p = 0; p < patches_.size(); ++p) mutable_parameter_block_sizes()->push_back(model->block_size());
  for (auto& d : corner_jacobians_) d.resize(3, model->block_size());
}

bool FeatureCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const int b = model_->block_size();
  auto& d_corner = corner_jacobians_;  // sized once: Ceres evaluates a cost on one thread at a time
  if (jacobians != nullptr) {
    for (size_t p = 0; p < patches_.size(); ++p) {
      if (jacobians[p] != nullptr)
        std::fill(jacobians[p], jacobians[p] + static_cast<size_t>(num_residuals()) * b, 0.0);
    }
  }
  for (size_t j = 0; j < points_.size(); ++j) {
    const Point& point = points_[j];
    const Eigen::Vector3i& blocks = corner_blocks_[j];
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d corner;
      const bool want = jacobians != nullptr && jacobians[blocks[k]] != nullptr;
      model_->EvaluateVertex(point.corners[k], model_->patch_of_vertex(point.corners[k]), parameters[blocks[k]],
                             corner.data(), want ? d_corner[k].data() : nullptr);
      x += point.barycentric[k] * corner;
    }
    Eigen::Vector2d projected;
    Eigen::Matrix3d d_pixel;
    if (!camera_.ProjectWithJacobian(x, &projected, &d_pixel)) return false;
    const Eigen::Vector2d e = projected - point.pixel;
    const double l = e.norm();
    // L(l) and L'(l) (see the header).
    double length = 0.0, slope = 0.0;
    if (l > dead_zone_) {
      const double m = weight_ * (l - dead_zone_);
      if (m <= huber_) {
        length = m;
        slope = weight_;
      } else {
        length = std::sqrt(2.0 * huber_ * m - huber_ * huber_);
        slope = huber_ * weight_ / length;
      }
    }
    const Eigen::Vector2d u = l > 0.0 ? Eigen::Vector2d(e / l) : Eigen::Vector2d::Zero();
    residuals[2 * j] = length * u.x();
    residuals[2 * j + 1] = length * u.y();
    if (jacobians == nullptr || length == 0.0) continue;
    // dr/de = (L / l) (I - u u') + L' u u'.
    const Eigen::Matrix2d uu = u * u.transpose();
    const Eigen::Matrix2d d_e = (length / l) * (Eigen::Matrix2d::Identity() - uu) + slope * uu;
    const Eigen::Matrix<double, 2, 3> d_residual = d_e * d_pixel.topRows<2>();
    for (int k = 0; k < 3; ++k) {
      double* jacobian = jacobians[blocks[k]];
      if (jacobian == nullptr) continue;
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> rows(jacobian, num_residuals(),
                                                                                              b);
      rows.middleRows(2 * static_cast<int>(j), 2).noalias() += point.barycentric[k] * d_residual * d_corner[k];
    }
  }
  return true;
}

}  // namespace polyfit
