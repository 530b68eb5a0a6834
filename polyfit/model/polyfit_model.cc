#include "polyfit/model/polyfit_model.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>

#include "polyfit/util/atomic_file.h"
#include "polyfit/util/binary_io.h"

namespace polyfit {
namespace {

constexpr char kMagic[8] = {'P', 'O', 'L', 'Y', 'F', 'I', 'T', '\0'};
constexpr char kEndMagic[4] = {'E', 'N', 'D', '\0'};

using Writer = BinaryWriter;
using Reader = BinaryReader<ModelIoError>;

}  // namespace

std::vector<PatchBoundaryPoint> PolyFitModel::BoundaryPoints() const {
  std::vector<PatchBoundaryPoint> points;
  for (int v = 0; v < num_vertices(); ++v) {
    const IndexRange range = memberships(v);
    for (int i : range) {
      for (int j = i + 1; j < range.front() + range.size(); ++j) {
        PatchBoundaryPoint p;
        p.vertex = v;
        int a = i, b = j;
        if (membership_patch[a] > membership_patch[b]) std::swap(a, b);
        p.patch_a = membership_patch[a];
        p.patch_b = membership_patch[b];
        p.uv_a = membership_uv.col(a);
        p.uv_b = membership_uv.col(b);
        points.push_back(p);
      }
    }
  }
  return points;
}

std::vector<std::vector<int>> PolyFitModel::PatchAdjacency() const {
  std::vector<std::vector<int>> adjacency(patches.size());
  for (int v = 0; v < num_vertices(); ++v) {
    for (int i : memberships(v)) {
      for (int j : memberships(v)) {
        if (i != j) adjacency[membership_patch[i]].push_back(membership_patch[j]);
      }
    }
  }
  for (auto& list : adjacency) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  return adjacency;
}

std::string PolyFitModel::Validate() const {
  const int num_p = num_patches();
  for (int p = 0; p < num_p; ++p) {
    const JetPatch& patch = patches[p];
    if (patch.order < 0 || patch.order > kMaxJetOrder) return "patch " + std::to_string(p) + ": order out of range";
    if (!(patch.frame.scale > 0.0) || !patch.frame.rotation.allFinite() || !patch.frame.translation.allFinite()) {
      return "patch " + std::to_string(p) + ": invalid frame";
    }
    for (double c : patch.coefficients) {
      if (!std::isfinite(c)) return "patch " + std::to_string(p) + ": non-finite coefficient";
    }
  }
  const int num_v = num_vertices();
  if (num_v == 0) return "no vertices";
  if (membership_offsets.front() != 0 || membership_offsets.back() != static_cast<int>(membership_patch.size()) ||
      membership_uv.cols() != static_cast<Eigen::Index>(membership_patch.size())) {
    return "membership sizes disagree";
  }
  for (int v = 0; v < num_v; ++v) {
    if (membership_offsets[v + 1] <= membership_offsets[v]) return "vertex " + std::to_string(v) + " has no patch";
  }
  for (int p : membership_patch) {
    if (p < 0 || p >= num_p) return "membership refers to patch " + std::to_string(p);
  }
  if (!membership_uv.allFinite()) return "non-finite (u, v)";
  if (static_cast<Eigen::Index>(face_patch.size()) != faces.cols()) return "face_patch size differs from #faces";
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    for (int c = 0; c < 3; ++c) {
      if (faces(c, f) < 0 || faces(c, f) >= num_v) return "face " + std::to_string(f) + ": vertex out of range";
    }
    if (face_patch[f] < 0 || face_patch[f] >= num_p) return "face " + std::to_string(f) + ": patch out of range";
  }
  return {};
}

void SavePolyFitModel(const std::string& path, const PolyFitModel& model) {
  if (const std::string problem = model.Validate(); !problem.empty()) {
    throw ModelIoError(path + ": refusing to save an invalid model: " + problem, ErrorKind::kInvalidArgument);
  }
  Writer w;
  w.PutBytes(kMagic, sizeof(kMagic));
  w.Put<std::uint32_t>(kPolyFitModelVersion);
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(model.num_vertices()));
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(model.faces.cols()));
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(model.num_patches()));
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(model.membership_patch.size()));
  w.Put<std::uint32_t>(kMaxJetCoefficients);
  for (const JetPatch& p : model.patches) {
    w.Put<std::int32_t>(p.order);
    w.Put<std::uint32_t>(p.flags);
    w.Put<std::int32_t>(p.num_points);
    w.Put<std::int32_t>(p.refinement_iterations);
    w.Put<double>(p.rms_residual);
    w.Put<double>(p.frame.scale);
    w.PutBytes(p.frame.rotation.data(), 9 * sizeof(double));
    w.PutBytes(p.frame.translation.data(), 3 * sizeof(double));
    w.PutBytes(p.coefficients.data(), kMaxJetCoefficients * sizeof(double));
  }
  for (Eigen::Index f = 0; f < model.faces.cols(); ++f) {
    for (int c = 0; c < 3; ++c) w.Put<std::int32_t>(model.faces(c, f));
  }
  for (int p : model.face_patch) w.Put<std::int32_t>(p);
  for (int o : model.membership_offsets) w.Put<std::int32_t>(o);
  for (int p : model.membership_patch) w.Put<std::int32_t>(p);
  w.PutBytes(model.membership_uv.data(), model.membership_uv.size() * sizeof(double));
  w.PutBytes(kEndMagic, sizeof(kEndMagic));
  try {
    WriteFileAtomically(path, [&](std::ostream& out) {
      out.write(w.buffer().data(), static_cast<std::streamsize>(w.buffer().size()));
    });
  } catch (const Error& e) {
    throw ModelIoError(e.what(), ErrorKind::kOutput);
  }
}

PolyFitModel LoadPolyFitModel(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ModelIoError(path + ": cannot be opened for reading");
  std::vector<char> data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  Reader r(std::move(data), path);
  char magic[8];
  r.GetBytes(magic, sizeof(magic), "header");
  if (std::memcmp(magic, kMagic, sizeof(magic)) != 0) r.Fail("not a PolyFit model (bad magic)");
  const auto version = r.Get<std::uint32_t>("header");
  if (version != static_cast<std::uint32_t>(kPolyFitModelVersion)) {
    r.Fail("model format version " + std::to_string(version) + "; this build reads version " +
           std::to_string(kPolyFitModelVersion));
  }
  const auto num_vertices = r.Get<std::uint32_t>("header");
  const auto num_faces = r.Get<std::uint32_t>("header");
  const auto num_patches = r.Get<std::uint32_t>("header");
  const auto num_memberships = r.Get<std::uint32_t>("header");
  const auto num_coefficients = r.Get<std::uint32_t>("header");
  if (num_coefficients != static_cast<std::uint32_t>(kMaxJetCoefficients)) r.Fail("unexpected coefficient count");
  // Sizes are checked against the file length before allocating.
  const unsigned long long expected = num_patches * (4ull * 4 + 8 * (2 + 9 + 3 + kMaxJetCoefficients)) +
                                      num_faces * 16ull + (num_vertices + 1ull) * 4 + num_memberships * 20ull +
                                      sizeof(kEndMagic);
  if (expected != r.remaining()) {
    r.Fail("size " + std::to_string(r.remaining()) + " bytes after the header, expected " + std::to_string(expected) +
           " (truncated or corrupt)");
  }
  PolyFitModel model;
  model.patches.resize(num_patches);
  for (JetPatch& p : model.patches) {
    p.order = r.Get<std::int32_t>("patches");
    p.flags = r.Get<std::uint32_t>("patches");
    p.num_points = r.Get<std::int32_t>("patches");
    p.refinement_iterations = r.Get<std::int32_t>("patches");
    p.rms_residual = r.Get<double>("patches");
    p.frame.scale = r.Get<double>("patches");
    r.GetBytes(p.frame.rotation.data(), 9 * sizeof(double), "patches");
    r.GetBytes(p.frame.translation.data(), 3 * sizeof(double), "patches");
    r.GetBytes(p.coefficients.data(), kMaxJetCoefficients * sizeof(double), "patches");
  }
  std::vector<std::int32_t> faces(3 * static_cast<size_t>(num_faces));
  r.GetBytes(faces.data(), faces.size() * sizeof(std::int32_t), "faces");
  model.faces = Eigen::Map<Eigen::Matrix3Xi>(faces.data(), 3, num_faces);
  model.face_patch.resize(num_faces);
  r.GetBytes(model.face_patch.data(), num_faces * sizeof(std::int32_t), "face_patch");
  model.membership_offsets.resize(static_cast<size_t>(num_vertices) + 1);
  r.GetBytes(model.membership_offsets.data(), model.membership_offsets.size() * sizeof(std::int32_t),
             "membership_offsets");
  model.membership_patch.resize(num_memberships);
  r.GetBytes(model.membership_patch.data(), num_memberships * sizeof(std::int32_t), "membership_patch");
  model.membership_uv.resize(2, num_memberships);
  r.GetBytes(model.membership_uv.data(), 2 * static_cast<size_t>(num_memberships) * sizeof(double), "membership_uv");
  char end[4];
  r.GetBytes(end, sizeof(end), "end marker");
  if (std::memcmp(end, kEndMagic, sizeof(end)) != 0) r.Fail("bad end marker (corrupt file)");
  if (const std::string problem = model.Validate(); !problem.empty()) r.Fail("inconsistent model: " + problem);
  return model;
}

}  // namespace polyfit
