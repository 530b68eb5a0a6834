// The other way a fold could have formed. A flat sheet that starts to fold
// looks alike from the camera whichever side its flap turns to (to first
// order: the flap's foreshortening is the same), so a solve picks one, and
// once the fold has grown it cannot turn through flat again. The other
// candidate is the flap mirrored about the plane of the sheet beside the
// crease (a fold of angle a becomes one of -a about the same line).
#ifndef POLYFIT_SFT_SOLVER_FOLD_MIRROR_H_
#define POLYFIT_SFT_SOLVER_FOLD_MIRROR_H_

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "polyfit/mesh/mesh_topology.h"
#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// `vertices` (3 by #V, the surface as solved) with the flap of a crease
// mirrored. crease: per hinge of `hinges` (the mesh's InteriorHinges),
// whether the crease runs along it. The faces joined across the other
// hinges fall apart into the sheet (the most faces) and the flap (the
// next most, at least min_flap_faces); the flap's vertices that no other
// face holds are mirrored about the plane (least squares) through the
// vertices on the crease between the two and the sheet's vertices one
// edge from them. Returns the number of vertices mirrored: 0 (and
// `mirrored` = `vertices`) when the crease does not cut a flap off or the
// plane is not defined (fewer than three points, or all on a line).
int MirrorFoldFlap(const TriangleMesh& mesh, const std::vector<MeshHinge>& hinges,
                   const std::vector<std::uint8_t>& crease, const Eigen::Matrix3Xd& vertices,
                   Eigen::Matrix3Xd* mirrored, int min_flap_faces = 4);

// `vertices` (3 by #V, in the camera's frame: the camera at the origin)
// with a crease that cuts no flap off turned inside out: a ridge that
// dies out inside the sheet becomes a valley, which the camera sees alike
// (the same to first order where the sheet beside faces it). The largest
// set of faces on crease hinges joined where the hinges meet (at least
// min_faces) is the crease's band; its vertices slide along their
// rays to the other side of the plane (least squares) through the
// vertices one edge outside it, as far as they were on this side, so
// that every one projects where it did. Returns the number of vertices
// moved: 0 (and `flipped` = `vertices`) without such a band, without a
// plane, or where the plane is seen within about 6 degrees of edge-on
// from one of them.
int FlipCreaseAlongRays(const TriangleMesh& mesh, const std::vector<MeshHinge>& hinges,
                        const std::vector<std::uint8_t>& crease, const Eigen::Matrix3Xd& vertices,
                        Eigen::Matrix3Xd* flipped, int min_faces = 4);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SOLVER_FOLD_MIRROR_H_
