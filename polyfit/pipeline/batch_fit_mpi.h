// FitMeshFiles shared over the ranks of an MPI job (`mpirun -n N polyfit
// fit ...`): every rank plans the same batch, then takes inputs one at a
// time from a counter on rank 0 (MPI_Fetch_and_op: dynamic load
// balancing, since meshes differ a lot in size), fits them and writes
// their outputs atomically, as FitMeshFiles does; rank 0 then gathers every
// item and writes report.csv and report.json. Resumable across any number
// of ranks: inputs whose outputs exist are skipped. Built only with MPI
// (POLYFIT_WITH_MPI); the library itself never needs it.
#ifndef POLYFIT_PIPELINE_BATCH_FIT_MPI_H_
#define POLYFIT_PIPELINE_BATCH_FIT_MPI_H_

#include <mpi.h>

#include <string>
#include <vector>

#include "polyfit/pipeline/batch_fit.h"

namespace polyfit {

struct MpiBatchSummary {
  // On rank 0 every item; on the others those this rank fitted or skipped.
  // The counts are the whole batch's on every rank.
  BatchFitSummary batch;
  int rank = 0;
  int num_ranks = 1;
  int threads_per_rank = 1;
  // Inputs this rank processed.
  int num_processed = 0;
};

// Collective over `comm`. options.num_threads = 0 gives each rank the
// hardware threads of its node shared among the node's ranks. progress is
// called on each rank for its own items (done counts them). Throws like
// FitMeshFiles (the same on every rank, before any fitting).
MpiBatchSummary FitMeshFilesMpi(const BatchFitOptions& options, const std::vector<std::string>& inputs, MPI_Comm comm,
                                const BatchProgressCallback& progress = nullptr);

}  // namespace polyfit

#endif  // POLYFIT_PIPELINE_BATCH_FIT_MPI_H_
