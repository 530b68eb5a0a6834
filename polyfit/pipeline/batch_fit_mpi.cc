#include "polyfit/pipeline/batch_fit_mpi.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "polyfit/util/status.h"

namespace polyfit {
namespace {

// The next input's index from a counter held by rank 0 (every rank, rank 0
// included, draws from it until the batch is exhausted).
class SharedCounter {
 public:
  explicit SharedCounter(MPI_Comm comm) {
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    MPI_Win_allocate(rank == 0 ? sizeof(long long) : 0, sizeof(long long), MPI_INFO_NULL, comm, &base_, &window_);
    if (rank == 0) {
      MPI_Win_lock(MPI_LOCK_EXCLUSIVE, 0, 0, window_);
      *base_ = 0;
      MPI_Win_unlock(0, window_);
    }
    MPI_Barrier(comm);
  }
  ~SharedCounter() { MPI_Win_free(&window_); }
  SharedCounter(const SharedCounter&) = delete;
  SharedCounter& operator=(const SharedCounter&) = delete;

  long long Next() {
    const long long one = 1;
    long long value = 0;
    MPI_Win_lock(MPI_LOCK_SHARED, 0, 0, window_);
    MPI_Fetch_and_op(&one, &value, MPI_LONG_LONG, 0, 0, MPI_SUM, window_);
    MPI_Win_unlock(0, window_);
    return value;
  }

 private:
  long long* base_ = nullptr;
  MPI_Win window_;
};

// Hardware threads shared among the ranks on this node.
int ThreadsPerRank(const BatchFitOptions& options, MPI_Comm comm) {
  if (options.num_threads > 0) return options.num_threads;
  MPI_Comm node;
  MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  int ranks_on_node = 1;
  MPI_Comm_size(node, &ranks_on_node);
  MPI_Comm_free(&node);
  const int hardware = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return std::max(1, hardware / ranks_on_node);
}

// Gathers every rank's "index json" lines on rank 0.
std::string GatherLines(const std::string& mine, int rank, int num_ranks, MPI_Comm comm) {
  const int length = static_cast<int>(mine.size());
  std::vector<int> lengths(rank == 0 ? num_ranks : 0), offsets(rank == 0 ? num_ranks : 0);
  MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0, comm);
  std::string all;
  if (rank == 0) {
    int total = 0;
    for (int r = 0; r < num_ranks; ++r) {
      offsets[r] = total;
      total += lengths[r];
    }
    all.resize(total);
  }
  MPI_Gatherv(mine.data(), length, MPI_CHAR, all.data(), lengths.data(), offsets.data(), MPI_CHAR, 0, comm);
  return all;
}

}  // namespace

MpiBatchSummary FitMeshFilesMpi(const BatchFitOptions& options, const std::vector<std::string>& inputs, MPI_Comm comm,
                                const BatchProgressCallback& progress) {
  const auto start = std::chrono::steady_clock::now();
  MpiBatchSummary result;
  MPI_Comm_rank(comm, &result.rank);
  MPI_Comm_size(comm, &result.num_ranks);
  BatchFitSummary planned = PlanMeshFiles(options, inputs);  // the same on every rank
  const int num_inputs = static_cast<int>(planned.items.size());
  result.threads_per_rank = ThreadsPerRank(options, comm);

  // Phase 1: draw and fit inputs until none is left.
  std::ostringstream mine;
  std::vector<int> processed;
  {
    SharedCounter counter(comm);
    for (long long i = counter.Next(); i < num_inputs; i = counter.Next()) {
      BatchFitItemSummary& item = planned.items[i];
      FitMeshFile(options, result.threads_per_rank, &item);
      processed.push_back(static_cast<int>(i));
      mine << i << ' ' << BatchItemToJson(item) << '\n';
      if (progress) progress(static_cast<int>(processed.size()), num_inputs, item);
    }
  }
  result.num_processed = static_cast<int>(processed.size());

  // Phase 2: rank 0 gathers the items and writes the reports; the others
  // learn the counts, or that the reports could not be written.
  const std::string all = GatherLines(mine.str(), result.rank, result.num_ranks, comm);
  int counts[4] = {0, 0, 0, 0};  // fitted, skipped, failed, reports not written
  std::exception_ptr report_error;
  if (result.rank == 0) {
    std::istringstream lines(all);
    std::string line;
    while (std::getline(lines, line)) {
      const size_t space = line.find(' ');
      const int i = std::stoi(line.substr(0, space));
      BatchFitItemSummary item = BatchItemFromJson(line.substr(space + 1));
      item.input = planned.items[i].input;
      planned.items[i] = std::move(item);
    }
    planned.total_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    try {
      FinishMeshFiles(options, &planned);
    } catch (...) {
      report_error = std::current_exception();
      counts[3] = 1;
    }
    counts[0] = planned.num_fitted;
    counts[1] = planned.num_skipped;
    counts[2] = planned.num_failed;
    result.batch = std::move(planned);
  } else {
    for (int i : processed) result.batch.items.push_back(planned.items[i]);
  }
  MPI_Bcast(counts, 4, MPI_INT, 0, comm);
  if (report_error) std::rethrow_exception(report_error);
  if (counts[3] != 0) {
    throw Error(ErrorKind::kOutput, options.output_dir + ": rank 0 could not write report.csv / report.json");
  }
  result.batch.num_fitted = counts[0];
  result.batch.num_skipped = counts[1];
  result.batch.num_failed = counts[2];
  result.batch.total_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace polyfit
