// The MakeHuman body folder's files one at a time: LoadMakeHumanBody reads
// them all and assembles the body; tests and the fuzz targets reach each
// file's parser alone, with the others already read.
#ifndef POLYFIT_DRAPE_BODY_MAKEHUMAN_FILES_H_
#define POLYFIT_DRAPE_BODY_MAKEHUMAN_FILES_H_

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "drape/body/makehuman_body.h"

namespace polyfit {

// base.obj: every vertex (decimetres) and each group's polygons.
struct MakeHumanObj {
  std::vector<Eigen::Vector3d> vertices;
  // Per group: its faces' corner vertex indices (0-based), polygon by polygon.
  std::map<std::string, std::vector<std::vector<int>>> faces;
};

// Throw BodyError naming the file (and line).
MakeHumanObj ReadMakeHumanObj(const std::string& path);
nlohmann::json ReadBodyJson(const std::string& path);

// The body from base.obj, the rig (rig.cmu_mb.json) and the weights
// (weights.cmu_mb.json), each path for the messages. Throws BodyError
// naming the file whose content is wrong (a key missing or of the wrong
// type, a bone or vertex that does not exist).
SkinnedBody AssembleMakeHumanBody(const MakeHumanObj& obj, const std::string& obj_path, const nlohmann::json& rig,
                                  const std::string& rig_path, const nlohmann::json& weights,
                                  const std::string& weights_path);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_BODY_MAKEHUMAN_FILES_H_
