#include "drape/garment/mhclo_garment.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "polyfit/mesh/ordered_io.h"

namespace polyfit {

ClothesBinding ReadMhclo(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw GarmentError(path + ": cannot be opened (missing?)");
  ClothesBinding binding;
  std::string line;
  int number = 0;
  bool in_verts = false;
  bool scales[3] = {false, false, false};
  auto fail = [&](const std::string& reason) {
    throw GarmentError(path + ": line " + std::to_string(number) + ": " + reason);
  };
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::istringstream tokens(line);
    std::string first;
    tokens >> first;
    const bool numeric = std::isdigit(static_cast<unsigned char>(first[0])) != 0;
    if (in_verts && numeric) {
      std::vector<double> values;
      for (std::string token = first; !token.empty(); token.clear(), tokens >> token) {
        char* end = nullptr;
        const double value = std::strtod(token.c_str(), &end);
        if (*end != '\0' || !std::isfinite(value)) fail("bad number '" + token + "'");
        values.push_back(value);
      }
      // References are base-mesh vertex indices (hm08 has 19,158): whole,
      // and small enough to be ints.
      const auto reference = [&](double v) {
        if (v < 0 || v > 1e8 || v != std::floor(v)) fail("bad vertex index " + std::to_string(v));
        return static_cast<int>(v);
      };
      if (values.size() == 1) {
        const int v = reference(values[0]);
        binding.references.push_back({v, v, v});
        binding.weights.push_back({1.0, 0.0, 0.0});
        binding.offsets.emplace_back(Eigen::Vector3d::Zero());
      } else if (values.size() == 9) {
        binding.references.push_back({reference(values[0]), reference(values[1]), reference(values[2])});
        binding.weights.push_back({values[3], values[4], values[5]});
        binding.offsets.emplace_back(values[6], values[7], values[8]);
      } else {
        fail("a vertex binding needs 1 or 9 numbers, not " + std::to_string(values.size()));
      }
      continue;
    }
    in_verts = false;
    if (first == "verts") {
      in_verts = true;
    } else if (first == "name") {
      tokens >> binding.name;
    } else if (first == "obj_file") {
      tokens >> binding.obj_file;
    } else if (first == "x_scale" || first == "y_scale" || first == "z_scale") {
      const int axis = first[0] - 'x';
      if (!(tokens >> binding.scale_vertices[axis][0] >> binding.scale_vertices[axis][1] >>
            binding.scale_distances[axis]) ||
          !(binding.scale_distances[axis] > 0.0) || !std::isfinite(binding.scale_distances[axis])) {
        fail("bad " + first);
      }
      scales[axis] = true;
    }
  }
  if (binding.references.empty()) throw GarmentError(path + ": no 'verts' section");
  if (binding.obj_file.empty()) throw GarmentError(path + ": no 'obj_file'");
  for (int axis = 0; axis < 3; ++axis) {
    if (!scales[axis]) throw GarmentError(path + ": no " + std::string(1, static_cast<char>('x' + axis)) + "_scale");
  }
  return binding;
}

Eigen::Matrix3Xd ApplyBinding(const ClothesBinding& binding, const Eigen::Matrix3Xd& base, double units) {
  const int n = static_cast<int>(base.cols());
  Eigen::Vector3d scale;
  for (int axis = 0; axis < 3; ++axis) {
    const auto& r = binding.scale_vertices[axis];
    if (r[0] < 0 || r[0] >= n || r[1] < 0 || r[1] >= n) {
      throw GarmentError("binding '" + binding.name + "': scale vertex out of range of the base mesh");
    }
    scale[axis] = std::abs(base(axis, r[0]) - base(axis, r[1])) / (units * binding.scale_distances[axis]);
  }
  Eigen::Matrix3Xd out(3, binding.references.size());
  for (size_t i = 0; i < binding.references.size(); ++i) {
    Eigen::Vector3d p = units * binding.offsets[i].cwiseProduct(scale);
    for (int k = 0; k < 3; ++k) {
      const int v = binding.references[i][k];
      if (v < 0 || v >= n) {
        throw GarmentError("binding '" + binding.name + "': garment vertex " + std::to_string(i) +
                           " refers to base vertex " + std::to_string(v) + " of " + std::to_string(n));
      }
      p += binding.weights[i][k] * base.col(v);
    }
    out.col(i) = p;
  }
  return out;
}

TriangleMesh LoadGarment(const std::string& mhclo_path, const Eigen::Matrix3Xd& base, double units) {
  const ClothesBinding binding = ReadMhclo(mhclo_path);
  const std::string obj_path = (std::filesystem::path(mhclo_path).parent_path() / binding.obj_file).string();
  TriangleMesh mesh;
  try {
    mesh = ReadObjTemplate(obj_path);
  } catch (const std::runtime_error& e) {
    throw GarmentError(e.what());
  }
  if (mesh.num_vertices() != static_cast<int>(binding.references.size())) {
    throw GarmentError(mhclo_path + ": binds " + std::to_string(binding.references.size()) + " vertices, " + obj_path +
                       " has " + std::to_string(mesh.num_vertices()));
  }
  mesh.vertices = ApplyBinding(binding, base, units);
  return mesh;
}

}  // namespace polyfit
