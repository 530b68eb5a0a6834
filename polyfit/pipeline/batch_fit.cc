#include "polyfit/pipeline/batch_fit.h"

#include <glob.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "polyfit/mesh/mesh_io.h"
#include "polyfit/util/atomic_file.h"
#include "polyfit/util/file_extension.h"
#include "polyfit/util/json_number.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

bool IsMeshFile(const fs::path& path) {
  const std::string ext = LowercaseExtension(path);
  static const std::set<std::string> kExtensions = {".obj", ".ply", ".off", ".stl", ".gltf", ".glb"};
  return kExtensions.count(ext) > 0;
}

double NumberOr(const json& j, const char* key) {
  return j.contains(key) && j[key].is_number() ? j[key].get<double>() : std::numeric_limits<double>::quiet_NaN();
}

json SummaryToJson(const BatchFitItemSummary& item) {
  const MeshFitSummary& s = item.summary;
  return json{{"input", item.input},
              {"name", item.name},
              {"input_vertices", s.input_vertices},
              {"input_faces", s.input_faces},
              {"fitted_vertices", s.fitted_vertices},
              {"fitted_faces", s.fitted_faces},
              {"subdivision_levels", s.subdivision.levels},
              {"patches", s.clustering.num_patches},
              {"requested_patches", s.clustering.requested_patches},
              {"components", s.clustering.num_components},
              {"soup_fallback", s.clustering.soup_fallback},
              {"patch_area_min_rel", JsonNumber(s.clustering.min_relative_area)},
              {"patch_area_max_rel", JsonNumber(s.clustering.max_relative_area)},
              {"patch_area_std_rel", JsonNumber(s.clustering.relative_area_stddev)},
              {"cluster_iterations", s.clustering.iterations},
              {"not_height_field_patches", s.jet_fit.num_not_height_field},
              {"reduced_order_patches", s.jet_fit.num_reduced_order},
              {"read_s", JsonNumber(item.read_time_s)},
              {"subdivide_s", JsonNumber(s.subdivide_time_s)},
              {"cluster_s", JsonNumber(s.cluster_time_s)},
              {"fit_s", JsonNumber(s.fit_time_s)},
              {"reconstruct_s", JsonNumber(s.reconstruct_time_s)},
              {"time_s", JsonNumber(s.total_time_s)},
              {"chamfer", JsonNumber(s.chamfer)},
              {"chamfer_x1e3", JsonNumber(1e3 * s.chamfer)},
              {"chamfer_floor", JsonNumber(s.chamfer_floor)},
              {"surface_chamfer", JsonNumber(s.surface_chamfer)},
              {"height_rmse", JsonNumber(s.height_rmse)},
              {"normal_error_deg", JsonNumber(s.normal_error_deg)},
              {"mean_seam_gap", JsonNumber(s.reconstruction.mean_seam_gap)}};
}

void SummaryFromJson(const json& j, BatchFitItemSummary* item) {
  MeshFitSummary& s = item->summary;
  s.input_vertices = j.value("input_vertices", 0);
  s.input_faces = j.value("input_faces", 0);
  s.fitted_vertices = j.value("fitted_vertices", 0);
  s.fitted_faces = j.value("fitted_faces", 0);
  s.subdivision.levels = j.value("subdivision_levels", 0);
  s.clustering.num_patches = j.value("patches", 0);
  s.clustering.requested_patches = j.value("requested_patches", 0);
  s.clustering.num_components = j.value("components", 0);
  s.clustering.soup_fallback = j.value("soup_fallback", false);
  s.clustering.min_relative_area = NumberOr(j, "patch_area_min_rel");
  s.clustering.max_relative_area = NumberOr(j, "patch_area_max_rel");
  s.clustering.relative_area_stddev = NumberOr(j, "patch_area_std_rel");
  s.clustering.iterations = j.value("cluster_iterations", 0);
  s.jet_fit.num_not_height_field = j.value("not_height_field_patches", 0);
  s.jet_fit.num_reduced_order = j.value("reduced_order_patches", 0);
  item->read_time_s = NumberOr(j, "read_s");
  s.subdivide_time_s = NumberOr(j, "subdivide_s");
  s.cluster_time_s = NumberOr(j, "cluster_s");
  s.fit_time_s = NumberOr(j, "fit_s");
  s.reconstruct_time_s = NumberOr(j, "reconstruct_s");
  s.total_time_s = NumberOr(j, "time_s");
  s.chamfer = NumberOr(j, "chamfer");
  s.chamfer_floor = NumberOr(j, "chamfer_floor");
  s.surface_chamfer = NumberOr(j, "surface_chamfer");
  s.height_rmse = NumberOr(j, "height_rmse");
  s.normal_error_deg = NumberOr(j, "normal_error_deg");
  s.reconstruction.mean_seam_gap = NumberOr(j, "mean_seam_gap");
}

const char* StatusName(BatchItemStatus status) {
  switch (status) {
    case BatchItemStatus::kFitted: return "fitted";
    case BatchItemStatus::kSkipped: return "skipped";
    case BatchItemStatus::kFailed: return "failed";
  }
  return "?";
}

std::string CsvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string quoted = "\"";
  for (char c : s) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}

std::string CsvJsonNumber(double x) {
  if (!std::isfinite(x)) return "";
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.6g", x);
  return buffer;
}

// A distinct colour per patch (golden-ratio hues) for looking at patches.
Eigen::Matrix<std::uint8_t, 3, Eigen::Dynamic> PatchColours(const PolyFitModel& model) {
  Eigen::Matrix<std::uint8_t, 3, Eigen::Dynamic> colours(3, model.num_vertices());
  for (int v = 0; v < model.num_vertices(); ++v) {
    const double hue = std::fmod(model.owner(v) * 0.618033988749895, 1.0) * 6.0;
    const int sector = static_cast<int>(hue);
    const double f = hue - sector;
    const double s = 0.65, value = 0.95;
    const double p = value * (1 - s), q = value * (1 - s * f), t = value * (1 - s * (1 - f));
    // (r, g, b) per hue sector.
    const double rgb[6][3] = {{value, t, p}, {q, value, p}, {p, value, t}, {p, q, value}, {t, p, value}, {value, p, q}};
    const double r = rgb[sector % 6][0], g = rgb[sector % 6][1], b = rgb[sector % 6][2];
    colours.col(v) << static_cast<std::uint8_t>(255 * r), static_cast<std::uint8_t>(255 * g),
        static_cast<std::uint8_t>(255 * b);
  }
  return colours;
}

// An item with its status (and error): the reports' rows.
json ItemToJson(const BatchFitItemSummary& item) {
  json j =
      item.status == BatchItemStatus::kFailed ? json{{"input", item.input}, {"name", item.name}} : SummaryToJson(item);
  j["status"] = StatusName(item.status);
  if (!item.error.empty()) j["error"] = item.error;
  return j;
}

void WriteReports(const std::string& dir, const BatchFitSummary& summary) {
  WriteFileAtomically((fs::path(dir) / "report.csv").string(), [&](std::ostream& out) {
    out << "name,input,status,input_vertices,input_faces,fitted_faces,subdivision_levels,patches,"
           "time_s,cluster_s,fit_s,chamfer_x1e3,chamfer_floor_x1e3,surface_chamfer_x1e3,height_rmse,normal_error_deg,"
           "not_height_field_patches,error\n";
    for (const BatchFitItemSummary& item : summary.items) {
      const MeshFitSummary& s = item.summary;
      out << CsvField(item.name) << ',' << CsvField(item.input) << ',' << StatusName(item.status) << ','
          << s.input_vertices << ',' << s.input_faces << ',' << s.fitted_faces << ',' << s.subdivision.levels << ','
          << s.clustering.num_patches << ',' << CsvJsonNumber(s.total_time_s) << ',' << CsvJsonNumber(s.cluster_time_s)
          << ',' << CsvJsonNumber(s.fit_time_s) << ',' << CsvJsonNumber(1e3 * s.chamfer) << ','
          << CsvJsonNumber(1e3 * s.chamfer_floor) << ',' << CsvJsonNumber(1e3 * s.surface_chamfer) << ','
          << CsvJsonNumber(s.height_rmse) << ',' << CsvJsonNumber(s.normal_error_deg) << ','
          << s.jet_fit.num_not_height_field << ',' << CsvField(item.error) << '\n';
    }
  });
  json items = json::array();
  for (const BatchFitItemSummary& item : summary.items) items.push_back(ItemToJson(item));
  const json report = {
      {"fitted", summary.num_fitted},
      {"skipped", summary.num_skipped},
      {"failed", summary.num_failed},
      {"total_time_s", summary.total_time_s},
      {"chamfer_normalisation", "unit sphere of the input (bounding-box centre, farthest vertex at 1)"},
      {"meshes", items}};
  WriteFileAtomically((fs::path(dir) / "report.json").string(),
                      [&](std::ostream& out) { out << report.dump(1) << '\n'; });
}

}  // namespace

std::string BatchFitOptions::Validate() const {
  if (output_dir.empty()) return "output_dir is empty";
  if (std::string p = fit.Validate(); !p.empty()) return p;
  return {};
}

std::vector<std::string> ExpandMeshInputs(const std::vector<std::string>& inputs) {
  std::vector<std::string> files;
  for (const std::string& input : inputs) {
    std::error_code ec;
    if (fs::is_directory(input, ec)) {
      size_t before = files.size();
      for (const auto& entry : fs::directory_iterator(input, ec)) {
        if (entry.is_regular_file() && IsMeshFile(entry.path())) files.push_back(entry.path().string());
      }
      if (files.size() == before) throw std::invalid_argument(input + ": directory holds no mesh files");
    } else if (fs::exists(input, ec)) {
      files.push_back(input);
    } else {
      glob_t matches{};
      const int rc = ::glob(input.c_str(), 0, nullptr, &matches);
      size_t count = 0;
      if (rc == 0) {
        for (size_t i = 0; i < matches.gl_pathc; ++i) {
          if (fs::is_regular_file(matches.gl_pathv[i], ec)) {
            files.emplace_back(matches.gl_pathv[i]);
            ++count;
          }
        }
      }
      globfree(&matches);
      if (count == 0) throw std::invalid_argument(input + ": no such file, directory or matching files");
    }
  }
  std::sort(files.begin(), files.end());
  files.erase(std::unique(files.begin(), files.end()), files.end());
  return files;
}

BatchFitSummary PlanMeshFiles(const BatchFitOptions& options, const std::vector<std::string>& raw_inputs) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw std::invalid_argument("BatchFitOptions: " + problem);
  }
  const std::vector<std::string> inputs = ExpandMeshInputs(raw_inputs);
  BatchFitSummary summary;
  summary.items.resize(inputs.size());
  // Stems name the outputs; inputs sharing a stem (pig.off, pig.stl) keep
  // their extension in the name.
  std::map<std::string, int> stem_count;
  for (const std::string& input : inputs) ++stem_count[fs::path(input).stem().string()];
  std::map<std::string, std::string> names;
  for (size_t i = 0; i < inputs.size(); ++i) {
    BatchFitItemSummary& item = summary.items[i];
    item.input = inputs[i];
    const fs::path path(inputs[i]);
    item.name = path.stem().string();
    if (stem_count[item.name] > 1) {
      std::string ext = path.extension().string();
      if (!ext.empty()) item.name += "_" + ext.substr(1);
    }
    auto [it, inserted] = names.emplace(item.name, inputs[i]);
    if (!inserted) {
      throw std::invalid_argument("inputs " + it->second + " and " + inputs[i] + " would both write outputs named '" +
                                  item.name + "'; fit them into different output directories");
    }
  }
  std::error_code ec;
  fs::create_directories(options.output_dir, ec);
  if (!fs::is_directory(options.output_dir, ec)) {
    throw std::invalid_argument(options.output_dir + ": cannot create the output directory");
  }
  return summary;
}

void FitMeshFile(const BatchFitOptions& options, int num_threads, BatchFitItemSummary* item) {
  const fs::path stem = fs::path(options.output_dir) / item->name;
  const std::string model_path = stem.string() + ".pfm";
  const std::string recon_path = stem.string() + ".recon.ply";
  const std::string summary_path = stem.string() + ".summary.json";
  if (!options.force && fs::exists(summary_path) && fs::exists(model_path) && fs::exists(recon_path)) {
    try {
      std::ifstream in(summary_path);
      SummaryFromJson(json::parse(in), item);
      item->status = BatchItemStatus::kSkipped;
      return;
    } catch (const std::exception&) {
      // An unreadable summary: fit again.
    }
  }
  try {
    const auto read_start = std::chrono::steady_clock::now();
    const TriangleMesh mesh = ReadTriangleMesh(item->input);
    item->read_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - read_start).count();
    MeshFitOptions fit_options = options.fit;
    fit_options.num_threads = num_threads;
    PolyFitModel model;
    TriangleMesh reconstruction;
    item->summary = FitMesh(fit_options, mesh, &model, &reconstruction);
    SavePolyFitModel(model_path, model);
    const auto colours = PatchColours(model);
    WritePly(recon_path, reconstruction, &colours);
    const json j = SummaryToJson(*item);
    WriteFileAtomically(summary_path, [&](std::ostream& out) { out << j.dump(1) << '\n'; });
    item->status = BatchItemStatus::kFitted;
    item->error.clear();
  } catch (const std::exception& e) {
    item->status = BatchItemStatus::kFailed;
    item->error = e.what();
    if (item->error.find(item->input) == std::string::npos) item->error = item->input + ": " + item->error;
  }
}

void FinishMeshFiles(const BatchFitOptions& options, BatchFitSummary* summary) {
  summary->num_fitted = summary->num_skipped = summary->num_failed = 0;
  for (const BatchFitItemSummary& item : summary->items) {
    summary->num_fitted += item.status == BatchItemStatus::kFitted;
    summary->num_skipped += item.status == BatchItemStatus::kSkipped;
    summary->num_failed += item.status == BatchItemStatus::kFailed;
  }
  WriteReports(options.output_dir, *summary);
}

std::string BatchItemToJson(const BatchFitItemSummary& item) { return ItemToJson(item).dump(); }

BatchFitItemSummary BatchItemFromJson(const std::string& text) {
  const json j = json::parse(text);
  BatchFitItemSummary item;
  item.input = j.value("input", "");
  item.name = j.value("name", "");
  item.error = j.value("error", "");
  const std::string status = j.value("status", "failed");
  item.status = status == "fitted"    ? BatchItemStatus::kFitted
                : status == "skipped" ? BatchItemStatus::kSkipped
                                      : BatchItemStatus::kFailed;
  if (item.status != BatchItemStatus::kFailed) SummaryFromJson(j, &item);
  return item;
}

BatchFitSummary FitMeshFiles(const BatchFitOptions& options, const std::vector<std::string>& raw_inputs,
                             const BatchProgressCallback& progress) {
  const auto start = std::chrono::steady_clock::now();
  BatchFitSummary summary = PlanMeshFiles(options, raw_inputs);
  const int num_inputs = static_cast<int>(summary.items.size());
  const int threads = ResolveNumThreads(options.num_threads);
  const bool across_inputs = num_inputs > 1 && threads > 1;
  std::mutex progress_mutex;
  int done = 0;
  auto process = [&](int, int i) {
    FitMeshFile(options, across_inputs ? 1 : threads, &summary.items[i]);
    std::lock_guard<std::mutex> lock(progress_mutex);
    ++done;
    if (progress) progress(done, num_inputs, summary.items[i]);
  };
  ParallelFor(num_inputs, across_inputs ? threads : 1, process, 1);
  summary.total_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  FinishMeshFiles(options, &summary);
  return summary;
}

}  // namespace polyfit
