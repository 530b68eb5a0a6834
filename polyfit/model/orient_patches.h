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

}  // namespace polyfit

#endif  // POLYFIT_MODEL_ORIENT_PATCHES_H_
