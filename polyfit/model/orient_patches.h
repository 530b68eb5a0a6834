// Orients every patch of a model like its faces. PCA leaves a patch's
// normal axis with an arbitrary sign; terms that compare normals across
// patches (OneFit's boundary continuity) need them to agree. A patch whose
// frame normal points against the area-weighted normal of its faces is
// turned 180 degrees about its u axis (v -> -v, z -> -z):
//   z'(u, v') = -z(u, -v'),  alpha'_(a, b) = -(-1)^b alpha_(a, b),
// and its members' v coordinates change sign. The surface is unchanged.
#ifndef POLYFIT_MODEL_ORIENT_PATCHES_H_
#define POLYFIT_MODEL_ORIENT_PATCHES_H_

#include "polyfit/mesh/triangle_mesh.h"
#include "polyfit/model/polyfit_model.h"

namespace polyfit {

// mesh: the model's mesh (its faces and face_patch index the same faces).
// Returns the number of patches turned.
int OrientPatchesLikeFaces(const TriangleMesh& mesh, PolyFitModel* model);

// Turns every patch's frame about its normal so that its u axis points
// along `primary` projected onto the patch's plane (along `secondary` where
// primary is within 15 degrees of the normal). PCA leaves the in-plane axes
// wherever the patch's spread puts them, at random for a round patch; a
// learner that reads jets (OneFit's patch embeddings) wants them in a frame
// that a remeshed or re-patched garment shares. With the turn
// (u, v) = (c u' - s v', s u' + c v'), c = cos(theta), s = sin(theta),
//   z'(u', v') = z(c u' - s v', s u' + c v'),
// expanded binomially (exact), and the members' (u, v) turn with it. The
// surface is unchanged. Returns the largest |theta| (radians).
double AlignPatchFrames(const Eigen::Vector3d& primary, const Eigen::Vector3d& secondary, PolyFitModel* model);

// The jet of `patch` re-expressed in its frame turned by theta about the
// normal (the formula above), and the turned frame.
void TurnPatchAboutNormal(double theta, JetPatch* patch);

}  // namespace polyfit

#endif  // POLYFIT_MODEL_ORIENT_PATCHES_H_
