// PolySfT: shape from template over a video. Each frame's surface is the
// template's patch deformed by JetDeformationModel parameters; frames are
// solved in a sliding window by Levenberg-Marquardt (Ceres), coarse to fine
// over an image pyramid, warm-started from the previous frame. Terms, each
// built only when the scene supports it:
//   photometric   the soft rasterizer's colour against the frame (RGB)
//   silhouette    its silhouette against the mask (scenes with masks)
//   inextensibility  edge lengths kept (cost_functions/edge_inextensibility.h)
//   temporal      consecutive frames close (temporal_consistency.h; only with
//                 more than one frame)
#ifndef POLYFIT_SFT_SOLVER_POLYSFT_H_
#define POLYFIT_SFT_SOLVER_POLYSFT_H_

#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "polyfit/util/status.h"
#include "sft/model/jet_deformation.h"
#include "sft/render/soft_rasterizer.h"
#include "sft/scene/scene.h"
#include "sft/solver/patch_atlas.h"
#include "sft/solver/robust_loss.h"
#include "sft/solver/texture_features.h"

namespace polyfit {

// PolySftOptions::ground_truth_start.
enum class GroundTruthStart { kNone, kThisFrame, kFrameBefore };

struct PolySftOptions {
  JetDeformationOptions deformation;
  // The template starts as one patch and splits where one jet cannot
  // hold the frames (sft/solver/patch_atlas.h); max_patches 1: never.
  PatchAtlasOptions atlas;
  // sigma is in pixels squared at every pyramid level. Without the depth
  // gradient (SoftRasterizerOptions::depth_gradient) by default: with a
  // z-buffer hard enough to hide a fold's far layer (1 cm), its pull on
  // depth drove the hanging cloth 5.6 -> 36.8 mm off (docs/benchmarks.md).
  //
  // Mip-mapped on the coarse levels (finest_mipmap: the finest): the
  // texture given each pyramid level is prefiltered to about one texel
  // per pixel where the template is nearest, and a far or grazing part
  // read from it aliases, which misleads the coarse levels' search for
  // the frame's motion (docs/benchmarks.md).
  //
  // Composited in depth order over what lies behind the surface
  // (Compositing::kOverBackground; finest_compositing: the finest level):
  // a fold-over's near layer hides the far one, where the soft z-buffer
  // (3 cm) blended layers 1 cm apart at 0.72 of the front one's weight;
  // and a rim pixel reads its coverage's share of the surface over a
  // background plate (the frame with the mask's region filled from
  // around it: sft/render/background_plate.h), as the camera saw it,
  // where over the observed frame itself its residual was not zero at the
  // exact surface. Without masks nothing says what lies behind, and the
  // composite is kOver (the surface's colour wherever it reaches).
  // Together with relax_mask_border: docs/benchmarks.md.
  SoftRasterizerOptions rasterizer = [] {
    SoftRasterizerOptions o;
    o.depth_gradient = false;
    o.mipmap = true;
    o.compositing = Compositing::kOverBackground;
    return o;
  }();
  // With Compositing::kSoftZ only (the depth-ordered composites have no
  // softness): the soft z-buffer's softness in metres at the template's
  // mean depth Z: the rasterizer's gamma becomes depth_softness / (Z^2 (1/near -
  // 1/far)), so that a layer this far behind another weighs e times less,
  // whatever the scene's scale and the depth range the normalised inverse
  // depth spans (the template's depth +- its size, its near end clamped
  // at 1 mm: gamma 0.01 was 42 mm for a sheet 0.4 m away and 1.6 m, no
  // z-buffer at all, for a cloth 0.39 m across). 0: rasterizer.gamma as
  // given. At 3 cm (without the depth gradient) every simulated cloth and
  // sheet scene but the hanging cloth (+0.2 mm) has a lower RMSE than
  // with gamma 0.01; at 1-2 cm a sheet turning edge-on, or leaving the
  // image, was lost (polysft_stress_test; docs/benchmarks.md).
  double depth_softness = 0.03;
  // The coverage sigmoid's width at the finest pyramid level (pixels
  // squared; 0: rasterizer.sigma there too). Coarser levels keep
  // rasterizer.sigma (0.5), whose soft edges widen the basin a frame's
  // motion must fall in. But a soft silhouette reads larger than its mesh
  // (beyond a rim vertex several triangles' halos unite; +1.7% of a 40 px
  // sheet's area at 0.5, +0.14% at 0.06: soft_rasterizer_test), and the
  // silhouette term then holds the surface too far from the camera; a
  // camera's box-filtered pixel ramps over one pixel, where sigmoid(d^2 /
  // 0.09) reaches 0.94 half a pixel in. 0.09 against 0.5 on every
  // generated scene: RMSE lower on all nine that are tracked (the wave
  // packet 3.14 -> 2.70 mm, the rigid sheet 1.09 -> 0.46) and on the HD
  // sheet solved at 640 px (0.33 -> 0.29 mm; docs/benchmarks.md).
  double finest_sigma = 0.09;
  // Whether the finest level's texture is mip-mapped too. Off: there the
  // solve is after precision, and mip levels blur a sheet seen at about
  // one texel per pixel (without masks the crease 2.26 -> 2.61 mm, the
  // wave packet 3.53 -> 4.37); on the coarse levels alone they kept most
  // of the cloth's gain (docs/benchmarks.md).
  bool finest_mipmap = false;
  // The finest level's compositing (rasterizer.compositing: the coarse
  // levels').
  Compositing finest_compositing = Compositing::kOverBackground;
  // Frames solved together; the oldest leaves the window (and is written)
  // when a new one enters. Two cost a quarter to a third less than three
  // at the same error on the sheets (within 0.06 mm) and 0.7-3.5 mm more
  // on the simulated cloth scenes that are lost anyway; one loses the
  // crease (docs/benchmarks.md).
  int window_size = 2;
  // The pyramid's coarse levels solve only the window's newest frame (the
  // others, solved at every level before, held), the finest all of them:
  // 5-38% less CPU time on every generated scene at the same error (the
  // flag, lost either way, 2 mm worse; docs/benchmarks.md).
  bool coarse_levels_newest_only = true;
  // Before each finer level, the frames that the coarser levels moved go
  // back to where the window's solve began wherever that costs the finer
  // level less (its image terms and regularisers, as its solve would
  // start): the coarse levels are to bring a far start into the basin, not
  // to take a near one out of it. Blurred, they settle millimetres off a
  // surface whose truth the finer levels prefer, and those stay in the
  // basin they are handed: the table's cloth started from its truth every
  // frame, mean e3D 0.0133 -> 0.0122 (its lifting corner's frames 12-14
  // 0.0022-0.0092 -> 0.0015-0.0032, polysft_test). Tracked, a lower cost
  // at a level's start is no better basin: on one thread the flags 0.0165
  // -> 0.0153 and the tables 0.0162 -> 0.0167, on two the flags 0.0165 ->
  // 0.0166 and a table lost (0.0158 -> 0.0718), up to 7% more time
  // (docs/benchmarks.md). Off by default. Two renders of the moved frames
  // and their regularisers per finer level; metrics.json counts the checks.
  bool check_coarse_levels = false;
  // Levels of the image pyramid, coarsest first (3: 1/4, 1/2, full size).
  // 0: as many as bring the coarsest level to at most 128 px wide, and at
  // least 3 (3 at 320 px, 4 at 640, 5 at 1920): a frame's motion must fall
  // within the coarsest level's reach, and it is as many pixels there at
  // any resolution only if that level's width is.
  int pyramid_levels = 0;
  // Solve at most at this image width (0: full size): the finest level is
  // scaled down to it, the others halve from there. For HD video.
  int max_image_width = 0;
  // The adaptive window, in solver iterations: each level stops after
  // max_iterations_per_level, or once `patience` iterations in a row lowered
  // the cost by less than improvement_tolerance (relative).
  int max_iterations_per_level = 6;
  // The finest level of a newest frame that fits as well as the tracked
  // ones (its cost within 4 times theirs, beyond which a frame is lost)
  // when it reaches max_iterations_per_level goes on, up to this many
  // iterations in all; a frame that fits far worse stops there. On
  // tracked frames the cap of 6 stopped the finest level short of what
  // the images say: the 13 simulated tables' mean e3D 0.0097 -> 0.0083,
  // the worst 0.0209 -> 0.0100, at the same time a frame; the flags,
  // falls, hanging cloths and sheets within 0.0014 (their lost frames
  // stop at 6 as before). Every level at 12 loses a sheet leaving the
  // image and coming back (RMSE 18 -> 28 mm), every frame's finest at 12
  // the one turning edge-on further in depth (8.5 -> 13.7 mm); with this
  // rule the latter is 17.5 mm off in depth in the frames it is lost in
  // either way, its shape as near (e3D 0.0036 -> 0.0037; docs/
  // benchmarks.md). 0 (or at most max_iterations_per_level): off.
  int tracked_finest_iterations = 12;
  int patience = 1;
  double improvement_tolerance = 1e-2;
  // How an atlas's Levenberg-Marquardt steps are solved (one patch: dense
  // QR). Below iterative_min_patches patches, by sparse Cholesky on the
  // normal equations (Ceres' SPARSE_NORMAL_CHOLESKY); from it on, by
  // conjugate gradients on them (CGNR, block Jacobi by patch), each step
  // until its residual is iterative_eta times its start. Factorising
  // grows about as the cube of the patches (the fill of their graph),
  // CG's products as their number; CG's inexact steps cost more of them
  // on a few patches. 16 (the default atlas's cap): on two threads the
  // flags 0.89-1.22 -> 0.74-0.91 s a frame, the falls 10-20% less, the
  // hanging cloth 10-20% more (docs/benchmarks.md, "conjugate gradients").
  int iterative_min_patches = 16;
  double iterative_eta = 1e-2;
  // Term weights (relative; each term is normalised by its size).
  double photometric_weight = 1.0;
  double silhouette_weight = 1.0;
  double inextensibility_weight = 10.0;  // k_mi
  // The inextensibility term robust above this strain (pseudo-Huber,
  // EdgeInextensibilityResidual): quadratic in an edge's strain well below
  // it, linear well above. A fold that runs inside a patch leaves some
  // stretch its jet cannot remove, and squared, the term spread it over
  // the whole cloth and moved it off the truth (a flag solved from each
  // frame's truth: regularisers 0.14 there against 0.04 where the solve
  // went, the image the other way); robust, it stays at the fold. 0.1
  // against squared: the 13 simulated tables' mean e_n 4.50 -> 4.10
  // degrees (ten better, two worse), twenty flags 12.25 -> 11.69, the falls,
  // hanging cloths and sheets within their spread; 0.03 lost two tables
  // (docs/benchmarks.md). 0: squared, the paper's.
  double inextensibility_robust_strain = 0.1;
  double temporal_weight = 0.1;  // k_tc
  // Bending (HingeBendingResidual at every interior edge of the template,
  // the discrete-shell weights 3 |e|^2 / (A_1 + A_2)): the cost is this
  // weight / 2 times the integral of the squared mean curvature (times 4)
  // away from the template's rest shape, per frame. 0: off.
  double bending_weight = 0.0;
  // A solve can mirror part of the surface in depth about a hinge, which
  // projects nearly alike: the flag's corner folded back away from the
  // camera at one row of edges where the truth bends on toward it, at
  // twice the cost the truth's basin reaches (docs/benchmarks.md). A
  // frame whose solve changed some hinge's dihedral angle by more than
  // new_crease_angle_deg since the frame before is solved again from its
  // start under a bending prior of new_crease_bending_weight, then
  // without it from there, and the lower final cost kept (a warning, and
  // trace.csv's recovery 3). 0: off. The trigger lower tries more
  // frames and finds more of the flags' folds, at more time: 60 -> 55,
  // the nine flags' mean e_n 11.31 -> 10.99 degrees, the tables, falls,
  // hanging cloths and sheets within 0.2 (sheets the same); 50 gains
  // 10.48 and 45 10.59, but took flag 1 or three flags to 1.0-1.1 s a
  // frame on two threads (docs/benchmarks.md).
  double new_crease_bending_weight = 1e-4;
  double new_crease_angle_deg = 55.0;
  // And, on the same trigger, the crease folded the other way: the flap
  // beyond the hinges that turned by more than half new_crease_angle_deg
  // mirrored about the sheet beside them (MirrorFoldFlap), the frame fitted
  // to it and solved again, the lower final cost kept (trace.csv's
  // recovery 4).
  bool mirror_new_creases = true;
  // And with it, where the crease cuts no flap off (a ridge that dies
  // out inside the sheet: most of the flags' new creases), the crease
  // turned inside out instead: its band of faces slid along the camera's
  // rays to the other side of the sheet beside it (FlipCreaseAlongRays),
  // so that the frame looks the same, fitted to that and solved again,
  // the lower final cost kept (trace.csv's recovery 6). Tried on most of
  // a flag's new creases (the flap mirror on one in eight) and kept on half:
  // twenty flags' e_n -0.31 deg (12 better), the other scenes the same;
  // flag 10 0.53 -> 0.81 s a frame on two threads (docs/benchmarks.md).
  bool flip_new_crease_bands = true;
  // And, on the same trigger, where the frame's start was moved on from
  // where the frame before ended (the constant-velocity prediction, the
  // flow's or the keypoints' fit), the frame solved again from where the
  // frame before ended, the lower final cost kept (trace.csv's recovery
  // 5): a flap whose motion turns between frames is carried by the
  // prediction past the hinge angle it turns back from, into the basin
  // that folds it the other way. On the nine simulated flags, mean e_n
  // 11.63 -> 11.27 degrees (flag 1's corner: 19-33 -> 7-10 degrees in
  // frames 34-37); the tables, falls, hanging cloths and sheets within
  // 0.0001 e3D (docs/benchmarks.md).
  bool new_crease_from_frame_before = true;
  // A crease can also grow over several frames, its hinges turning less
  // than new_crease_angle_deg a frame (most of the flags' folds: of their
  // 28 error episodes, 8 began at a frame that fired the test above). A
  // frame that does not fire it is tested again against the frame this
  // many frames before (or the oldest kept) and, over the angle, gets the
  // bending-prior, mirror and flip opinions, not the frame-before one
  // (that frame is part of the drift: with it, the same errors at more
  // time). 3 against 1: twenty flags' e_n 10.41 -> 9.54 degrees on one
  // thread (15 better), +0.13 on two (other paths), tables the same,
  // eight falls +0.12 (fall 6 +0.83), hanging cloths and sheets the same
  // to the bit; a flag's or a table's frame takes a fifth to a half more
  // time (docs/benchmarks.md). 1: the frame before only.
  int new_crease_span_frames = 3;
  // What the temporal term holds each frame to (TemporalCost): 1, the
  // frame before (the paper's: a surface that moves fast is held back);
  // 2, the line through the two frames before (constant velocity, inertia
  // without the mass and gravity a scene does not give: a surface moving
  // steadily is not held back, one that changes its motion is). Where
  // fewer frames came before, as many as there are.
  int temporal_order = 1;
  // The physics prior: inertia under gravity. Where the scene states its
  // gravity and frame rate (scene.json's optional "gravity" and
  // "frame_rate", docs/sft.md), the temporal term holds each frame with two
  // before it to InertiaResidual's target with gravity folded in, the line
  // through those two moved by g dt^2 (order 2 whatever temporal_order
  // says): a cloth falling freely is not held back, a surface that stops or
  // turns is. A scene that states neither gets the temporal term as
  // configured, and a warning says the prior is off.
  bool gravity_prior = false;
  // Where the surface folds over itself, the part it hides has no image
  // to go by, and the jets it shares with the parts in view carry it
  // along: the table's cloth under its lifted corner, still in the truth
  // (0.3-0.6 mm in two frames), moved 3-37 mm in two frames tracked. Each
  // frame's vertices that a nearer part of its own surface hides (by more
  // than 1% of the template's size, where the estimate is when its
  // problem is built) are held to where the frame before put them, at
  // this weight (TemporalCost of order 1 on those vertices alone,
  // normalised as the temporal term). On the five tables the mean e3D
  // 0.0343 -> 0.0296 (four better, one worse), the flags, falls and
  // hanging cloths within 0.0003; a scene that never folds over pays
  // nothing and is solved to the same bit. 3 gains a third as much; 30
  // more on four tables and loses the fifth (0.035 -> 0.075;
  // docs/benchmarks.md). 0: off.
  double occluded_temporal_weight = 10.0;
  // The share of its velocity in the frame before that such a hidden
  // vertex keeps (the hold then of order 2, TemporalCost's velocity b:
  // x_t held to x_t-1 + b (x_t-1 - x_t-2)). 0 holds it where it was; 1
  // carries it on as it moved, which a cloth draping on behind itself
  // does but a hidden layer that slid and stopped does not (the tables
  // lose 0.005 e3D). 0.5, a motion that dies away: a layer that lay still
  // as it was hidden stays still, a part of a fold that rolls on is not
  // left behind. With the hidden splits (PatchAtlasOptions::
  // hidden_split_share, whose children it alone carries), 0 -> 0.5: a
  // table lost (0.077) found (0.0093), the falls' e_n 9.78 / 9.64 -> 9.57
  // / 9.10 degrees, the flags even (mean e3D 0.0158 -> 0.0163, one of
  // nine worse by 0.004, as they tip); a sheet turning edge-on and back is
  // further off in the frames it is lost in either way (docs/
  // benchmarks.md, "the hidden layer a patch of its own, by default"). In
  // [0, 1].
  double occluded_velocity = 0.5;
  // A segmentation's mask is a few pixels off: within this many pixels
  // (of the full-size frame) of the mask's border, the silhouette may
  // cover or not at no cost, so that a mask a little too large or too
  // small does not pull the surface toward or away from the camera
  // (sft/solver/silhouette_band.h). 0: the silhouette matches the mask
  // everywhere, as in the paper. Negative: measured on the first frame, as
  // far as its mask is grown or shrunk against the template's silhouette
  // (the template is registered to that frame; MaskBorderOffset), so that
  // exact masks keep their precision.
  double silhouette_band = -1.0;
  // A mask is binary (the scene format: foreground > 127), and of a pixel
  // on its border it says only on which side of 1/2 the object covers it:
  // the silhouette's bounds there are [1/2, 1] inside and [0, 1/2] outside
  // (RelaxBinaryBorder, sft/solver/silhouette_band.h). Matched as 1 and 0,
  // a straight edge at a fixed sub-pixel offset (a sheet facing the
  // camera: its top edge covers its border pixels by 0.6, read as 1) is
  // pulled outwards along its whole length, and the sheet bends toward
  // the camera. (That pull used to offset the inward one of SoftRas' rim
  // over the observed frame: with kSoftZ, relaxing it alone is worse.)
  bool relax_mask_border = true;
  // The silhouette's long reach (SilhouetteReachCost) on the pyramid's
  // coarsest level: every vertex is pulled inside the mask's outline from
  // wherever it is, so that a surface that moved further than the
  // coverage term sees is brought back; the finer levels are left to the
  // coverage term (and a segmentation's few pixels of error), so that a
  // surface the outline cannot tell from its mirror image (a sheet
  // turning back from edge-on) is placed by the texture. Its cost is
  // w^2 / 2 times the mean squared distance (px) of the vertices outside.
  // 0: off, the default. At 2 it helps the simulated flag and table a
  // little, but it pulled a sheet leaving the image and coming back to a
  // wrong place (polysft_stress_test; docs/benchmarks.md).
  double silhouette_reach_weight = 0.0;
  // Keypoint correspondences between the template and each frame
  // (sft/solver/texture_features.h): on the pyramid's coarse levels each
  // pulls its surface point to where the frame shows it, w^2 / 2 times the
  // mean squared distance over the template's size in the image (both in
  // pixels), nothing within feature_dead_zone_px, Huber beyond
  // feature_huber_px more; the finest level is the image's (with
  // features_on_finest, every level). They reach as far as the surface
  // moved, where the image terms reach only the coarsest level's blur, and
  // they say whether a frame is found (Tracked). 0: off, the default:
  // with the flow start at 100 the simulated flag's e3D drops 0.041 ->
  // 0.025 and the fall's 0.050 -> 0.021, but the sheets' creases lose 3-4%
  // and a frame takes up to twice as long. (Without the flow start they
  // pulled a 160 px sheet turning 60 degrees between frames into its
  // mirror image, which fits the image better and the keypoints exactly;
  // with it, no longer: docs/benchmarks.md.) Needs the photometric term.
  double feature_weight = 0.0;
  // With feature_weight 0: keypoint correspondences at weight 100 from the
  // frame after the first lost one (cost over 4 times the median of the
  // frames tracked before) on, so that a scene pays for them only once it needs them (a warning
  // says from when). With the flow start and relocalize, on the simulated
  // cloth: the table 0.053 -> 0.046, the flag 0.029 -> 0.026, the fall
  // 0.050 -> 0.022 (e3D); the sheets that are never lost unchanged, the
  // two creases, lost in their last frames, 0.5-1% worse (docs/
  // benchmarks.md).
  bool keypoints_when_lost = true;
  // Relocalisation on the template's keypoints (SIFT matches with its
  // texture) for frames that lose the surface. The template is placed
  // rigidly on a frame's keypoints (a RANSAC perspective-n-point solve:
  // sft/solver/match_pose.h), and the frame fitted to that and then to the
  // keypoints that agree, under the regularisers:
  //  - a frame after one that was not tracked (lost, or an empty mask)
  //    starts there where its keypoints disagree with its warm start and
  //    that fits its coarsest level better;
  //  - a frame lost after its solve (cost over 4 times the median of the
  //    frames tracked before) whose keypoints disagree with the surface is solved again from
  //    there (if that start fits the coarsest level better than its own
  //    did), the lower final cost kept; trace.csv's `recovery` is 2 on
  //    those rows.
  // Keypoints are sought only in such frames. A sheet leaving the image at
  // 12 cm a frame and coming back: 159 -> 4.8 mm (RMSE, polysft_stress_test);
  // the simulated flag 0.041 -> 0.029 (e3D); scenes never lost unchanged
  // (docs/benchmarks.md). Needs the photometric term.
  bool relocalize = true;
  double feature_huber_px = 3.0;
  // Within this many pixels (full size) of its match a keypoint costs
  // nothing (FeatureCost's dead zone): a keypoint's own error, about a
  // pixel, is the photometric term's to settle, not a pull to bias it.
  double feature_dead_zone_px = 2.0;
  bool features_on_finest = false;
  // Optical-flow correspondences (sft/solver/flow_matches.h): the frame
  // before's surface as solved, where that frame saw it, carried into this
  // frame by dense optical flow (forward-backward checked), only when the
  // frame before is tracked (the flow carries a registration on, right or
  // wrong). As a start (flow_start, on): the newest frame fitted to them
  // under the regularisers, kept as its start where that fits its coarsest
  // level better than the warm start; the solve is then the images' alone.
  // On the simulated cloth it holds the table within 7 mm through frame 20
  // where the warm start alone loses it from frame 8 (e3D 0.079 -> 0.053)
  // and finds the fall 4 frames longer (lost either way once it lands:
  // 0.048 -> 0.050 over the sequence); the flag 0.042 -> 0.041; the sheets
  // within 0.01 mm but the wave packet 2.70 -> 2.48 mm and a real-like
  // sheet 0.75 -> 0.69; a frame takes 1.05-1.45 times as long on the
  // sheets, up to twice on the cloth. As a term (flow_weight > 0, off):
  // the vertices pulled to where the image moved them, weighted as
  // keypoints are (FeatureCost; their dead zone and Huber threshold), on
  // the coarse levels only (with flow_on_finest every level); weaker than
  // the start, since it ties each frame to the frame before's solution
  // (docs/benchmarks.md). Both need the photometric term and more than one
  // frame.
  double flow_weight = 0.0;
  bool flow_on_finest = false;
  bool flow_start = true;
  TextureFeatureOptions features;
  // Map each frame to the texture's lighting (per-channel gain and bias,
  // sft/solver/brightness.h) before the photometric term compares them.
  bool match_brightness = true;
  // Start each frame from the last one moved on by its last change
  // (constant velocity) where that fits the frame better than the last
  // one does (the image terms at the coarsest level): fast smooth motion
  // stays within the pyramid's reach and takes fewer iterations, and a
  // motion that reverses between two frames is not overshot. Only the
  // motion of two tracked frames is carried on (seen, fitting within 4
  // times the median cost of the frames tracked before, colours
  // correlated with the texture's).
  // On by default since 2026-11-29: on the cloth a corner lifts and turns
  // over, it carries the flap through edge-on where the last frame alone
  // turns it back (13 table seeds: four lost without, one with; mean e3D
  // 0.032 -> 0.023), and it is neutral or better on every other generated
  // scene, the sheet turning edge-on included (docs/benchmarks.md).
  bool predict_motion = true;
  // A newest frame that fits far worse than the first (cost over 4 times
  // frame 0's) is moved onto its mask (the surface translated parallel to
  // the image so that its projected centroid is the mask's), its window
  // solved again from there, and the better of the two kept; said in a
  // warning and in trace.csv's `recovery` column. Off by default: on the
  // simulated flag it re-solved 26 frames and ended worse (docs/
  // benchmarks.md).
  bool recover_lost_frames = false;
  // A diagnostic (per-vertex ground truth only; ignored otherwise): each
  // frame starts from the model fitted under the regularisers to the
  // ground truth of
  //   kThisFrame   the frame itself: the error left is what the cost holds
  //                the surface to when tracking is perfect, the part that
  //                better tracking cannot remove;
  //   kFrameBefore the frame before: one ordinary step from a perfect
  //                past, what a frame's motion alone costs (without the
  //                errors that tracking accumulates).
  GroundTruthStart ground_truth_start = GroundTruthStart::kNone;
  // Per-pixel robust loss of the photometric residual (real video).
  RobustLoss robust_loss = RobustLoss::kNone;
  double robust_scale = 0.1;
  // Frames to solve (0: all).
  int max_frames = 0;
  int num_threads = 0;

  std::string Validate() const;
};

// The pyramid's levels for frames `image_width` pixels wide: the
// options' own, or when 0, as many as bring the coarsest level to at most
// 128 px wide (at least 3).
int ChoosePyramidLevels(const PolySftOptions& options, int image_width);

struct SftFrameSummary {
  int index = 0;
  // 3 by #V, camera frame, template vertex order.
  Eigen::Matrix3Xd vertices;
  // Solver time spent on the windows this frame entered as the newest.
  double time_s = 0.0;
  // The final cost of the window this frame entered as the newest, per
  // frame of that window.
  double cost = 0.0;
  int iterations = 0;
  // The atlas the frame was solved with: its patches, and each vertex's
  // (#V; empty for a frame never solved).
  int patches = 1;
  std::vector<int> vertex_patches;
  // Its optical-flow correspondences from the frame before (0 when that
  // frame was not tracked), and whether it started from their fit
  // (PolySftOptions::flow_start).
  int flow_matches = 0;
  bool flow_start = false;
  // Its keypoint correspondences with the template's texture (0 where
  // none were sought: feature_weight, keypoints_when_lost, relocalize),
  // and whether it started from the template they placed (relocalize).
  int keypoint_matches = 0;
  bool relocalized = false;
  double e3d = std::numeric_limits<double>::quiet_NaN();
  double normal_error_deg = std::numeric_limits<double>::quiet_NaN();
  double rmse_mm = std::numeric_limits<double>::quiet_NaN();
  double chamfer_1e4 = std::numeric_limits<double>::quiet_NaN();
};

struct SftIterationSummary {
  int frame = 0;   // the window's newest frame
  int window = 0;  // the window's oldest frame
  int iteration = 0;
  double time_s = 0.0;  // since the start of the sequence
  double cost = 0.0;
  int patches = 1;
  double e3d = std::numeric_limits<double>::quiet_NaN();
  // On a frame's re-solve: 1 a lost frame moved onto its mask
  // (PolySftOptions::recover_lost_frames), 2 placed on its keypoints
  // (relocalize); a new crease's second opinion: 3 under a bending prior
  // (new_crease_bending_weight), 4 its flap mirrored (mirror_new_creases),
  // 5 from where the frame before ended (new_crease_from_frame_before),
  // 6 its crease turned inside out (flip_new_crease_bands).
  int recovery = 0;
};

// A patch of the atlas split after `frame` was solved: it fit `ratio` times
// worse than on the first frame, and splitting it promised `significance`
// times what noise would give.
struct SftPatchSplit {
  int frame = 0;
  int patch = 0;
  int children = 0;
  double ratio = 0.0;
  // The score test's gain over its noise level.
  double significance = 0.0;
  // How far the score test's step moved the patch's vertices (largest, px).
  double step_pixels = 0.0;
};

struct PolySftSummary {
  // kFailure: the solve diverged or the surface went behind the camera;
  // `frames` holds the frames finalised before (the message names the
  // frame). kNoConvergence: some level solve reached its iteration cap (the
  // usual case at a fixed cost per frame).
  TerminationType termination_type = TerminationType::kConvergence;
  std::string message;
  std::vector<SftFrameSummary> frames;
  std::vector<SftIterationSummary> trace;
  // "patch_jet", or "texture_space" (the fallback for templates that are
  // no height field, or when asked for).
  std::string deformation;
  // The atlas: its splits in order, and each patch's vertex count at the end.
  std::vector<SftPatchSplit> splits;
  std::vector<int> patch_vertices;
  // Active terms and their weights.
  std::vector<std::pair<std::string, double>> terms;
  std::vector<std::string> warnings;
  // The silhouette band used (px of the full-size frame; measured when
  // PolySftOptions::silhouette_band < 0).
  double silhouette_band_px = 0.0;
  // The pyramid's levels (chosen by width when PolySftOptions::
  // pyramid_levels is 0).
  int pyramid_levels = 0;
  // How often a frame went back to its start before a finer level
  // (PolySftOptions::check_coarse_levels), of how often it was checked.
  int coarse_moves_undone = 0;
  int coarse_moves_checked = 0;
  double total_time_s = 0.0;
  double mean_time_per_frame_s = 0.0;
  double mean_e3d = std::numeric_limits<double>::quiet_NaN();
  double mean_normal_error_deg = std::numeric_limits<double>::quiet_NaN();
  double mean_rmse_mm = std::numeric_limits<double>::quiet_NaN();
  double mean_chamfer_1e4 = std::numeric_limits<double>::quiet_NaN();
  // e_3D of holding the template still (the baseline), when ground truth
  // has vertices.
  double template_e3d = std::numeric_limits<double>::quiet_NaN();
  double template_rmse_mm = std::numeric_limits<double>::quiet_NaN();

  bool IsSolutionUsable() const { return termination_type != TerminationType::kFailure; }
  std::string BriefReport() const;
};

// Called once per frame, when it leaves the window (its result is final).
using SftFrameCallback = std::function<void(const SftFrameSummary&)>;

// Throws std::invalid_argument on invalid options, SceneError on a scene
// that cannot be read. A diverged solve is no exception: the summary says
// so (termination_type, message).
PolySftSummary SolvePolySft(const PolySftOptions& options, const SftScene& scene,
                            const SftFrameCallback& on_frame = nullptr);

// Writes meshes/NNNNNN.ply, trace.csv and metrics.json into `directory` as
// the scene format specifies, each file atomically (a crash leaves whole
// files or none). metrics.json's "settings" are the options as
// polysft_settings.h writes them, so that `polysft --config` takes them
// back. Throws Error (kOutput) naming a file.
void WriteSftOutputs(const std::string& directory, const SftScene& scene, const PolySftOptions& options,
                     const PolySftSummary& summary);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SOLVER_POLYSFT_H_
