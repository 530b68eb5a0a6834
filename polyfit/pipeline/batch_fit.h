// Fitting many mesh files: inputs expanded from files, directories and
// globs, fitted in parallel, written to one output directory, resumable.
#ifndef POLYFIT_PIPELINE_BATCH_FIT_H_
#define POLYFIT_PIPELINE_BATCH_FIT_H_

#include <functional>
#include <string>
#include <vector>

#include "polyfit/pipeline/fit_mesh.h"

namespace polyfit {

struct BatchFitOptions {
  MeshFitOptions fit;
  std::string output_dir;
  // Refit inputs whose outputs already exist.
  bool force = false;
  // 0: all hardware threads. Several inputs are fitted side by side, one
  // thread each; a single input gets every thread.
  int num_threads = 0;

  std::string Validate() const;
};

enum class BatchItemStatus { kFitted, kSkipped, kFailed };

struct BatchFitItemSummary {
  std::string input;
  // Output stem: <name>.pfm, <name>.recon.ply, <name>.summary.json. The
  // input's stem, with its extension (pig_off) when two inputs share a stem.
  std::string name;
  BatchItemStatus status = BatchItemStatus::kFailed;
  // Why it failed (names the file).
  std::string error;
  double read_time_s = 0.0;
  MeshFitSummary summary;
};

struct BatchFitSummary {
  std::vector<BatchFitItemSummary> items;
  int num_fitted = 0;
  int num_skipped = 0;
  int num_failed = 0;
  double total_time_s = 0.0;
};

// Called after each input, from the thread that fitted it but never from
// two threads at once.
using BatchProgressCallback = std::function<void(int done, int total, const BatchFitItemSummary& item)>;

// Files as they are; directories give their mesh files (obj, ply, off,
// stl, gltf, glb; not recursive); anything else is a glob pattern. Sorted,
// duplicates removed. Throws std::invalid_argument naming an input that
// matches nothing.
std::vector<std::string> ExpandMeshInputs(const std::vector<std::string>& inputs);

// Fits every input, writing per input <name>.pfm (the model),
// <name>.recon.ply and <name>.summary.json (written last: its presence
// marks the input done), and per run report.csv and report.json covering
// every input, skipped ones included. A failing input is reported and the
// others go on. Throws std::invalid_argument on invalid options, inputs or
// clashing output names.
BatchFitSummary FitMeshFiles(const BatchFitOptions& options, const std::vector<std::string>& inputs,
                             const BatchProgressCallback& progress = nullptr);

// The phases of FitMeshFiles, for drivers that share a batch over
// processes (batch_fit_mpi.h). PlanMeshFiles expands and names the inputs
// and creates the output directory (throws as FitMeshFiles does).
// FitMeshFile fits one planned item with num_threads threads, or skips it
// when its outputs exist, writing them atomically; a bad input marks the
// item failed, never throws. FinishMeshFiles counts the statuses and writes
// report.csv and report.json (set total_time_s first).
BatchFitSummary PlanMeshFiles(const BatchFitOptions& options, const std::vector<std::string>& inputs);
void FitMeshFile(const BatchFitOptions& options, int num_threads, BatchFitItemSummary* item);
void FinishMeshFiles(const BatchFitOptions& options, BatchFitSummary* summary);

// An item (status, error, the summary's reported fields) as one line of
// JSON and back: the report's row, and what ranks send to the one that
// writes the report.
std::string BatchItemToJson(const BatchFitItemSummary& item);
BatchFitItemSummary BatchItemFromJson(const std::string& text);

}  // namespace polyfit

#endif  // POLYFIT_PIPELINE_BATCH_FIT_H_
