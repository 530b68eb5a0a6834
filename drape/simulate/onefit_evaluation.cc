#include "drape/simulate/onefit_evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <limits>

#include "drape/render/line_plot.h"
#include "drape/render/mesh_render.h"
#include "polyfit/util/atomic_file.h"

namespace polyfit {
namespace {

// The re-solve's carry as the command line takes it (0.95, 0, 1).
std::string FormatCarry(double carry) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", carry);
  return text;
}

namespace fs = std::filesystem;

enum class Drape { kReference, kNetwork, kNetworkAsPredicted };

// A drape into its own folder, keeping its garments for the comparison:
// the reference drape, the network's, or the network's without its
// relaxation.
DrapeSimulationSummary RunDrape(const OneFitEvaluationOptions& options, Drape drape) {
  const bool network = drape != Drape::kReference;
  const char* folder = drape == Drape::kReference ? "reference"
                       : drape == Drape::kNetwork ? "network"
                                                  : "network_predicted";
  DrapeSimulationOptions o = options.simulation;
  o.out_dir = (fs::path(options.simulation.out_dir) / folder).string();
  o.keep_positions = true;
  if (drape == Drape::kNetworkAsPredicted) o.relax_passes = 0;
  if (network) {
    o.project_offset = options.project_offset;
    o.strain_limit_passes = options.strain_limit_passes;
  } else {
    o.model_path.clear();
    o.warp_sweeps = 0;
    o.warp_translations = false;
    o.project_offset = -1.0;
  }
  return RunDrapeSimulation(o);
}

// Per frame t >= 2, the mean over vertices of |x_t - 2 x_(t-1) + x_(t-2)| (mm); NaN before.
std::vector<double> Jitter(const std::vector<Eigen::Matrix3Xd>& positions) {
  std::vector<double> jitter(positions.size(), std::numeric_limits<double>::quiet_NaN());
  for (size_t t = 2; t < positions.size(); ++t) {
    jitter[t] = 1e3 * (positions[t] - 2.0 * positions[t - 1] + positions[t - 2]).colwise().norm().mean();
  }
  return jitter;
}

double FiniteMean(const std::vector<double>& values) {
  double sum = 0.0;
  int count = 0;
  for (double v : values) {
    if (std::isfinite(v)) sum += v, ++count;
  }
  return count > 0 ? sum / count : std::numeric_limits<double>::quiet_NaN();
}

// Per frame (of the shorter), the mean over vertices of |a_t - b_t| (mm).
std::vector<double> DistancesMm(const std::vector<Eigen::Matrix3Xd>& a, const std::vector<Eigen::Matrix3Xd>& b) {
  std::vector<double> distance;
  for (size_t t = 0; t < std::min(a.size(), b.size()); ++t) {
    distance.push_back(1e3 * (a[t] - b[t]).colwise().norm().mean());
  }
  return distance;
}

// A row's distance to the reference drape: the mean and worst frame of
// `distance` (mm per frame).
void SetDistanceToReference(const std::vector<double>& distance, OneFitEvaluationRow* row) {
  row->distance_to_reference_mm = FiniteMean(distance);
  row->max_distance_to_reference_mm = distance.empty() ? 0.0 : *std::max_element(distance.begin(), distance.end());
}

OneFitEvaluationRow Summarize(const std::string& name, const DrapeSimulationSummary& drape,
                              const std::vector<double>& jitter) {
  OneFitEvaluationRow row;
  row.name = name;
  const double n = static_cast<double>(std::max<size_t>(drape.records.size(), 1));
  for (const DrapeFrameSummary& r : drape.records) {
    row.inside_percent += r.inside_unprojected_percent / n;
    row.inside_projected_percent += r.inside_percent / n;
    row.inside_area_percent += r.inside_area_percent / n;
    row.edge_strain_percent += r.edge_strain_percent / n;
    row.edge_strain_raw_percent += r.edge_strain_unprojected_percent / n;
    row.area_change_percent += r.area_change_percent / n;
    row.ms_per_frame += 1e3 * r.time_s / n;
  }
  row.jitter_mm = FiniteMean(jitter);
  return row;
}

// predicted (or null): the network's drape without its relaxation.
void WriteReport(const OneFitEvaluationOptions& options, const OneFitEvaluationSummary& summary,
                 const DrapeSimulationSummary& reference, const DrapeSimulationSummary& network,
                 const DrapeSimulationSummary* predicted, const std::vector<double>& reference_jitter,
                 const std::vector<double>& network_jitter) {
  const fs::path out(options.simulation.out_dir);
  WriteFileAtomically((out / "eval.csv").string(), [&](std::ostream& csv) {
    csv << "frame,reference_inside_percent,network_inside_percent,network_projected_inside_percent,"
           "reference_inside_area_percent,network_inside_area_percent,"
           "reference_edge_strain_percent,network_edge_strain_percent,reference_area_change_percent,"
           "network_area_change_percent,distance_to_reference_mm,reference_jitter_mm,network_jitter_mm,"
           "reference_ms,network_ms,network_edge_strain_raw_percent\n";
    csv << std::setprecision(6);
    for (size_t t = 0; t < summary.frame_numbers.size(); ++t) {
      const DrapeFrameSummary &r = reference.records[t], &k = network.records[t];
      csv << summary.frame_numbers[t] << ',' << r.inside_percent << ',' << k.inside_unprojected_percent << ','
          << k.inside_percent << ',' << r.inside_area_percent << ',' << k.inside_area_percent << ','
          << r.edge_strain_percent << ',' << k.edge_strain_percent << ',' << r.area_change_percent << ','
          << k.area_change_percent << ',' << summary.distance_mm[t] << ',' << reference_jitter[t] << ','
          << network_jitter[t] << ',' << 1e3 * r.time_s << ',' << 1e3 * k.time_s << ','
          << k.edge_strain_unprojected_percent << '\n';
    }
  });
  WriteFileAtomically((out / "eval.md").string(), [&](std::ostream& md) { md << summary.Table(); });
  std::vector<double> x(summary.frame_numbers.begin(), summary.frame_numbers.end());
  const auto column = [](const DrapeSimulationSummary& s, double DrapeFrameSummary::*field) {
    std::vector<double> values;
    for (const DrapeFrameSummary& r : s.records) values.push_back(r.*field);
    return values;
  };
  const cv::Scalar grey(90, 90, 90), blue(200, 110, 30), orange(30, 140, 240), red(40, 40, 200);
  std::vector<PlotPanel> panels = {
      {"epsilon_c (% inside)",
       {{"reference", column(reference, &DrapeFrameSummary::inside_percent), grey},
        {"network", column(network, &DrapeFrameSummary::inside_unprojected_percent), blue},
        {"network + post", column(network, &DrapeFrameSummary::inside_percent), orange}}},
      {"epsilon_e (% edge change)",
       {{"reference", column(reference, &DrapeFrameSummary::edge_strain_percent), grey},
        {"network", column(network, &DrapeFrameSummary::edge_strain_unprojected_percent), blue},
        {"network + post", column(network, &DrapeFrameSummary::edge_strain_percent), orange}}},
      {"distance to the reference (mm)", {{"network + post", summary.distance_mm, orange}}},
      {"jitter (mm)", {{"reference", reference_jitter, grey}, {"network + post", network_jitter, orange}}}};
  if (predicted != nullptr) {
    panels[0].series.push_back(
        {"as predicted", column(*predicted, &DrapeFrameSummary::inside_unprojected_percent), red});
    panels[1].series.push_back(
        {"as predicted", column(*predicted, &DrapeFrameSummary::edge_strain_unprojected_percent), red});
  }
  WriteImage((out / "eval.png").string(), DrawLinePlot(x, panels));
}

}  // namespace

std::string OneFitEvaluationOptions::Validate() const {
  if (simulation.model_path.empty()) return "a model is needed";
  if (simulation.out_dir.empty()) return "an output folder is needed";
  if (!(project_offset >= 0.0) || !std::isfinite(project_offset)) return "project_offset must be >= 0";
  if (strain_limit_passes < 0) return "strain_limit_passes must be >= 0";
  return simulation.Validate();
}

std::string OneFitEvaluationSummary::Table() const {
  std::string table =
      "| drape | eps_c % | eps_c % post | eps_c % area | eps_e % | eps_a % | to reference mm (max frame) | jitter mm | "
      "ms / frame | eps_e % raw |\n"
      "|---|---:|---:|---:|---:|---:|---|---:|---:|---:|\n";
  std::vector<const OneFitEvaluationRow*> rows = {&reference};
  if (has_predicted) rows.push_back(&predicted);
  rows.push_back(&network);
  for (const OneFitEvaluationRow* row : rows) {
    char line[512];
    std::snprintf(line, sizeof(line), "| %s | %.2f | %.2f | %.2f | %.2f | %.2f | %.1f (%.1f) | %.2f | %.3g | %.2f |\n",
                  row->name.c_str(), row->inside_percent, row->inside_projected_percent, row->inside_area_percent,
                  row->edge_strain_percent, row->area_change_percent, row->distance_to_reference_mm,
                  row->max_distance_to_reference_mm, row->jitter_mm, row->ms_per_frame, row->edge_strain_raw_percent);
    table += line;
  }
  return table;
}

std::string OneFitEvaluationSummary::BriefReport() const {
  char line[512];
  std::snprintf(
      line, sizeof(line),
      "%s: %d frames, %d vertices; network eps_c %.2f%% (%.2f%% post) eps_e %.2f%% (%.2f%% raw), %.3g ms/frame; "
      "reference eps_c %.2f%% eps_e %.2f%%, %.3g ms/frame; network to reference %.1f mm",
      TerminationTypeToString(termination_type), frames, garment_vertices, network.inside_percent,
      network.inside_projected_percent, network.edge_strain_percent, network.edge_strain_raw_percent,
      network.ms_per_frame, reference.inside_percent, reference.edge_strain_percent, reference.ms_per_frame,
      network.distance_to_reference_mm);
  std::string report = line;
  if (!message.empty()) report += " (" + message + ")";
  return report;
}

OneFitEvaluationSummary EvaluateOneFitModel(const OneFitEvaluationOptions& options) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw Error(ErrorKind::kInvalidArgument, "onefit eval: " + problem);
  }
  // The network first: a bad model fails before the long reference drape.
  const DrapeSimulationSummary network = RunDrape(options, Drape::kNetwork);
  const DrapeSimulationSummary reference = RunDrape(options, Drape::kReference);
  OneFitEvaluationSummary summary;
  summary.frames = static_cast<int>(std::min(network.records.size(), reference.records.size()));
  summary.garment_vertices = network.garment_vertices;
  for (int t = 0; t < summary.frames; ++t) summary.frame_numbers.push_back(network.records[t].frame);
  summary.distance_mm = DistancesMm(network.positions, reference.positions);
  const std::vector<double> reference_jitter = Jitter(reference.positions), network_jitter = Jitter(network.positions);
  summary.reference = Summarize("reference drape", reference, reference_jitter);
  const int refine = options.simulation.refine_iterations, sweeps = options.simulation.warp_sweeps;
  const std::string name = refine > 0   ? "network + " + std::to_string(refine) + " LM iterations"
                           : sweeps > 0 ? std::string("network + warps ") +
                                              (options.simulation.warp_translations ? "and translations " : "") +
                                              "re-solved (" + std::to_string(sweeps) + " sweeps, carry " +
                                              FormatCarry(options.simulation.warp_carry) + ")"
                                        : std::string("network");
  const int relax = refine > 0 || sweeps > 0 ? 0 : options.simulation.relax_passes;
  summary.network =
      Summarize(relax > 0 ? name + ", relaxed (" + std::to_string(relax) + " passes)" : name, network, network_jitter);
  SetDistanceToReference(summary.distance_mm, &summary.network);
  DrapeSimulationSummary predicted;
  if (relax > 0) {
    // The network alone beside it: what the relaxation changes.
    predicted = RunDrape(options, Drape::kNetworkAsPredicted);
    summary.has_predicted = true;
    summary.predicted = Summarize("the network as predicted (`--relax 0`)", predicted, Jitter(predicted.positions));
    SetDistanceToReference(DistancesMm(predicted.positions, reference.positions), &summary.predicted);
  }
  summary.termination_type =
      (network.termination_type == TerminationType::kFailure || reference.termination_type == TerminationType::kFailure)
          ? TerminationType::kFailure
          : TerminationType::kConvergence;
  if (!network.all_finite) summary.message = "the network predicted non-finite frames";
  WriteReport(options, summary, reference, network, summary.has_predicted ? &predicted : nullptr, reference_jitter,
              network_jitter);
  return summary;
}

}  // namespace polyfit
