#include "sft/solver/frame_costs.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>

#include <ceres/crs_matrix.h>
#include <ceres/dynamic_autodiff_cost_function.h>
#include <ceres/jet.h>
#include <ceres/problem.h>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "cost_functions/gravity_inertia_residuals.h"
#include "cost_functions/patch_boundary_residual.h"
#include "polyfit/mesh/mesh_topology.h"
#include "polyfit/mesh/unique_edges.h"
#include "polyfit/util/scoped_temp_dir.h"
#include "sft/render/mask_distance.h"
#include "sft/scene/scene.h"
#include "sft/solver/patch_atlas.h"
#include "sft/solver/silhouette_band.h"
#include "sft/synthetic/sheet_scene.h"

namespace polyfit {
namespace {

// Central differences of a cost's residuals against its Jacobian, theta
// holding its parameter blocks one after the other; returns the largest
// difference relative to the Jacobian's largest entry.
double RelativeJacobianError(const ceres::CostFunction& cost, std::vector<double> theta, double h,
                             double* largest = nullptr) {
  const int m = cost.num_residuals();
  const std::vector<int32_t>& sizes = cost.parameter_block_sizes();
  std::vector<int> offsets;
  int total = 0;
  for (int size : sizes) {
    offsets.push_back(total);
    total += size;
  }
  EXPECT_EQ(total, static_cast<int>(theta.size()));
  auto blocks = [&](std::vector<double>& t) {
    std::vector<const double*> out;
    for (int offset : offsets) out.push_back(t.data() + offset);
    return out;
  };
  std::vector<double> r(m), rp(m), rm(m);
  std::vector<std::vector<double>> jacobian(sizes.size());
  std::vector<double*> jacobians;
  for (size_t b = 0; b < sizes.size(); ++b) {
    jacobian[b].resize(static_cast<size_t>(m) * sizes[b]);
    jacobians.push_back(jacobian[b].data());
  }
  EXPECT_TRUE(cost.Evaluate(blocks(theta).data(), r.data(), jacobians.data()));
  double max_entry = 0.0, max_error = 0.0;
  for (const auto& j : jacobian) {
    for (double v : j) max_entry = std::max(max_entry, std::abs(v));
  }
  for (size_t b = 0; b < sizes.size(); ++b) {
    for (int c = 0; c < sizes[b]; ++c) {
      std::vector<double> plus = theta, minus = theta;
      plus[offsets[b] + c] += h;
      minus[offsets[b] + c] -= h;
      cost.Evaluate(blocks(plus).data(), rp.data(), nullptr);
      cost.Evaluate(blocks(minus).data(), rm.data(), nullptr);
      for (int i = 0; i < m; ++i) {
        const double analytic = jacobian[b][static_cast<size_t>(i) * sizes[b] + c];
        max_error = std::max(max_error, std::abs((rp[i] - rm[i]) / (2 * h) - analytic));
      }
    }
  }
  if (largest != nullptr) *largest = max_entry;
  return max_error / max_entry;
}

// The largest difference between the model's Jacobian and central
// differences of its vertices.
double ModelJacobianError(const JetDeformationModel& model, const std::vector<double>& theta) {
  Eigen::Matrix3Xd v, vp, vm;
  Eigen::MatrixXd jacobian;
  model.Evaluate(theta.data(), &v, &jacobian);
  double max_error = 0.0;
  for (int c = 0; c < model.num_parameters(); ++c) {
    std::vector<double> plus = theta, minus = theta;
    plus[c] += 1e-7;
    minus[c] -= 1e-7;
    model.Evaluate(plus.data(), &vp);
    model.Evaluate(minus.data(), &vm);
    const Eigen::Matrix3Xd numeric = (vp - vm) / 2e-7;
    for (int i = 0; i < model.num_vertices(); ++i) {
      max_error = std::max(max_error, (numeric.col(i) - jacobian.block(3 * i, c, 3, 1)).cwiseAbs().maxCoeff());
    }
  }
  return max_error;
}

// The normal equations a render cost forms directly equal those of its
// full Jacobian J and residuals r.
void ExpectNormalEquationsOf(const RenderCost& cost, const std::vector<double>& theta, const Eigen::MatrixXd& J,
                             const Eigen::VectorXd& r) {
  double squared_norm = 0.0;
  Eigen::MatrixXd jtj;
  Eigen::VectorXd jtr;
  ASSERT_TRUE(cost.EvaluateNormalEquations(theta.data(), &squared_norm, &jtj, &jtr));
  EXPECT_NEAR(squared_norm, r.squaredNorm(), 1e-9 * r.squaredNorm());
  EXPECT_LT((jtj - J.transpose() * J).norm(), 1e-9 * jtj.norm());
  EXPECT_LT((jtr - J.transpose() * r).norm(), 1e-9 * jtr.norm());
}

class FrameCostsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    GenerateSheetScene(SheetSceneOptions::Small(80, 8, 2), dir_.path().string());
    scene_ = LoadScene(dir_.path().string());
    model_ = std::make_unique<JetDeformationModel>(JetDeformationOptions(), scene_.template_mesh.vertices);
    theta_.assign(model_->num_parameters(), 0.0);
    // Away from zero so that every term is exercised.
    for (size_t k = 0; k < theta_.size(); ++k) theta_[k] = 0.01 * std::sin(1.0 + 3.0 * k);
  }
  // The render term of `frame` over the whole image.
  RenderCost::Data RenderData(const SoftRasterizer& rasterizer, const SftFrame& frame) const {
    RenderCost::Data d;
    d.model = model_.get();
    d.rasterizer = &rasterizer;
    d.mesh.faces = scene_.template_mesh.faces;
    d.mesh.corner_texcoords = scene_.template_mesh.corner_texcoords;
    d.mesh.boundary_edges = MeshBoundaryEdgeFlags(d.mesh.faces);
    d.mesh.depth_near = 0.2;
    d.mesh.depth_far = 0.8;
    d.camera = scene_.camera;
    d.image = frame.image;
    d.mask = frame.mask;
    d.roi = cv::Rect(0, 0, 80, 60);
    return d;
  }
  ScopedTempDir dir_{"polyfit_frame_costs"};
  SftScene scene_;
  std::unique_ptr<JetDeformationModel> model_;
  std::vector<double> theta_;
};

TEST_F(FrameCostsTest, ModelJacobianMatchesFiniteDifferences) {
  EXPECT_LT(ModelJacobianError(*model_, theta_), 1e-6);
  EXPECT_LT(model_->template_rms_error(), 1e-9);  // the flat sheet is a jet exactly
}

TEST(JetDeformationModelTest, TexturedCylinderFallsBackToTheTextureSpaceField) {
  // Three quarters of a cylinder: no height field over any plane.
  const int na = 24, nh = 6;
  Eigen::Matrix3Xd vertices(3, (na + 1) * (nh + 1));
  Eigen::Matrix2Xd texcoords(2, vertices.cols());
  for (int j = 0; j <= nh; ++j) {
    for (int i = 0; i <= na; ++i) {
      const double a = 1.5 * M_PI * i / na;
      vertices.col(j * (na + 1) + i) << 0.05 * std::cos(a), 0.1 * j / nh - 0.05, 0.4 + 0.05 * std::sin(a);
      texcoords.col(j * (na + 1) + i) << static_cast<double>(i) / na, static_cast<double>(j) / nh;
    }
  }
  EXPECT_THROW(JetDeformationModel(JetDeformationOptions(), vertices), std::invalid_argument);
  const JetDeformationModel model(JetDeformationOptions(), vertices, &texcoords);
  ASSERT_TRUE(model.texture_space());
  EXPECT_EQ(model.num_parameters(), 3 * 14 + 6);
  std::vector<double> theta(model.num_parameters(), 0.0);
  Eigen::Matrix3Xd at_zero;
  model.Evaluate(theta.data(), &at_zero);
  EXPECT_LT((at_zero - vertices).cwiseAbs().maxCoeff(), 1e-15);
  for (size_t k = 0; k < theta.size(); ++k) theta[k] = 0.01 * std::cos(2.0 + k);
  EXPECT_LT(ModelJacobianError(model, theta), 1e-7);
}

// A sag no 4-jet holds (a narrow bump): the detail makes the model the
// template at zero parameters, and leaves the Jacobian exact.
TEST(JetDeformationModelTest, TheTemplatesDetailIsKeptExactly) {
  const int n = 16;
  Eigen::Matrix3Xd vertices(3, (n + 1) * (n + 1));
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      const double x = 0.2 * i / n - 0.1, y = 0.2 * j / n - 0.1;
      vertices.col(j * (n + 1) + i) << x, y, 0.4 + 0.01 * std::exp(-(x * x + y * y) / (0.02 * 0.02));
    }
  }
  JetDeformationOptions options;
  options.keep_detail = false;
  const JetDeformationModel plain(options, vertices);
  const JetDeformationModel detailed(JetDeformationOptions(), vertices);
  EXPECT_GT(detailed.template_rms_error(), 5e-4);
  std::vector<double> theta(detailed.num_parameters(), 0.0);
  Eigen::Matrix3Xd with, without;
  detailed.Evaluate(theta.data(), &with);
  plain.Evaluate(theta.data(), &without);
  EXPECT_LT((with - vertices).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(std::sqrt((without - vertices).colwise().squaredNorm().mean()), plain.template_rms_error(), 1e-12);
  for (size_t k = 0; k < theta.size(); ++k) theta[k] = 0.01 * std::cos(2.0 + k);
  EXPECT_LT(ModelJacobianError(detailed, theta), 1e-6);
}
TEST_F(FrameCostsTest, RenderCostJacobianMatchesFiniteDifferences) {
  const SoftRasterizer rasterizer(SoftRasterizerOptions(), scene_.texture);
  const SftFrame frame = LoadFrame(scene_, 1);
  RenderCost::Data d = RenderData(rasterizer, frame);
  const RenderCost cost(d);
  double largest = 0.0;
  EXPECT_LT(RelativeJacobianError(cost, theta_, 1e-6, &largest), 0.02);
  EXPECT_GT(largest, 0.0);

  // The normal equations formed directly equal those of the full Jacobian.
  const int m = cost.num_residuals(), P = model_->num_parameters();
  std::vector<double> r(m), j(static_cast<size_t>(m) * P);
  const double* parameters[1] = {theta_.data()};
  double* jacobians[1] = {j.data()};
  ASSERT_TRUE(cost.Evaluate(parameters, r.data(), jacobians));
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(j.data(), m, P);
  ExpectNormalEquationsOf(cost, theta_, J, Eigen::Map<const Eigen::VectorXd>(r.data(), m));
}

// With a band around the mask's border, a silhouette within the bounds
// costs nothing (residual and Jacobian row zero); elsewhere it is the
// plain residual S - M; and the Jacobian stays exact.
TEST_F(FrameCostsTest, ASilhouetteBandFreesTheBorderAndKeepsTheJacobianExact) {
  const SoftRasterizer rasterizer(SoftRasterizerOptions(), scene_.texture);
  const SftFrame frame = LoadFrame(scene_, 1);
  RenderCost::Data d = RenderData(rasterizer, frame);
  const RenderCost plain(d);
  MaskBounds(frame.mask, 2.0, &d.mask, &d.mask_upper);
  const RenderCost banded(d);
  EXPECT_LT(RelativeJacobianError(banded, theta_, 1e-6), 0.02);

  const int m = plain.num_residuals();
  std::vector<double> r_plain(m), r_band(m);
  const double* parameters[1] = {theta_.data()};
  ASSERT_TRUE(plain.Evaluate(parameters, r_plain.data(), nullptr));
  ASSERT_TRUE(banded.Evaluate(parameters, r_band.data(), nullptr));
  int freed = 0, kept = 0;
  for (int y = 0; y < 60; ++y) {
    for (int x = 0; x < 80; ++x) {
      const int i = (y * 80 + x) * 4 + 3;
      const float lo = d.mask.at<float>(y, x), hi = d.mask_upper.at<float>(y, x);
      if (lo == hi) {
        EXPECT_EQ(r_band[i], r_plain[i]);
        ++kept;
      } else {
        EXPECT_LE(std::abs(r_band[i]), std::abs(r_plain[i]) + 1e-12);
        if (r_band[i] == 0.0 && r_plain[i] != 0.0) ++freed;
      }
    }
  }
  EXPECT_GT(freed, 50);
  EXPECT_GT(kept, 1000);
}

TEST_F(FrameCostsTest, InextensibilityAndTemporalJacobiansMatchFiniteDifferences) {
  std::vector<Eigen::Vector2i> edges = {{0, 1}, {0, 9}, {10, 11}, {5, 14}};
  std::vector<double> lengths;
  for (const auto& e : edges) {
    lengths.push_back((scene_.template_mesh.vertices.col(e[0]) - scene_.template_mesh.vertices.col(e[1])).norm());
  }
  const InextensibilityCost inextensibility(model_.get(), {0}, edges, lengths, 2.0);
  EXPECT_LT(RelativeJacobianError(inextensibility, theta_, 1e-7), 1e-5);
  const Eigen::Matrix3Xd previous = scene_.template_mesh.vertices;
  const TemporalCost temporal(model_.get(), 0, 0.3, 1.5, &previous);
  EXPECT_LT(RelativeJacobianError(temporal, theta_, 1e-7), 1e-5);
}

// Bending: r = w (theta - theta_rest) per hinge; zero on the template
// (the model is the template at zero parameters), and its Jacobian is
// the chain through the model's.
TEST_F(FrameCostsTest, BendingIsZeroOnTheTemplateAndItsJacobianMatchesFiniteDifferences) {
  const TriangleMesh& mesh = scene_.template_mesh;
  std::vector<std::array<int, 4>> hinges;
  std::vector<double> rest, weights;
  for (const MeshHinge& hinge : InteriorHinges(mesh)) {
    const auto& [i, j, k, l] = hinge.vertices;
    hinges.push_back(hinge.vertices);
    rest.push_back(SignedDihedralAngle(mesh.vertices.col(i).data(), mesh.vertices.col(j).data(),
                                       mesh.vertices.col(k).data(), mesh.vertices.col(l).data()));
    weights.push_back(1.5);
  }
  ASSERT_GT(hinges.size(), 100u);
  const BendingCost bending(model_.get(), {0}, hinges, rest, weights);
  const std::vector<double> zero(theta_.size(), 0.0);
  std::vector<double> r(hinges.size());
  const double* at_rest[1] = {zero.data()};
  ASSERT_TRUE(bending.Evaluate(at_rest, r.data(), nullptr));
  for (double v : r) EXPECT_NEAR(v, 0.0, 1e-9);
  const double* bent[1] = {theta_.data()};
  ASSERT_TRUE(bending.Evaluate(bent, r.data(), nullptr));
  double largest = 0.0;
  for (double v : r) largest = std::max(largest, std::abs(v));
  EXPECT_GT(largest, 1e-3);  // theta_ bends the sheet
  EXPECT_LT(RelativeJacobianError(bending, theta_, 1e-7), 1e-5);
}

// Order 2: r = (w / L) (x_t - 2 x_t-1 + x_t-2), alike whether the earlier
// frames are parameters or data; with a velocity b < 1, x_t-1 carried on
// at b times its velocity.
TEST_F(FrameCostsTest, TheSecondOrderTemporalTermHoldsAFrameToTheLineThroughTheTwoBefore) {
  ASSERT_EQ(model_->num_patches(), 1);
  const int b = model_->block_size();
  std::vector<double> frames[3] = {theta_, theta_, theta_};
  frames[1][3] += 0.01;  // each frame a little elsewhere
  frames[2][4] -= 0.02;
  frames[0][0] += 0.005;
  Eigen::Matrix3Xd x[3];
  for (int f = 0; f < 3; ++f) model_->Evaluate(frames[f].data(), &x[f]);
  const double scale = 1.5 / 0.3;
  const Eigen::Matrix3Xd expected = scale * (x[0] - 2.0 * x[1] + x[2]);

  std::vector<double> all = frames[0];
  all.insert(all.end(), frames[1].begin(), frames[1].end());
  all.insert(all.end(), frames[2].begin(), frames[2].end());
  const TemporalCost free(model_.get(), 0, 0.3, 1.5, 2, {});
  ASSERT_EQ(free.parameter_block_sizes().size(), 3u);
  const TemporalCost last_fixed(model_.get(), 0, 0.3, 1.5, 2, {&x[2]});
  const TemporalCost both_fixed(model_.get(), 0, 0.3, 1.5, 2, {&x[1], &x[2]});
  ASSERT_EQ(both_fixed.parameter_block_sizes().size(), 1u);
  Eigen::Matrix3Xd r(3, model_->num_vertices());
  const double* blocks[3] = {frames[0].data(), frames[1].data(), frames[2].data()};
  for (const TemporalCost* cost : {&free, &last_fixed, &both_fixed}) {
    ASSERT_TRUE(cost->Evaluate(blocks, r.data(), nullptr));
    EXPECT_LT((r - expected).cwiseAbs().maxCoeff(), 1e-12);
  }
  EXPECT_LT(RelativeJacobianError(free, all, 1e-7), 1e-5);
  EXPECT_LT(RelativeJacobianError(last_fixed, std::vector<double>(all.begin(), all.begin() + 2 * b), 1e-7), 1e-5);
  EXPECT_LT(RelativeJacobianError(both_fixed, frames[0], 1e-7), 1e-5);
  EXPECT_THROW(TemporalCost(model_.get(), 0, 0.3, 1.5, 3, {}), std::invalid_argument);
  EXPECT_THROW(TemporalCost(model_.get(), 0, 0.3, 1.5, 1, {&x[1], &x[2]}), std::invalid_argument);

  // A damped inertia: the frame before carried on at half its velocity,
  // r = (w / L) (x_t - 1.5 x_t-1 + 0.5 x_t-2); at 0, the order-1 hold.
  const Eigen::Matrix3Xd damped = scale * (x[0] - 1.5 * x[1] + 0.5 * x[2]);
  const TemporalCost half(model_.get(), 0, 0.3, 1.5, 2, {}, Eigen::Vector3d::Zero(), {}, 0.5);
  const TemporalCost half_fixed(model_.get(), 0, 0.3, 1.5, 2, {&x[2]}, Eigen::Vector3d::Zero(), {}, 0.5);
  for (const TemporalCost* cost : {&half, &half_fixed}) {
    ASSERT_TRUE(cost->Evaluate(blocks, r.data(), nullptr));
    EXPECT_LT((r - damped).cwiseAbs().maxCoeff(), 1e-12);
  }
  EXPECT_LT(RelativeJacobianError(half, all, 1e-7), 1e-5);
  const TemporalCost still(model_.get(), 0, 0.3, 1.5, 2, {}, Eigen::Vector3d::Zero(), {}, 0.0);
  ASSERT_TRUE(still.Evaluate(blocks, r.data(), nullptr));
  EXPECT_LT((r - scale * (x[0] - x[1])).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_THROW(TemporalCost(model_.get(), 0, 0.3, 1.5, 2, {}, Eigen::Vector3d::Zero(), {}, NAN),
               std::invalid_argument);
}

// On some of the patch's vertices only (the ones a fold hides): their
// rows of the whole patch's residual, exact derivatives, and a vertex of
// another patch refused.
TEST_F(FrameCostsTest, TheTemporalTermOnSomeVerticesIsThoseVerticesRows) {
  ASSERT_EQ(model_->num_patches(), 1);
  std::vector<double> frames[2] = {theta_, theta_};
  frames[1][3] += 0.01;
  Eigen::Matrix3Xd before;
  model_->Evaluate(frames[1].data(), &before);
  const TemporalCost all(model_.get(), 0, 0.3, 1.5, 1, {&before});
  const std::vector<int> some = {2, 7, 11};
  const TemporalCost held(model_.get(), 0, 0.3, 1.5, 1, {&before}, Eigen::Vector3d::Zero(), some);
  ASSERT_EQ(held.num_residuals(), 9);
  Eigen::Matrix3Xd r_all(3, model_->num_vertices()), r_some(3, 3);
  const double* blocks[1] = {frames[0].data()};
  ASSERT_TRUE(all.Evaluate(blocks, r_all.data(), nullptr));
  ASSERT_TRUE(held.Evaluate(blocks, r_some.data(), nullptr));
  for (int k = 0; k < 3; ++k) EXPECT_LT((r_some.col(k) - r_all.col(some[k])).norm(), 1e-15);
  EXPECT_GT(r_some.norm(), 1e-4);
  EXPECT_LT(RelativeJacobianError(held, frames[0], 1e-7), 1e-5);
  EXPECT_THROW(TemporalCost(model_.get(), 0, 0.3, 1.5, 1, {&before}, Eigen::Vector3d::Zero(), {model_->num_vertices()}),
               std::invalid_argument);
}

// With gravity folded in (the shift g dt^2), the target is InertiaResidual's
// (k_g = k_i): the residual is the order-2 one less (w / L) g dt^2.
TEST_F(FrameCostsTest, TheSecondOrderTemporalTermWithGravityHoldsAFrameWhereAFreeFallGoes) {
  ASSERT_EQ(model_->num_patches(), 1);
  const Eigen::Vector3d gravity(0.0, 7.5, 6.3);  // camera frame, m/s^2
  const double dt = 1.0 / 30.0;
  const Eigen::Vector3d shift = InertiaResidual::GravityShift(dt, 1.0, 1.0, gravity.norm(), -gravity.normalized());
  EXPECT_LT((shift - gravity * dt * dt).norm(), 1e-15);
  std::vector<double> frames[3] = {theta_, theta_, theta_};
  frames[1][3] += 0.01;
  frames[2][4] -= 0.02;
  Eigen::Matrix3Xd x[3];
  for (int f = 0; f < 3; ++f) model_->Evaluate(frames[f].data(), &x[f]);
  const double scale = 1.5 / 0.3;
  const TemporalCost both_fixed(model_.get(), 0, 0.3, 1.5, 2, {&x[1], &x[2]}, shift);
  const TemporalCost last_fixed(model_.get(), 0, 0.3, 1.5, 2, {&x[2]}, shift);
  Eigen::Matrix3Xd r(3, model_->num_vertices());
  const double* blocks[2] = {frames[0].data(), frames[1].data()};
  ASSERT_TRUE(both_fixed.Evaluate(blocks, r.data(), nullptr));
  Eigen::Matrix3Xd expected = scale * (x[0] - 2.0 * x[1] + x[2]);
  expected.colwise() -= scale * shift;
  EXPECT_LT((r - expected).cwiseAbs().maxCoeff(), 1e-12);
  // Vertex by vertex, InertiaResidual's target (unit mass and weight).
  for (int v = 0; v < model_->num_vertices(); v += 7) {
    const InertiaResidual inertia(x[1].col(v), x[2].col(v), 1.0, dt, 1.0, 1.0, gravity.norm(), -gravity.normalized());
    EXPECT_LT((x[0].col(v) - inertia.predicted() - r.col(v) / scale).norm(), 1e-12);
  }
  ASSERT_TRUE(last_fixed.Evaluate(blocks, r.data(), nullptr));
  EXPECT_LT((r - expected).cwiseAbs().maxCoeff(), 1e-12);
  std::vector<double> both = frames[0];
  both.insert(both.end(), frames[1].begin(), frames[1].end());
  EXPECT_LT(RelativeJacobianError(last_fixed, both, 1e-7), 1e-5);
  EXPECT_THROW(TemporalCost(model_.get(), 0, 0.3, 1.5, 1, {&x[1]}, shift), std::invalid_argument);
}

// The outline's distance: 0 inside (holes filled), the distance to the
// nearest inside pixel less half a pixel outside, and straight on beyond
// the image.
TEST(OutsideDistanceTest, FillsHolesAndMeasuresPixels) {
  cv::Mat mask(40, 60, CV_8U, cv::Scalar(0));
  cv::rectangle(mask, cv::Rect(20, 10, 20, 20), cv::Scalar(255), cv::FILLED);
  cv::rectangle(mask, cv::Rect(27, 17, 5, 5), cv::Scalar(0), cv::FILLED);  // a hole
  const cv::Mat d = OutsideDistance(mask);
  EXPECT_EQ(d.at<float>(19, 29), 0.0f);  // in the hole
  EXPECT_NEAR(d.at<float>(20, 45), 5.5, 1e-3);
  Eigen::Vector2d gradient;
  EXPECT_NEAR(SampleOutsideDistance(d, 45.5, 20.0, &gradient), 6.0, 1e-3);
  EXPECT_NEAR(gradient.x(), 1.0, 1e-3);
  EXPECT_NEAR(SampleOutsideDistance(d, 62.0, 20.0, &gradient), d.at<float>(20, 59) + 3.0, 1e-3);
  EXPECT_EQ(gradient.x(), 1.0);
  // An object the image cuts off goes on past it; one that stays inside
  // does not.
  cv::Mat cut(40, 60, CV_8U, cv::Scalar(0));
  cv::rectangle(cut, cv::Rect(40, 10, 20, 20), cv::Scalar(255), cv::FILLED);
  const cv::Mat padded = OutsideDistance(cut, 8);
  ASSERT_EQ(padded.cols, 76);
  EXPECT_EQ(padded.at<float>(20 + 8, 63 + 8), 0.0f);
  EXPECT_NEAR(padded.at<float>(20 + 8, -4 + 8), 43.5, 1e-3);
}

// The reach pulls the vertices that project outside the mask's outline,
// with an exact Jacobian, and costs nothing while the surface is inside.
TEST_F(FrameCostsTest, SilhouetteReachIsZeroInsideAndExactOutside) {
  const SftFrame frame = LoadFrame(scene_, 0);
  const cv::Mat outside = OutsideDistance(frame.mask, 10);
  const SilhouetteReachCost reach(model_.get(), 0, scene_.camera, outside, 10, 0.5, 20.0);
  ASSERT_EQ(reach.num_residuals(), model_->num_vertices());
  std::vector<double> theta(model_->num_parameters(), 0.0), r(reach.num_residuals());
  const double* blocks[] = {theta.data()};
  ASSERT_TRUE(reach.Evaluate(blocks, r.data(), nullptr));
  EXPECT_LT(Eigen::Map<Eigen::VectorXd>(r.data(), r.size()).cwiseAbs().maxCoeff(), 1e-9);
  // Moved along the frame's u by a third of the sheet (the frame's units
  // span it as [-1, 1]), tilted and bent: part of it is outside.
  theta = theta_;
  theta[model_->translation_offset()] += 0.7;
  ASSERT_TRUE(reach.Evaluate(blocks, r.data(), nullptr));
  int outside_count = 0;
  for (double v : r) outside_count += v > 0.0;
  EXPECT_GT(outside_count, model_->num_vertices() / 5);
  EXPECT_LT(RelativeJacobianError(reach, theta, 1e-7), 1e-5);
}

// The atlas: the sheet split in four by ACVD, each child inheriting the
// parent's parameters, is the same surface; its hand Jacobian matches
// finite differences and the templated definition (automatic
// differentiation); and every cost over the patches' blocks is exact.
// A compressed term's cost, Gauss-Newton matrix and gradient.
struct NormalSystem {
  double cost = 0.0;
  Eigen::MatrixXd jtj;
  Eigen::VectorXd jtr;
};

// `candidate` against the exact system: the same cost, and J^T J and J^T r
// no further from it than twice `reference` is, and within the rounding
// of factorising a render term's ill-conditioned system.
void ExpectCompressedAsWell(const NormalSystem& candidate, const NormalSystem& reference, const NormalSystem& exact) {
  EXPECT_NEAR(candidate.cost, exact.cost, 1e-9 * exact.cost);
  EXPECT_NEAR(reference.cost, exact.cost, 1e-9 * exact.cost);
  const double jtj_error = (candidate.jtj - exact.jtj).norm(), jtr_error = (candidate.jtr - exact.jtr).norm();
  EXPECT_LT(jtj_error, 2.0 * (reference.jtj - exact.jtj).norm() + 1e-9 * exact.jtj.norm());
  EXPECT_LT(jtr_error, 2.0 * (reference.jtr - exact.jtr).norm() + 1e-9 * exact.jtr.norm());
  EXPECT_LT(jtj_error, 1e-4 * exact.jtj.norm());
  EXPECT_LT(jtr_error, 1e-2 * exact.jtr.norm());
}

class AtlasCostsTest : public FrameCostsTest {
 protected:
  void SetUp() override {
    FrameCostsTest::SetUp();
    model_->Evaluate(theta_.data(), &before_split_);
    const std::vector<int> child = SplitPatchVertices(scene_.template_mesh, model_->vertex_patches(), 0, 4);
    ASSERT_FALSE(child.empty());
    const PatchSplit split = model_->SplitPatch(0, child);
    EXPECT_EQ(split.num_children, 4);
    theta_ = model_->InheritParameters(split, theta_);
  }
  // A problem over theta_'s patch blocks (in patch order), its split render
  // terms prepared by `callback`.
  std::unique_ptr<ceres::Problem> NewProblem(RenderTermCallback* callback) {
    ceres::Problem::Options options;
    options.evaluation_callback = callback;
    auto problem = std::make_unique<ceres::Problem>(options);
    const int b = model_->block_size();
    for (int p = 0; p < model_->num_patches(); ++p) problem->AddParameterBlock(theta_.data() + b * p, b);
    return problem;
  }
  void AddRowBlocks(const SplitRenderTerm& split, ceres::Problem* problem) {
    for (int i = 0; i < split.num_row_blocks(); ++i) {
      std::vector<double*> blocks;
      for (const int p : split.row_block_patches(i)) blocks.push_back(theta_.data() + model_->block_size() * p);
      problem->AddResidualBlock(split.NewRowBlockCost(i), nullptr, blocks);
    }
  }
  Eigen::Matrix3Xd before_split_;
};

TEST_F(AtlasCostsTest, ChildrenInheritTheSurfaceAndTheJacobianIsExact) {
  ASSERT_EQ(model_->num_patches(), 4);
  for (int size : model_->PatchSizes()) EXPECT_GE(size, 10);
  Eigen::Matrix3Xd v;
  model_->Evaluate(theta_.data(), &v);
  EXPECT_LT((v - before_split_).cwiseAbs().maxCoeff(), 1e-12);
  // Each child moves on its own: perturb, then differentiate.
  for (size_t k = 0; k < theta_.size(); ++k) theta_[k] += 0.005 * std::cos(0.3 + 7.0 * k);
  EXPECT_LT(ModelJacobianError(*model_, theta_), 1e-6);
  // The hand Jacobian against the templated definition, also where a
  // vertex is placed by a patch that does not own it.
  const int b = model_->block_size();
  using J = ceres::Jet<double, 64>;
  ASSERT_LE(b, 64);
  for (int i = 0; i < model_->num_vertices(); i += 7) {
    for (int p = 0; p < model_->num_patches(); ++p) {
      const double* block = theta_.data() + b * p;
      std::vector<J> jets(b);
      for (int k = 0; k < b; ++k) jets[k] = J(block[k], k);
      J x[3], n[3];
      model_->VertexOnPatch(i, p, jets.data(), x, n);
      Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor> rows(3, b);
      Eigen::Vector3d position;
      model_->EvaluateVertex(i, p, block, position.data(), rows.data());
      for (int r = 0; r < 3; ++r) {
        EXPECT_NEAR(x[r].a, position[r], 1e-14);
        EXPECT_LT((x[r].v.head(b).transpose() - rows.row(r)).cwiseAbs().maxCoeff(), 1e-12);
      }
    }
  }
}

// The patches to split: the one fitting worse than its first frame, with
// as many children as it holds down to min_children; none where even
// those would be too small or would overflow max_patches.
TEST_F(AtlasCostsTest, APatchTooSmallForFourChildrenSplitsInTwoWhereAllowed) {
  const std::vector<int> sizes = model_->PatchSizes();
  const int V = model_->num_vertices();
  const Eigen::VectorXd floor = Eigen::VectorXd::Ones(V), pixels = Eigen::VectorXd::Ones(V);
  Eigen::VectorXd squared = floor;
  for (int i = 0; i < V; ++i) {
    if (model_->patch_of_vertex(i) == 2) squared[i] = 3.0;  // patch 2 fits 3 times worse
  }
  PatchAtlasOptions options;
  options.max_patches = 16;
  options.min_vertices = sizes[2] / 2;  // room for two children of patch 2, not four
  ASSERT_EQ(options.ChildrenFor(sizes[2]), 0);
  EXPECT_TRUE(PatchesToSplit(options, *model_, squared, pixels, floor, pixels).empty());
  options.min_children = 2;
  ASSERT_TRUE(options.Validate().empty()) << options.Validate();
  EXPECT_EQ(options.ChildrenFor(sizes[2]), 2);
  EXPECT_EQ(options.ChildrenFor(4 * options.min_vertices), 4);
  EXPECT_EQ(options.ChildrenFor(options.min_vertices), 0);
  EXPECT_EQ(PatchesToSplit(options, *model_, squared, pixels, floor, pixels), std::vector<int>{2});
  options.max_patches = model_->num_patches();  // full
  EXPECT_TRUE(PatchesToSplit(options, *model_, squared, pixels, floor, pixels).empty());
  options.min_children = 5;
  EXPECT_NE(options.Validate().find("min_children"), std::string::npos);
  options.min_children = 2;
  for (double PatchAtlasOptions::*weight : {&PatchAtlasOptions::seam_uv_weight, &PatchAtlasOptions::coarse_seam_uv_weight,
                                           &PatchAtlasOptions::seen_seam_uv_weight}) {
    PatchAtlasOptions bad = options;
    bad.*weight = -1.0;
    EXPECT_NE(bad.Validate().find("seam weights"), std::string::npos);
    bad.*weight = std::nan("");
    EXPECT_NE(bad.Validate().find("seam weights"), std::string::npos);
    bad.*weight = 0.0;
    EXPECT_TRUE(bad.Validate().empty()) << bad.Validate();
  }
  for (double value : {-1e-4, std::nan(""), HUGE_VAL}) {
    PatchAtlasOptions bad = options;
    bad.seam_uv_robust = value;
    EXPECT_NE(bad.Validate().find("atlas.seam_uv_robust"), std::string::npos) << value;
    bad = options;
    bad.seen_seam_uv_robust = value;
    EXPECT_NE(bad.Validate().find("atlas.seen_seam_uv_robust"), std::string::npos) << value;
  }
}

TEST_F(AtlasCostsTest, CostsOverPatchBlocksAreExact) {
  // Children apart, a little: larger steps make the soft render's finite
  // differences cross its cut-offs.
  for (size_t k = 0; k < theta_.size(); ++k) theta_[k] += 0.001 * std::cos(0.3 + 7.0 * k);
  const SoftRasterizer rasterizer(SoftRasterizerOptions(), scene_.texture);
  const SftFrame frame = LoadFrame(scene_, 1);
  const RenderCost cost(RenderData(rasterizer, frame));
  ASSERT_EQ(cost.parameter_block_sizes().size(), 4u);
  EXPECT_LT(RelativeJacobianError(cost, theta_, 1e-6), 0.02);
  // The normal equations gathered by patch equal those of the full
  // Jacobian (rows of seam pixels span several blocks).
  const int m = cost.num_residuals(), P = model_->num_parameters(), b = model_->block_size();
  std::vector<double> r(m);
  std::vector<std::vector<double>> j(4, std::vector<double>(static_cast<size_t>(m) * b));
  std::vector<const double*> parameters;
  std::vector<double*> jacobians;
  for (int p = 0; p < 4; ++p) {
    parameters.push_back(theta_.data() + b * p);
    jacobians.push_back(j[p].data());
  }
  ASSERT_TRUE(cost.Evaluate(parameters.data(), r.data(), jacobians.data()));
  Eigen::MatrixXd full(m, P);
  for (int p = 0; p < 4; ++p) {
    full.middleCols(b * p, b) =
        Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(j[p].data(), m, b);
  }
  const Eigen::Map<const Eigen::VectorXd> R(r.data(), m);
  ExpectNormalEquationsOf(cost, theta_, full, R);
  // Pixels shared among vertices add up to the covered pixels' cost.
  Eigen::VectorXd squared, pixels;
  ASSERT_TRUE(cost.VertexResiduals(theta_.data(), &squared, &pixels));
  EXPECT_GT(pixels.sum(), 100.0);
  EXPECT_LE(squared.sum(), R.squaredNorm() * (1.0 + 1e-9));

  // Inextensibility across a seam, temporal per patch, and the seam itself.
  std::vector<int> ends(2, -1);
  Eigen::Vector2i seam_edge(-1, -1);
  for (int f = 0; f < scene_.template_mesh.num_faces() && seam_edge[0] < 0; ++f) {
    const int a = scene_.template_mesh.faces(0, f), c = scene_.template_mesh.faces(1, f);
    if (model_->patch_of_vertex(a) != model_->patch_of_vertex(c)) seam_edge = Eigen::Vector2i(a, c);
  }
  ASSERT_GE(seam_edge[0], 0);
  const int pa = model_->patch_of_vertex(seam_edge[0]), pb = model_->patch_of_vertex(seam_edge[1]);
  const std::vector<int> pair = {std::min(pa, pb), std::max(pa, pb)};
  const double length =
      (scene_.template_mesh.vertices.col(seam_edge[0]) - scene_.template_mesh.vertices.col(seam_edge[1])).norm();
  const InextensibilityCost across(model_.get(), pair, {seam_edge}, {length}, 2.0);
  std::vector<double> pair_theta(theta_.begin() + b * pair[0], theta_.begin() + b * (pair[0] + 1));
  pair_theta.insert(pair_theta.end(), theta_.begin() + b * pair[1], theta_.begin() + b * (pair[1] + 1));
  EXPECT_LT(RelativeJacobianError(across, pair_theta, 1e-7), 1e-5);
  const TemporalCost temporal(model_.get(), pair[1], 0.3, 1.5);
  std::vector<double> two_frames(theta_.begin() + b * pair[1], theta_.begin() + b * (pair[1] + 1));
  two_frames.insert(two_frames.end(), two_frames.begin(), two_frames.end());
  two_frames[3] += 0.01;
  EXPECT_LT(RelativeJacobianError(temporal, two_frames, 1e-7), 1e-5);
  std::unique_ptr<ceres::CostFunction> seam(
      CreateSeamCost(model_.get(), pair[0], pair[1], {seam_edge}, 0.01, 1.0, 0.1));
  EXPECT_LT(RelativeJacobianError(*seam, pair_theta, 1e-7), 1e-5);
  // A hinge over more than one patch.
  bool across_patches = false;
  for (const MeshHinge& hinge : InteriorHinges(scene_.template_mesh)) {
    std::vector<int> patches;
    for (int i : hinge.vertices) patches.push_back(model_->patch_of_vertex(i));
    std::sort(patches.begin(), patches.end());
    patches.erase(std::unique(patches.begin(), patches.end()), patches.end());
    if (patches.size() < 2) continue;
    std::vector<double> blocks;
    for (int p : patches) blocks.insert(blocks.end(), theta_.begin() + b * p, theta_.begin() + b * (p + 1));
    const BendingCost bending(model_.get(), patches, {hinge.vertices}, {0.1}, {2.0});
    EXPECT_LT(RelativeJacobianError(bending, blocks, 1e-7), 1e-5);
    across_patches = true;
    break;
  }
  EXPECT_TRUE(across_patches);
  std::unique_ptr<ceres::CostFunction> shared_uv(CreateSharedUvCost(model_.get(), 3.0));
  EXPECT_EQ(shared_uv->num_residuals(), model_->num_duv());
  EXPECT_LT(RelativeJacobianError(*shared_uv, pair_theta, 1e-7), 1e-8);
  // Robust: the pseudo-Huber penalty of the fields' difference, and its Jacobian.
  for (double scale : {0.003, 0.3}) {
    std::unique_ptr<ceres::CostFunction> robust(CreateSharedUvCost(model_.get(), 3.0, scale));
    EXPECT_LT(RelativeJacobianError(*robust, pair_theta, 1e-7), 1e-6);
    std::vector<double> plain_r(shared_uv->num_residuals()), robust_r(plain_r.size());
    const double* blocks[] = {pair_theta.data(), pair_theta.data() + b};
    shared_uv->Evaluate(blocks, plain_r.data(), nullptr);
    robust->Evaluate(blocks, robust_r.data(), nullptr);
    double plain2 = 0.0, robust2 = 0.0;
    for (size_t k = 0; k < plain_r.size(); ++k) {
      plain2 += plain_r[k] * plain_r[k];
      robust2 += robust_r[k] * robust_r[k];
    }
    const double wb = 3.0 * scale;  // the penalty in the residual's units
    EXPECT_NEAR(robust2, 2.0 * wb * wb * (std::sqrt(1.0 + plain2 / (wb * wb)) - 1.0), 1e-9 * robust2);
  }
  EXPECT_THROW(CreateSharedUvCost(model_.get(), 3.0, -1.0), std::invalid_argument);
  EXPECT_THROW(CreateSharedUvCost(model_.get(), 0.0), std::invalid_argument);
}

// The sheet seen from so far that a pixel covers most of it: its vertices
// span more patches than a pixel's block holds. The evaluation does not
// fail (it did, and the solve with it); the strongest pulls are kept, the
// same in the dense Jacobian and in the normal equations.
TEST_F(AtlasCostsTest, APixelOverMorePatchesThanItsBlockHoldsIsEvaluated) {
  for (int p = 0; p < 4; ++p) {
    const std::vector<int> child = SplitPatchVertices(scene_.template_mesh, model_->vertex_patches(), p, 4);
    ASSERT_FALSE(child.empty());
    theta_ = model_->InheritParameters(model_->SplitPatch(p, child), theta_);
  }
  ASSERT_GT(model_->num_patches(), 8);
  for (size_t k = 0; k < theta_.size(); ++k) theta_[k] += 0.001 * std::cos(0.3 + 7.0 * k);
  SoftRasterizerOptions options;
  options.sigma = 2.0;
  const SoftRasterizer rasterizer(options, scene_.texture);
  const SftFrame frame = LoadFrame(scene_, 1);
  RenderCost::Data data = RenderData(rasterizer, frame);
  data.camera.fx /= 100.0;
  data.camera.fy /= 100.0;
  const RenderCost cost(std::move(data));
  const int m = cost.num_residuals(), P = model_->num_parameters(), b = model_->block_size();
  std::vector<double> r(m);
  std::vector<std::vector<double>> j(model_->num_patches(), std::vector<double>(static_cast<size_t>(m) * b));
  std::vector<const double*> parameters;
  std::vector<double*> jacobians;
  for (int p = 0; p < model_->num_patches(); ++p) {
    parameters.push_back(theta_.data() + b * p);
    jacobians.push_back(j[p].data());
  }
  ASSERT_TRUE(cost.Evaluate(parameters.data(), r.data(), jacobians.data()));
  Eigen::MatrixXd full(m, P);
  for (int p = 0; p < model_->num_patches(); ++p) {
    full.middleCols(b * p, b) =
        Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(j[p].data(), m, b);
  }
  EXPECT_TRUE(full.allFinite());
  EXPECT_GT(full.cwiseAbs().maxCoeff(), 0.0);
  ExpectNormalEquationsOf(cost, theta_, full, Eigen::Map<const Eigen::VectorXd>(r.data(), m));
  // Some pixel's row lost a pull: its Jacobian is not all of the finite
  // differences', but most of it.
  double largest = 0.0;
  const double error = RelativeJacobianError(cost, theta_, 1e-6, &largest);
  EXPECT_GT(error, 1e-3);
  EXPECT_LT(error, 0.5);
}

// Keypoints on faces whose corners span two or more patches: residuals
// are the projection's offset (less the dead zone, Huber beyond its
// threshold), and the Jacobian over each patch's block is exact.
TEST_F(AtlasCostsTest, FeatureCostProjectsItsSurfacePointsAndIsExact) {
  for (size_t k = 0; k < theta_.size(); ++k) theta_[k] += 0.002 * std::cos(0.3 + 7.0 * k);
  const int b = model_->block_size();
  const Eigen::Matrix3Xi& faces = scene_.template_mesh.faces;
  std::vector<int> seam_faces;
  for (int f = 0; f < faces.cols() && seam_faces.size() < 3; ++f) {
    if (model_->patch_of_vertex(faces(0, f)) != model_->patch_of_vertex(faces(1, f)) ||
        model_->patch_of_vertex(faces(0, f)) != model_->patch_of_vertex(faces(2, f))) {
      seam_faces.push_back(f);
    }
  }
  ASSERT_EQ(seam_faces.size(), 3u);
  Eigen::Matrix3Xd v;
  model_->Evaluate(theta_.data(), &v);
  // Offsets of 5 px, 0.5 px (within a 2 px dead zone) and 40 px (past a
  // Huber threshold).
  const Eigen::Vector2d offsets[] = {{3.0, -4.0}, {0.3, 0.4}, {24.0, 32.0}};
  std::vector<FeatureCost::Point> points;
  for (int j = 0; j < 3; ++j) {
    const Eigen::Vector3d barycentric(0.2, 0.5, 0.3);
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) x += barycentric[k] * v.col(faces(k, seam_faces[j]));
    points.push_back({faces.col(seam_faces[j]), barycentric, scene_.camera.Project(x) + offsets[j]});
  }
  auto blocks_of = [&](const FeatureCost& cost, std::vector<double>* flat, std::vector<const double*>* blocks) {
    for (int p : cost.patches()) flat->insert(flat->end(), theta_.begin() + b * p, theta_.begin() + b * (p + 1));
    for (size_t p = 0; p < cost.patches().size(); ++p) blocks->push_back(flat->data() + b * p);
  };
  // Plain: r = w (projected - observed).
  const FeatureCost plain(model_.get(), points, scene_.camera, 0.5, 0.0, 1e9);
  ASSERT_GE(plain.patches().size(), 2u);
  std::vector<double> flat;
  std::vector<const double*> blocks;
  blocks_of(plain, &flat, &blocks);
  double r[6];
  ASSERT_TRUE(plain.Evaluate(blocks.data(), r, nullptr));
  EXPECT_NEAR(r[0], -1.5, 1e-9);
  EXPECT_NEAR(r[1], 2.0, 1e-9);
  EXPECT_NEAR(r[5], -16.0, 1e-9);
  EXPECT_LT(RelativeJacobianError(plain, flat, 1e-7), 1e-6);
  // A 2 px dead zone and Huber at 5 (residual units): the 5 px offset
  // shortens to 3 px (1.5 after w), the 0.5 px one vanishes, the 40 px one
  // (19 after w, past 5) has |r|^2 = 2 a m - a^2.
  const FeatureCost robust(model_.get(), points, scene_.camera, 0.5, 2.0, 5.0);
  ASSERT_TRUE(robust.Evaluate(blocks.data(), r, nullptr));
  EXPECT_NEAR(r[0], -1.5 * 0.6, 1e-9);
  EXPECT_NEAR(r[1], 2.0 * 0.6, 1e-9);
  EXPECT_EQ(r[2], 0.0);
  EXPECT_EQ(r[3], 0.0);
  EXPECT_NEAR(r[4] * r[4] + r[5] * r[5], 2.0 * 5.0 * 19.0 - 25.0, 1e-9);
  EXPECT_LT(RelativeJacobianError(robust, flat, 1e-7), 1e-6);
}

TEST(PatchGroupsTest, FindsTheSmallestGroupHoldingAPixelsPatches) {
  PatchGroups groups;
  groups.groups = {{0, 1, 2}, {1, 3}, {4}};
  bool whole = false;
  const int a[] = {1}, b[] = {1, 3}, c[] = {0, 2}, d[] = {2, 3}, e[] = {5};
  EXPECT_EQ(groups.Find(a, 1, &whole), 1);  // {1, 3} is smaller than {0, 1, 2}
  EXPECT_TRUE(whole);
  EXPECT_EQ(groups.Find(b, 2, &whole), 1);
  EXPECT_EQ(groups.Find(c, 2, &whole), 0);
  EXPECT_TRUE(whole);
  EXPECT_EQ(groups.Find(d, 2, &whole), 1);  // in no group: one of those holding one
  EXPECT_FALSE(whole);
  EXPECT_EQ(groups.Find(e, 1, &whole), -1);
}

// Groups that do not hold every pixel's patches: a pixel's rows keep the
// columns of the group that holds most of them (none without one), and
// its cost; the normal equations are those rows' J^T J and J^T r exactly.
TEST_F(AtlasCostsTest, APixelKeepsTheColumnsOfTheGroupHoldingMostOfItsPatches) {
  for (size_t k = 0; k < theta_.size(); ++k) theta_[k] += 0.001 * std::cos(0.3 + 7.0 * k);
  const SoftRasterizer rasterizer(SoftRasterizerOptions(), scene_.texture);
  const SftFrame frame = LoadFrame(scene_, 1);
  const RenderCost cost(RenderData(rasterizer, frame));
  const int m = cost.num_residuals(), P = model_->num_parameters(), b = model_->block_size();
  const int K = model_->num_patches();
  ASSERT_EQ(K, 4);
  std::vector<double> r(m);
  std::vector<std::vector<double>> j(K, std::vector<double>(static_cast<size_t>(m) * b));
  std::vector<const double*> parameters;
  std::vector<double*> jacobians;
  for (int p = 0; p < K; ++p) {
    parameters.push_back(theta_.data() + b * p);
    jacobians.push_back(j[p].data());
  }
  ASSERT_TRUE(cost.Evaluate(parameters.data(), r.data(), jacobians.data()));
  Eigen::MatrixXd full(m, P);
  for (int p = 0; p < K; ++p) {
    full.middleCols(b * p, b) =
        Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(j[p].data(), m, b);
  }
  PatchGroups groups;
  groups.groups = {{0, 1}, {2, 3}};
  // Each pixel's four rows, the columns outside its group zeroed.
  int dropped = 0;
  for (int row = 0; row < m; row += 4) {
    int patches[4], size = 0;
    for (int p = 0; p < K; ++p) {
      if (full.block(row, b * p, 4, b).cwiseAbs().maxCoeff() > 0.0) patches[size++] = p;
    }
    if (size == 0) continue;
    bool whole = false;
    const std::vector<int>& members = groups.groups[groups.Find(patches, size, &whole)];
    for (int i = 0; i < size; ++i) {
      if (std::find(members.begin(), members.end(), patches[i]) != members.end()) continue;
      full.block(row, b * patches[i], 4, b).setZero();
      ++dropped;
    }
  }
  EXPECT_GT(dropped, 0);
  std::vector<int> slot(K);
  for (int p = 0; p < K; ++p) slot[p] = p;
  double sum = 0.0;
  Eigen::MatrixXd slotted = Eigen::MatrixXd::Zero(P, P);
  Eigen::VectorXd slotted_jtr;
  ASSERT_TRUE(cost.EvaluateSlottedNormalEquations(theta_.data(), groups, slot, true, &sum, &slotted, &slotted_jtr));
  const Eigen::Map<const Eigen::VectorXd> R(r.data(), m);
  EXPECT_NEAR(sum, R.squaredNorm(), 1e-12 * sum);
  const Eigen::MatrixXd jtj = full.transpose() * full;
  const Eigen::VectorXd jtr = full.transpose() * R;
  EXPECT_LT((slotted_jtr - jtr).norm(), 1e-9 * jtr.norm());
  for (const std::vector<int>& g : groups.groups) {
    for (const int p : g) {
      for (const int q : g) {
        if (q < p) continue;
        EXPECT_LT((slotted.block(b * p, b * q, b, b) - jtj.block(b * p, b * q, b, b)).norm(), 1e-9 * jtj.norm())
            << p << ", " << q;
      }
    }
  }
  // No coupling across the groups.
  EXPECT_EQ(slotted.block(0, 2 * b, 2 * b, 2 * b).norm(), 0.0);
}

// A trial point's render kept (the cost alone, rendered with its
// gradients) gives the normal equations at that point to the bit, and a
// different point is rendered afresh.
TEST_F(AtlasCostsTest, ARenderKeptAtATrialPointGivesTheSameNormalEquations) {
  using Reuse = RenderCost::RenderReuse;
  for (size_t k = 0; k < theta_.size(); ++k) theta_[k] += 0.001 * std::cos(0.3 + 7.0 * k);
  const PatchGroups groups = MakePatchGroups(*model_, scene_.template_mesh.faces);
  const SoftRasterizer rasterizer(SoftRasterizerOptions(), scene_.texture);
  const SftFrame frame = LoadFrame(scene_, 1);
  const int P = model_->num_parameters(), K = model_->num_patches();
  std::vector<int> slot(K);
  for (int p = 0; p < K; ++p) slot[p] = p;
  std::vector<double> moved = theta_;
  for (size_t k = 0; k < moved.size(); ++k) moved[k] += 0.002 * std::sin(1.0 + 3.0 * k);
  struct Result {
    double cost = 0.0, trial_cost = 0.0;
    Eigen::MatrixXd jtj;
    Eigen::VectorXd jtr;
  };
  // The cost alone at `trial`, then the normal equations at `at`.
  const auto evaluate = [&](const RenderCost& cost, Reuse trial_render, Reuse render, const std::vector<double>& trial,
                            const std::vector<double>& at) {
    Result result;
    result.jtj = Eigen::MatrixXd::Zero(P, P);
    EXPECT_TRUE(cost.EvaluateSlottedNormalEquations(trial.data(), groups, slot, false, &result.trial_cost,
                                                    &result.jtj, &result.jtr, trial_render));
    EXPECT_TRUE(cost.EvaluateSlottedNormalEquations(at.data(), groups, slot, true, &result.cost, &result.jtj,
                                                    &result.jtr, render));
    return result;
  };
  const RenderCost fresh_cost(RenderData(rasterizer, frame)), kept_cost(RenderData(rasterizer, frame));
  for (const std::vector<double>* at : {&theta_, &moved}) {
    const Result fresh = evaluate(fresh_cost, Reuse::kNone, Reuse::kNone, theta_, *at);
    const Result kept = evaluate(kept_cost, Reuse::kKeep, Reuse::kReuse, theta_, *at);
    EXPECT_EQ(kept.trial_cost, fresh.trial_cost);
    EXPECT_EQ(kept.cost, fresh.cost);
    EXPECT_EQ((kept.jtj - fresh.jtj).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_EQ((kept.jtr - fresh.jtr).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_GT(fresh.jtr.norm(), 0.0);
  }
  // The two points differ, so the loop's second case did render afresh
  // rather than reuse the trial's render.
  const Result there = evaluate(fresh_cost, Reuse::kNone, Reuse::kNone, moved, moved);
  const Result here = evaluate(fresh_cost, Reuse::kNone, Reuse::kNone, theta_, theta_);
  EXPECT_NE(there.cost, here.cost);
}

TEST_F(AtlasCostsTest, TheRenderTermSplitByPatchGroupsIsTheSameProblem) {
  for (size_t k = 0; k < theta_.size(); ++k) theta_[k] += 0.001 * std::cos(0.3 + 7.0 * k);
  const PatchGroups groups = MakePatchGroups(*model_, scene_.template_mesh.faces);
  // Sorted, none inside another, every patch in one.
  std::vector<int> seen(model_->num_patches(), 0);
  for (const std::vector<int>& g : groups.groups) {
    EXPECT_TRUE(std::is_sorted(g.begin(), g.end()));
    for (int p : g) seen[p] = 1;
    for (const std::vector<int>& h : groups.groups) {
      if (&g != &h) {
        EXPECT_FALSE(std::includes(h.begin(), h.end(), g.begin(), g.end()));
      }
    }
  }
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), model_->num_patches());
  ASSERT_GT(groups.groups.size(), 1u);
  EXPECT_LT(groups.groups.size(), 8u);

  const SoftRasterizer rasterizer(SoftRasterizerOptions(), scene_.texture);
  const SftFrame frame = LoadFrame(scene_, 1);
  const RenderCost whole(RenderData(rasterizer, frame));
  double squared_norm = 0.0;
  Eigen::MatrixXd jtj;
  Eigen::VectorXd jtr;
  ASSERT_TRUE(whole.EvaluateNormalEquations(theta_.data(), &squared_norm, &jtj, &jtr));

  // Before compression, in any slot order, the pattern's upper blocks are
  // the whole system's (every pair of patches here shares a group or has
  // no pixel in common).
  const int b = model_->block_size(), P = model_->num_parameters(), K = model_->num_patches();
  std::vector<int> slot(K);
  for (int p = 0; p < K; ++p) slot[p] = K - 1 - p;
  double sum = 0.0;
  Eigen::MatrixXd slotted = Eigen::MatrixXd::Zero(P, P);
  Eigen::VectorXd slotted_jtr;
  ASSERT_TRUE(whole.EvaluateSlottedNormalEquations(theta_.data(), groups, slot, true, &sum, &slotted, &slotted_jtr));
  EXPECT_NEAR(sum, squared_norm, 1e-12 * squared_norm);
  for (int p = 0; p < K; ++p) {
    EXPECT_LT((slotted_jtr.segment(b * slot[p], b) - jtr.segment(b * p, b)).norm(), 1e-12 * jtr.norm());
    for (int q = 0; q < K; ++q) {
      const Eigen::MatrixXd block = slotted.block(b * slot[p], b * slot[q], b, b);
      if (slot[p] <= slot[q]) {
        EXPECT_LT((block - jtj.block(b * p, b * q, b, b)).norm(), 1e-12 * jtj.norm()) << p << ", " << q;
      } else {
        EXPECT_EQ(block.norm(), 0.0);
      }
    }
  }

  // Compressed, the row blocks give the same cost, gradient and
  // Gauss-Newton matrix as one dense block over every patch does (both to
  // the rounding of factorising a system this ill-conditioned).
  const auto compressed = [&](const PatchGroups& split_groups, double* cost, Eigen::MatrixXd* rtr,
                              Eigen::VectorXd* rtr_r) {
    SplitRenderTerm split(RenderData(rasterizer, frame), split_groups, theta_.data());
    ASSERT_TRUE(split.Prepare(true, true));
    ASSERT_EQ(split.num_row_blocks(), K);
    *cost = 0.0;
    rtr->setZero(P, P);
    rtr_r->setZero(P);
    for (int i = 0; i < K; ++i) {
      const std::vector<int>& patches = split.row_block_patches(i);
      const int k = static_cast<int>(patches.size());
      const int rows = b + (i + 1 == K ? 1 : 0);
      std::vector<double> r(rows);
      std::vector<std::vector<double>> j(k, std::vector<double>(static_cast<size_t>(rows) * b));
      std::vector<double*> jacobians;
      for (auto& block : j) jacobians.push_back(block.data());
      ASSERT_TRUE(split.Write(i, r.data(), jacobians.data()));
      const Eigen::Map<const Eigen::VectorXd> R(r.data(), rows);
      *cost += R.squaredNorm();
      using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
      for (int a = 0; a < k; ++a) {
        const Eigen::Map<const RowMajor> Ja(j[a].data(), rows, b);
        rtr_r->segment(b * patches[a], b) += Ja.transpose() * R;
        for (int c = 0; c < k; ++c) {
          rtr->block(b * patches[a], b * patches[c], b, b) +=
              Ja.transpose() * Eigen::Map<const RowMajor>(j[c].data(), rows, b);
        }
      }
    }
  };
  PatchGroups all;
  all.groups = {{0, 1, 2, 3}};
  NormalSystem split_system, one_system;
  compressed(groups, &split_system.cost, &split_system.jtj, &split_system.jtr);
  compressed(all, &one_system.cost, &one_system.jtj, &one_system.jtr);
  ExpectCompressedAsWell(split_system, one_system, {squared_norm, jtj, jtr});

  // Through Ceres, each frame rendered once by the callback: the same cost.
  SplitRenderTerm split(RenderData(rasterizer, frame), groups, theta_.data());
  RenderTermCallback callback;
  callback.Add(&split);
  const std::unique_ptr<ceres::Problem> problem = NewProblem(&callback);
  AddRowBlocks(split, problem.get());
  double ceres_cost = 0.0;
  std::vector<double> gradient;
  ASSERT_TRUE(problem->Evaluate(ceres::Problem::EvaluateOptions(), &ceres_cost, nullptr, &gradient, nullptr));
  EXPECT_NEAR(2.0 * ceres_cost, squared_norm, 1e-9 * squared_norm);
  EXPECT_LT((Eigen::Map<const Eigen::VectorXd>(gradient.data(), P) - jtr).norm(), 1e-2 * jtr.norm());
}

// Regularisers attached to the render term (their normal equations joined
// before the factorisation) give Ceres the same cost, gradient and
// Gauss-Newton matrix as the same terms as residual blocks of their own.
TEST_F(AtlasCostsTest, AttachedTermsAreTheSameProblemAsTheirOwnBlocks) {
  for (size_t k = 0; k < theta_.size(); ++k) theta_[k] += 0.002 * std::cos(0.7 + 5.0 * k);
  Eigen::Matrix2Xi unique = UniqueEdges(scene_.template_mesh);
  std::vector<Eigen::Vector2i> edges;
  std::vector<double> lengths;
  for (Eigen::Index e = 0; e < unique.cols(); ++e) {
    edges.emplace_back(unique(0, e), unique(1, e));
    lengths.push_back(0.9 * (scene_.template_mesh.vertices.col(unique(0, e)) -
                             scene_.template_mesh.vertices.col(unique(1, e))).norm());
  }
  const AtlasTerms terms = GroupAtlasTerms(*model_, edges, lengths);
  ASSERT_GE(terms.seams.size(), 3u);
  const PatchGroups groups = MakePatchGroups(*model_, scene_.template_mesh.faces);
  const SoftRasterizer rasterizer(SoftRasterizerOptions(), scene_.texture);
  const SftFrame frame = LoadFrame(scene_, 1);
  const int b = model_->block_size(), P = model_->num_parameters();
  // The regularisers: every edge group's inextensibility, every seam.
  const auto regularisers = [&](const std::function<void(ceres::CostFunction*, const std::vector<int>&)>& add) {
    for (const AtlasTerms::EdgeGroup& g : terms.edge_groups) {
      add(new InextensibilityCost(model_.get(), g.patches, g.edges, g.rest_lengths, 0.3), g.patches);
    }
    for (const AtlasTerms::Seam& seam : terms.seams) {
      add(CreateSeamCost(model_.get(), seam.a, seam.b, seam.edges, 0.01, 0.5, 0.2), {seam.a, seam.b});
    }
  };
  const auto evaluate = [&](bool attach, double* cost, Eigen::VectorXd* gradient, Eigen::MatrixXd* jtj) {
    SplitRenderTerm split(RenderData(rasterizer, frame), groups, theta_.data());
    RenderTermCallback callback;
    callback.Add(&split);
    const std::unique_ptr<ceres::Problem> problem = NewProblem(&callback);
    regularisers([&](ceres::CostFunction* term, const std::vector<int>& patches) {
      if (attach) {
        split.Attach(term, patches);
        return;
      }
      std::vector<double*> blocks;
      for (const int p : patches) blocks.push_back(theta_.data() + b * p);
      problem->AddResidualBlock(term, nullptr, blocks);
    });
    AddRowBlocks(split, problem.get());
    std::vector<double> g;
    ceres::CRSMatrix crs;
    ASSERT_TRUE(problem->Evaluate(ceres::Problem::EvaluateOptions(), cost, nullptr, &g, &crs));
    *gradient = Eigen::Map<const Eigen::VectorXd>(g.data(), P);
    Eigen::MatrixXd j = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
    for (int r = 0; r < crs.num_rows; ++r) {
      for (int e = crs.rows[r]; e < crs.rows[r + 1]; ++e) j(r, crs.cols[e]) = crs.values[e];
    }
    *jtj = j.transpose() * j;
  };
  // The exact system: the whole render term's and each regulariser's.
  const RenderCost whole(RenderData(rasterizer, frame));
  double exact_cost = 0.0;
  Eigen::MatrixXd exact_jtj;
  Eigen::VectorXd exact_gradient;
  ASSERT_TRUE(whole.EvaluateNormalEquations(theta_.data(), &exact_cost, &exact_jtj, &exact_gradient));
  regularisers([&](ceres::CostFunction* term, const std::vector<int>& patches) {
    std::unique_ptr<ceres::CostFunction> owned(term);
    const int m = term->num_residuals(), k = static_cast<int>(patches.size());
    std::vector<const double*> parameters;
    for (const int p : patches) parameters.push_back(theta_.data() + b * p);
    Eigen::VectorXd r(m);
    std::vector<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> j(k);
    std::vector<double*> jacobians;
    for (auto& block : j) {
      block.resize(m, b);
      jacobians.push_back(block.data());
    }
    ASSERT_TRUE(term->Evaluate(parameters.data(), r.data(), jacobians.data()));
    exact_cost += r.squaredNorm();
    for (int i = 0; i < k; ++i) {
      exact_gradient.segment(b * patches[i], b) += j[i].transpose() * r;
      for (int c = 0; c < k; ++c) exact_jtj.block(b * patches[i], b * patches[c], b, b) += j[i].transpose() * j[c];
    }
  });
  exact_cost *= 0.5;
  // Both to the rounding of factorising the render term's system, no
  // worse attached.
  NormalSystem attached, own;
  evaluate(true, &attached.cost, &attached.jtr, &attached.jtj);
  evaluate(false, &own.cost, &own.jtr, &own.jtj);
  ExpectCompressedAsWell(attached, own, {exact_cost, exact_jtj, exact_gradient});
}

TEST_F(AtlasCostsTest, SeamsAreContinuousWhenChildrenStartAndNotOnceTheyDiffer) {
  const AtlasTerms terms = GroupAtlasTerms(*model_, {{0, 1}}, {1.0});
  EXPECT_EQ(terms.edge_groups.size(), 1u);
  Eigen::Matrix2Xi unique = UniqueEdges(scene_.template_mesh);
  std::vector<Eigen::Vector2i> edges;
  std::vector<double> lengths;
  for (Eigen::Index e = 0; e < unique.cols(); ++e) {
    edges.emplace_back(unique(0, e), unique(1, e));
    lengths.push_back(1.0);
  }
  const AtlasTerms all = GroupAtlasTerms(*model_, edges, lengths);
  size_t grouped = 0;
  for (const auto& g : all.edge_groups) grouped += g.edges.size();
  EXPECT_EQ(grouped, edges.size());
  ASSERT_GE(all.seams.size(), 3u);  // four quarters: at least three seams
  const int b = model_->block_size();
  for (const AtlasTerms::Seam& s : all.seams) {
    std::unique_ptr<ceres::CostFunction> seam(CreateSeamCost(model_.get(), s.a, s.b, s.edges, 0.01, 1.0, 1.0));
    std::vector<double> blocks(theta_.begin() + b * s.a, theta_.begin() + b * (s.a + 1));
    blocks.insert(blocks.end(), theta_.begin() + b * s.b, theta_.begin() + b * (s.b + 1));
    const double* parameters[2] = {blocks.data(), blocks.data() + b};
    std::vector<double> r(seam->num_residuals());
    ASSERT_TRUE(seam->Evaluate(parameters, r.data(), nullptr));
    EXPECT_LT(Eigen::Map<Eigen::VectorXd>(r.data(), r.size()).cwiseAbs().maxCoeff(), 1e-10);
    blocks[b + 2] += 0.05;  // a jet coefficient of the second patch
    ASSERT_TRUE(seam->Evaluate(parameters, r.data(), nullptr));
    EXPECT_GT(Eigen::Map<Eigen::VectorXd>(r.data(), r.size()).cwiseAbs().maxCoeff(), 1e-4);
  }
}

// The seam by automatic differentiation of the model's definition.
struct SeamDefinition {
  template <typename T>
  bool operator()(T const* const* parameters, T* residuals) const {
    for (size_t e = 0; e < edges.size(); ++e) {
      T xa[3], na[3], xb[3], nb[3];
      model->EdgeMidpointOnPatch(edges[e][0], edges[e][1], a, parameters[0], xa, na);
      model->EdgeMidpointOnPatch(edges[e][0], edges[e][1], b, parameters[1], xb, nb);
      PatchBoundaryResidual::Difference(xa, na, xb, nb, 100.0, 0.5, residuals + 6 * e);
    }
    return true;
  }
  const JetDeformationModel* model;
  int a, b;
  std::vector<Eigen::Vector2i> edges;
};

// The seam's Jacobian chained by hand (EdgeMidpointJacobian) is the one
// automatic differentiation gives of the model's definition, with the uv
// field and every jet coefficient away from zero.
TEST_F(AtlasCostsTest, TheSeamsJacobianIsTheDefinitionsDerivative) {
  for (size_t k = 0; k < theta_.size(); ++k) theta_[k] += 0.02 * std::cos(0.3 + 7.0 * k);
  Eigen::Matrix2Xi unique = UniqueEdges(scene_.template_mesh);
  std::vector<Eigen::Vector2i> edges;
  for (Eigen::Index e = 0; e < unique.cols(); ++e) edges.emplace_back(unique(0, e), unique(1, e));
  const AtlasTerms terms = GroupAtlasTerms(*model_, edges, std::vector<double>(edges.size(), 1.0));
  ASSERT_FALSE(terms.seams.empty());
  const AtlasTerms::Seam& s = terms.seams[0];
  const int b = model_->block_size();
  ceres::DynamicAutoDiffCostFunction<SeamDefinition, 8> definition(new SeamDefinition{model_.get(), s.a, s.b, s.edges});
  definition.AddParameterBlock(b);
  definition.AddParameterBlock(b);
  definition.SetNumResiduals(6 * static_cast<int>(s.edges.size()));
  std::unique_ptr<ceres::CostFunction> seam(CreateSeamCost(model_.get(), s.a, s.b, s.edges, 0.01, 1.0, 0.5));
  ASSERT_EQ(seam->num_residuals(), definition.num_residuals());
  const int m = seam->num_residuals();
  const double* parameters[2] = {theta_.data() + b * s.a, theta_.data() + b * s.b};
  std::vector<double> r(m), r_ref(m), j0(m * b), j1(m * b), k0(m * b), k1(m * b);
  double* jacobians[2] = {j0.data(), j1.data()};
  double* reference[2] = {k0.data(), k1.data()};
  ASSERT_TRUE(seam->Evaluate(parameters, r.data(), jacobians));
  ASSERT_TRUE(definition.Evaluate(parameters, r_ref.data(), reference));
  const auto map = [](const std::vector<double>& v) { return Eigen::Map<const Eigen::VectorXd>(v.data(), v.size()); };
  EXPECT_GT(map(r_ref).norm(), 1e-3);
  EXPECT_LT((map(r) - map(r_ref)).norm(), 1e-12 * map(r_ref).norm());
  EXPECT_LT((map(j0) - map(k0)).norm(), 1e-12 * map(k0).norm());
  EXPECT_LT((map(j1) - map(k1)).norm(), 1e-12 * map(k1).norm());
}

// A flat grid split down the middle into two patches: the right one
// turned about the line through the middles of the edges across (a fold
// on the seam) costs nothing; moved off it by 0.3 of an edge, each edge
// across costs 0.3 w.
TEST(SeamCostTest, AFoldAlongTheSeamIsFreeAndAGapCostsItsLength) {
  const int nx = 9, ny = 6;
  const double h = 0.02;
  Eigen::Matrix3Xd vertices(3, nx * ny);
  std::vector<int> child(nx * ny);
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      vertices.col(j * nx + i) = Eigen::Vector3d(h * i, h * j, 0.5);
      child[j * nx + i] = i <= 4 ? 0 : 1;
    }
  }
  std::vector<Eigen::Vector2i> edges;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const int v = j * nx + i;
      if (i + 1 < nx) edges.emplace_back(v, v + 1);
      if (j + 1 < ny) edges.emplace_back(v, v + nx);
      if (i + 1 < nx && j + 1 < ny) edges.emplace_back(v, v + nx + 1);
    }
  }
  JetDeformationModel model(JetDeformationOptions(), vertices);
  const PatchSplit split = model.SplitPatch(0, child);
  ASSERT_EQ(model.num_patches(), 2);
  const AtlasTerms terms = GroupAtlasTerms(model, edges, std::vector<double>(edges.size(), h));
  ASSERT_EQ(terms.seams.size(), 1u);
  ASSERT_EQ(terms.seams[0].edges.size(), 2u * ny - 1);  // across and diagonal
  const int b = model.block_size();
  std::vector<double> theta = model.InheritParameters(split, std::vector<double>(b, 0.0));
  const int turned = model.patch_of_vertex(nx - 1);

  // The hinge: the world line x = 4.5 h, z = 0.5, in the frame's coordinates.
  const PatchFrame& frame = model.patch().frame;
  const Eigen::Vector3d hinge = frame.rotation.transpose() * (Eigen::Vector3d(4.5 * h, 0.0, 0.5) - frame.translation) /
                                frame.scale;
  const Eigen::Vector3d axis = frame.rotation.transpose() * Eigen::Vector3d::UnitY();
  const Eigen::Vector3d omega = 0.7 * axis;  // 40 degrees
  Eigen::Matrix3d rotation;
  ceres::AngleAxisToRotationMatrix(omega.data(), rotation.data());
  double* block = theta.data() + b * turned;
  Eigen::Map<Eigen::Vector3d>(block + model.rotation_offset()) = omega;
  Eigen::Map<Eigen::Vector3d>(block + model.translation_offset()) =
      (Eigen::Matrix3d::Identity() - rotation) * (hinge - model.centre(turned));

  const double w = 2.0;
  std::unique_ptr<ceres::CostFunction> seam(CreateSeamCost(&model, 0, 1, terms.seams[0].edges, h, w, 0.0));
  std::vector<double> r(seam->num_residuals());
  auto evaluate = [&] {
    const double* parameters[2] = {theta.data(), theta.data() + b};
    ASSERT_TRUE(seam->Evaluate(parameters, r.data(), nullptr));
  };
  evaluate();
  EXPECT_LT(Eigen::Map<Eigen::VectorXd>(r.data(), r.size()).cwiseAbs().maxCoeff(), 1e-12);
  // The fold is really there: the right patch's far column is off the plane.
  Eigen::Matrix3Xd folded;
  model.Evaluate(theta.data(), &folded);
  EXPECT_GT(std::abs(folded(2, nx - 1) - 0.5), 2.0 * h);

  // A gap of 0.3 h along the world z axis.
  Eigen::Map<Eigen::Vector3d>(block + model.translation_offset()) +=
      frame.rotation.transpose() * Eigen::Vector3d(0.0, 0.0, 0.3 * h) / frame.scale;
  evaluate();
  for (size_t e = 0; e < terms.seams[0].edges.size(); ++e) {
    EXPECT_NEAR(Eigen::Map<Eigen::Vector3d>(r.data() + 6 * e).norm(), 0.3 * w, 1e-9);
  }
}

}  // namespace
}  // namespace polyfit
