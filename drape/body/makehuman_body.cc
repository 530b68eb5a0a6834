#include "drape/body/makehuman_body.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "drape/body/makehuman_files.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;
constexpr int kBodyVertices = 13380;  // group "body": vertices 0 .. 13379 (README)

[[noreturn]] void Fail(const std::string& message) { throw BodyError(message); }

}  // namespace

int Skeleton::Find(const std::string& name) const {
  const auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

MakeHumanObj ReadMakeHumanObj(const std::string& path) {
  std::ifstream in(path);
  if (!in) Fail(path + ": cannot be opened (missing?)");
  MakeHumanObj obj;
  std::string line, group = "default";
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    std::istringstream tokens(line);
    std::string tag;
    tokens >> tag;
    if (tag == "v") {
      Eigen::Vector3d p;
      if (!(tokens >> p.x() >> p.y() >> p.z()) || !p.allFinite()) {
        Fail(path + ": line " + std::to_string(number) + ": bad vertex");
      }
      obj.vertices.push_back(p);
    } else if (tag == "g") {
      tokens >> group;
    } else if (tag == "f") {
      std::vector<int> face;
      std::string corner;
      while (tokens >> corner) {
        // strtol, not atoi: an index beyond long is reported, not undefined.
        const long index = std::strtol(corner.substr(0, corner.find('/')).c_str(), nullptr, 10);
        if (index < 1 || index > static_cast<long>(obj.vertices.size())) {
          Fail(path + ": line " + std::to_string(number) + ": vertex index out of range");
        }
        face.push_back(static_cast<int>(index - 1));
      }
      if (face.size() < 3) Fail(path + ": line " + std::to_string(number) + ": a face needs three corners");
      obj.faces[group].push_back(face);
    }
  }
  return obj;
}

nlohmann::json ReadBodyJson(const std::string& path) {
  std::ifstream in(path);
  if (!in) Fail(path + ": cannot be opened (missing?)");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    Fail(path + ": not valid JSON: " + e.what());
  }
}

namespace {

// The body's mesh (decimetres to metres) and every vertex of the OBJ
// (helpers included, for garments' bindings).
void ReadBodyMesh(const MakeHumanObj& obj, const std::string& obj_path, SkinnedBody* body) {
  if (static_cast<int>(obj.vertices.size()) < kBodyVertices) Fail(obj_path + ": fewer vertices than the hm08 body");
  const auto body_faces = obj.faces.find("body");
  if (body_faces == obj.faces.end()) Fail(obj_path + ": no group 'body'");
  body->mesh.vertices.resize(3, kBodyVertices);
  for (int v = 0; v < kBodyVertices; ++v) body->mesh.vertices.col(v) = 0.1 * obj.vertices[v];
  body->base_vertices.resize(3, static_cast<Eigen::Index>(obj.vertices.size()));
  for (size_t v = 0; v < obj.vertices.size(); ++v) body->base_vertices.col(v) = 0.1 * obj.vertices[v];
  std::vector<Eigen::Vector3i> triangles;
  for (const std::vector<int>& face : body_faces->second) {
    for (size_t k = 1; k + 1 < face.size(); ++k) {
      const Eigen::Vector3i t(face[0], face[k], face[k + 1]);
      if (t.maxCoeff() >= kBodyVertices) Fail(obj_path + ": a body face uses a helper vertex");
      triangles.push_back(t);
    }
  }
  body->mesh.faces.resize(3, static_cast<Eigen::Index>(triangles.size()));
  for (size_t f = 0; f < triangles.size(); ++f) body->mesh.faces.col(f) = triangles[f];
}

// Bones, parents first.
void ReadBones(const nlohmann::json& rig, const std::string& rig_path, Skeleton* skeleton) {
  std::vector<std::string> pending;
  for (const auto& [name, bone] : rig.items()) pending.push_back(name);
  while (!pending.empty()) {
    const size_t before = pending.size();
    for (auto it = pending.begin(); it != pending.end();) {
      const std::string parent = rig.at(*it).value("parent", std::string());
      const int parent_index = parent.empty() ? -1 : skeleton->Find(parent);
      if (!parent.empty() && parent_index < 0) {
        ++it;
        continue;
      }
      skeleton->names.push_back(*it);
      skeleton->parents.push_back(parent_index);
      it = pending.erase(it);
    }
    if (pending.size() == before) Fail(rig_path + ": bone '" + pending.front() + "' has a missing parent (or a cycle)");
  }
  if (skeleton->names.empty()) Fail(rig_path + ": no bones");
}

// Heads: the mean of the joint cube's vertices, or of listed vertices.
void PlaceJointHeads(const nlohmann::json& rig, const std::string& rig_path, const MakeHumanObj& obj,
                     const std::string& obj_path, Skeleton* skeleton) {
  skeleton->rest_heads.resize(3, skeleton->num_joints());
  for (int j = 0; j < skeleton->num_joints(); ++j) {
    const std::string& name = skeleton->names[j];
    // at(): a const operator[] on a missing key is undefined behaviour.
    const nlohmann::json& head = rig.at(name).at("head");
    std::set<int> vertices;
    const std::string strategy = head.value("strategy", std::string());
    if (strategy == "CUBE") {
      const std::string cube = head.value("cube_name", std::string());
      const auto group = obj.faces.find(cube);
      if (group == obj.faces.end()) Fail(obj_path + ": no joint cube '" + cube + "' (bone " + name + ")");
      for (const auto& face : group->second) vertices.insert(face.begin(), face.end());
    } else if (strategy == "MEAN") {
      for (int v : head.at("vertex_indices")) vertices.insert(v);
    } else {
      Fail(rig_path + ": bone '" + name + "': unknown head strategy '" + strategy + "'");
    }
    if (vertices.empty()) Fail(rig_path + ": bone '" + name + "' has no head vertices");
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int v : vertices) {
      if (v < 0 || v >= static_cast<int>(obj.vertices.size())) Fail(rig_path + ": vertex index out of range");
      sum += obj.vertices[v];
    }
    skeleton->rest_heads.col(j) = 0.1 * sum / static_cast<double>(vertices.size());
    skeleton->head_vertices.emplace_back(vertices.begin(), vertices.end());
  }
}

// Weights per body vertex, normalised to sum 1.
void ReadSkinWeights(const nlohmann::json& weights, const std::string& weights_path, SkinnedBody* body) {
  if (!weights.contains("weights")) Fail(weights_path + ": missing key 'weights'");
  std::vector<std::vector<std::pair<int, double>>> per_vertex(kBodyVertices);
  for (const auto& [bone, list] : weights.at("weights").items()) {
    const int j = body->skeleton.Find(bone);
    if (j < 0) Fail(weights_path + ": bone '" + bone + "' is not in the rig");
    for (const auto& entry : list) {
      const int v = entry.at(0).get<int>();
      const double w = entry.at(1).get<double>();
      if (!std::isfinite(w)) Fail(weights_path + ": bone '" + bone + "': a weight is not finite");
      if (v >= 0 && v < kBodyVertices && w > 0.0) per_vertex[v].emplace_back(j, w);
    }
  }
  body->weight_offsets.assign(1, 0);
  for (int v = 0; v < kBodyVertices; ++v) {
    double total = 0.0;
    for (const auto& [j, w] : per_vertex[v]) total += w;
    if (!(total > 0.0)) Fail(weights_path + ": body vertex " + std::to_string(v) + " has no weight");
    for (const auto& [j, w] : per_vertex[v]) {
      body->weight_joint.push_back(j);
      body->weight_value.push_back(w / total);
    }
    body->weight_offsets.push_back(static_cast<int>(body->weight_joint.size()));
  }
}

}  // namespace

SkinnedBody AssembleMakeHumanBody(const MakeHumanObj& obj, const std::string& obj_path, const nlohmann::json& rig,
                                  const std::string& rig_path, const nlohmann::json& weights,
                                  const std::string& weights_path) {
  SkinnedBody body;
  ReadBodyMesh(obj, obj_path, &body);
  // nlohmann's own errors (a key missing, a value of the wrong type) name
  // neither the file nor the bone: they are reported against the file.
  try {
    if (!rig.is_object()) Fail(rig_path + ": expected an object of bones");
    ReadBones(rig, rig_path, &body.skeleton);
    PlaceJointHeads(rig, rig_path, obj, obj_path, &body.skeleton);
  } catch (const nlohmann::json::exception& e) {
    Fail(rig_path + ": " + e.what());
  }
  try {
    if (!weights.is_object()) Fail(weights_path + ": expected an object");
    ReadSkinWeights(weights, weights_path, &body);
  } catch (const nlohmann::json::exception& e) {
    Fail(weights_path + ": " + e.what());
  }
  return body;
}

SkinnedBody LoadMakeHumanBody(const std::string& body_dir) {
  const fs::path dir(body_dir);
  const std::string obj_path = (dir / "makehuman" / "base.obj").string();
  const std::string rig_path = (dir / "mpfb2_rigs" / "rig.cmu_mb.json").string();
  const std::string weights_path = (dir / "mpfb2_rigs" / "weights.cmu_mb.json").string();
  const MakeHumanObj obj = ReadMakeHumanObj(obj_path);
  return AssembleMakeHumanBody(obj, obj_path, ReadBodyJson(rig_path), rig_path, ReadBodyJson(weights_path),
                               weights_path);
}

Eigen::Vector3d SkinPoint(const Eigen::Vector3d& rest, const int* joints, const double* weights, int count,
                          const std::vector<Eigen::Isometry3d>& rest_to_posed) {
  Eigen::Matrix3d linear = Eigen::Matrix3d::Zero();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  for (int k = 0; k < count; ++k) {
    const Eigen::Isometry3d& t = rest_to_posed[joints[k]];
    linear += weights[k] * t.linear();
    translation += weights[k] * t.translation();
  }
  return linear * rest + translation;
}

Eigen::Matrix3Xd SkinVertices(const SkinnedBody& body, const std::vector<Eigen::Isometry3d>& rest_to_posed) {
  if (static_cast<int>(rest_to_posed.size()) != body.skeleton.num_joints()) {
    throw std::invalid_argument("SkinVertices: one transform per joint is needed");
  }
  const int n = body.mesh.num_vertices();
  Eigen::Matrix3Xd posed(3, n);
  for (int v = 0; v < n; ++v) {
    const int begin = body.weight_offsets[v];
    posed.col(v) = SkinPoint(body.mesh.vertices.col(v), body.weight_joint.data() + begin,
                             body.weight_value.data() + begin, body.weight_offsets[v + 1] - begin, rest_to_posed);
  }
  return posed;
}

}  // namespace polyfit
