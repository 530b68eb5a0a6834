// PolySfT's patch atlas: where the template's single patch (the paper's
// model) is split, and the terms that tie the patches together.
//
// A sequence starts with one patch. After a frame is solved, each patch's
// image residual per pixel (RenderCost::VertexResiduals, summed over its
// vertices) is compared with the same patch's on the first frame, where the
// template is registered and the residual is the scene's floor (noise,
// blur, texture the renderer does not reproduce). The patch that fits
// worst against that floor (at least split_ratio times) is split in
// `children` by ACVD on its faces, each child inheriting its parent's
// parameters (JetDeformationModel::InheritParameters), if the split passes
// a score test: one Gauss-Newton step on the frame would lower its cost by
// split_significance times what the children's extra parameters would gain
// from noise alone and moving the patch visibly (split_min_step_pixels).
// Lost or unsettled frames are not split (polysft.cc). The window is then
// solved again.
//
// On by default (up to 16 patches), as measured (docs/benchmarks.md,
// "PolySfT: the atlas by default"): it holds creases and wave packets that
// one patch cannot (RMSE 7.6 -> 2.2 mm, 7.1 -> 3.1 mm) and is as good or
// better on every other generated scene, at 1.3-2.5 times one patch's time
// where it splits.
#ifndef POLYFIT_SFT_SOLVER_PATCH_ATLAS_H_
#define POLYFIT_SFT_SOLVER_PATCH_ATLAS_H_

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "polyfit/mesh/hinge_rest.h"
#include "polyfit/mesh/triangle_mesh.h"
#include "sft/model/jet_deformation.h"

namespace polyfit {

struct PatchAtlasOptions {
  // 1: the paper's single patch, never split.
  int max_patches = 16;
  // Patches at frame 0 (ACVD cells of the template), before any split;
  // at most max_patches, and min_vertices a cell on average.
  int initial_patches = 1;
  // A patch is a candidate when its residual per pixel exceeds this many
  // times its first-frame floor; the worst candidate splits when one
  // Gauss-Newton step with the split would lower the frame's cost by
  // split_significance times what its extra parameters would gain from
  // noise alone (the score test).
  double split_ratio = 1.1;
  double split_significance = 10.0;
  // ... and when that step moves some vertex of the patch by at least this
  // many pixels of the finest level: a step that moves nothing visibly
  // refines what one jet already holds (a smooth bend's residual has a
  // significant score too, its step a tenth of a pixel).
  double split_min_step_pixels = 0.2;
  int children = 4;
  // A patch splits only when each child would have this many vertices.
  int min_vertices = 20;
  // A patch too small for `children` such children splits into as many as
  // it holds, down to min_children (0: `children`, never fewer).
  int min_children = 0;
  // A patch that a nearer part of the surface turned over hides in part
  // (at least this share of its vertices hidden, and this share seen, in
  // the newest frame's estimate; hidden vertices count where they face
  // the camera as in the template and what hides them faces the other way:
  // a layer under a flap folded onto it, not a drape's far side or what a
  // wave's crest hides) splits into its hidden and its seen vertices, the
  // most even one after each frame: where a patch's jet holds both, the
  // parts in view carry the hidden ones off with them (a folded table's
  // hidden layer, centimetres behind the table). 0: never. The hidden
  // child has no image to go by: PolySftOptions::occluded_velocity is what
  // carries it (held still, a child under a fold that rolls on is left
  // behind: a simulated table lost). At 0.2, with occluded_velocity 0.5
  // and its own room (below), 12 of 13 simulated tables end at e3D
  // 0.0067-0.0115 instead of 0.014-0.018 (table 1 found instead of
  // half-lost; table 8 0.0163 -> 0.0209, its last frames lost either way),
  // table 3 at 0.84 s a frame on two threads against 0.53; the falls,
  // flags and hanging cloths barely split (e_n within 0.5 degrees but flag
  // 6, which tips); a sheet turning edge-on, lost in its edge-on frames
  // either way, is further off there (RMSE 7.9 -> 8.5 mm, e3D 0.0043 ->
  // 0.0036): docs/benchmarks.md, "the hidden layer a patch of its own, by
  // default".
  double hidden_split_share = 0.2;
  // The hidden splits' own room: the patches they add count against this,
  // not against max_patches, so that the residual's splits keep theirs
  // and a scene that never folds over pays nothing. Shared with
  // max_patches (32 in all), the tables' hidden splits took twice the
  // time: the residual's splits filled the room, and the seen patches'
  // system is what costs.
  int max_hidden_patches = 16;
  // A hidden child holds at least this many vertices: as a fold's front
  // advances over a patch, each frame hides a few more of it, and children
  // of 3-4 vertices, a slice a frame, used the room up by the tables'
  // frame 26-31, before the layer the folded flap hides in the last
  // frames. 10 against 3: the 13 simulated tables' mean e3D 0.0109 ->
  // 0.0097, their frames 35-44 0.0277 -> 0.0211; 20 splits too late (one
  // table lost; docs/benchmarks.md, "the hidden layer a patch of its own,
  // by default").
  int min_hidden_vertices = 10;
  // Seam continuity (SeamCost): positions (in template edge lengths) and
  // normals. Normals are left free by default: a crease on a seam is a
  // real shape, and only the images should decide it.
  double seam_position_weight = 1.0;
  // The same on the pyramid's coarse levels, which place a frame's large
  // motion: stiffer there, so that the patches move together where the
  // images are too coarse to tell them apart.
  double coarse_seam_position_weight = 10.0;
  // The positions' weight, on every level, on a seam between two patches
  // the frame sees whole (with masks, every vertex but 5% inside the
  // image): there the silhouette and the texture hold each patch, and the
  // stiffer seams held a simulated cloth's true folds back (from the
  // truth, the table's e3D 0.012 against 0.0055) and its patches' large
  // motion (docs/benchmarks.md, "Looser seams"). Where a patch is out of
  // view or has no silhouette, the seams above carry it (loose there, a
  // sheet leaving the image drifted 3.3 -> 18 mm, a flag without masks
  // 0.025 -> 0.057).
  double seen_seam_position_weight = 0.1;
  double seam_normal_weight = 0.0;
  // Neighbouring patches' uv fields alike (SharedUvCost), per seam: small
  // patches that each slide on their own lose a smooth bend that one patch
  // holds (docs/benchmarks.md); tied, they share how the surface slides.
  double seam_uv_weight = 10.0;
  // The same on the pyramid's coarse levels, and at most this on a seam
  // whose two patches the frame shows textured (in the image, at most a
  // tenth hidden, turned to the camera: a flap edge-on or turned over
  // keeps the tie). Scene-dependent, so the defaults keep the tie
  // everywhere (docs/benchmarks.md, "the seams' shared uv fields,
  // measured", "the uv tie on every tracked scene"): 0 there, the hanging
  // cloths gain 1.3 and 0.7 degrees of e_n and the tables hold, but twenty
  // flags lose 1.1 on average and a frame costs half as much again; free
  // on either level alone, tables are lost.
  double coarse_seam_uv_weight = 10.0;
  double seen_seam_uv_weight = 10.0;
  // The tie's pseudo-Huber scale b on the fields' difference d (their
  // coefficients, in the template frame's (u, v), whose extent is 1):
  // w^2 |d|^2 below b, 2 w^2 b |d| above (SharedUvCost). Two fields stay
  // one while what pulls them apart is weaker than w^2 b, so that a
  // drifting flap keeps sliding with its neighbours, and a seam across
  // which the images ask them to differ (a fold inside a patch, which
  // squared spread its stretch over the cloth) is let go. 0: squared.
  // At 1e-4, against squared, tracked (docs/benchmarks.md, "the seams'
  // uv tie robust"): thirteen tables' e_n -0.75 deg (12 better, none
  // lost), twenty flags -0.33, falls -0.67, hanging -0.85; 3e-4 loses a
  // table.
  double seam_uv_robust = 1e-4;
  // The same on a seam whose two patches the frame shows textured (as
  // seen_seam_uv_weight says): there each field is held by its own
  // texture, so the tie lets go sooner; a flap edge-on or turned over,
  // which the images do not hold, keeps seam_uv_robust (3e-5 everywhere
  // lost two tables). 3e-5 against 1e-4, tracked: twenty flags' e_n
  // -0.52 deg (11 better), the tables, falls, hanging cloths and sheets
  // within 0.1 (docs/benchmarks.md, "a crease turned inside out").
  double seen_seam_uv_robust = 3e-5;

  std::string Validate() const;
  // The children a patch of `vertices` vertices splits into (0: none).
  int ChildrenFor(int vertices) const;
  // The fewest children a split makes.
  int FewestChildren() const { return min_children > 0 ? min_children : children; }
};

// The edges and seams of the current atlas, grouped by the patches they
// join.
struct AtlasTerms {
  struct EdgeGroup {
    std::vector<int> patches;  // one, or two sorted
    std::vector<Eigen::Vector2i> edges;
    std::vector<double> rest_lengths;
  };
  struct Seam {
    int a = 0, b = 0;                    // a < b
    std::vector<Eigen::Vector2i> edges;  // the template's edges from one patch to the other
  };
  struct HingeGroup {
    std::vector<int> patches;  // one to four, sorted
    std::vector<std::array<int, 4>> hinges;
    std::vector<double> rest_angles;
    std::vector<double> weights;  // HingeRest's
  };
  std::vector<EdgeGroup> edge_groups;
  std::vector<Seam> seams;
  std::vector<HingeGroup> hinge_groups;  // with `hinges` only
};

// Edges, and hinges where given, grouped by the patches of their vertices.
AtlasTerms GroupAtlasTerms(const JetDeformationModel& model, const std::vector<Eigen::Vector2i>& edges,
                           const std::vector<double>& rest_lengths, const HingeRest* hinges = nullptr);

// #V entries: for the vertices of `patch`, which of up to `children` ACVD
// cells of its faces takes them; empty when it does not split into
// non-empty children.
std::vector<int> SplitPatchVertices(const TriangleMesh& mesh, const std::vector<int>& vertex_patch, int patch,
                                    int children);

// The patches to split, worst first, within max_patches: each patch's
// residual per pixel (sums over its vertices of squared / pixels, #V each)
// against its first-frame floor (the same sums then). Patches seen in
// fewer than a quarter of their first-frame pixels are left alone.
std::vector<int> PatchesToSplit(const PatchAtlasOptions& options, const JetDeformationModel& model,
                                const Eigen::VectorXd& squared, const Eigen::VectorXd& pixels,
                                const Eigen::VectorXd& floor_squared, const Eigen::VectorXd& floor_pixels,
                                std::vector<double>* ratios = nullptr);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SOLVER_PATCH_ATLAS_H_
