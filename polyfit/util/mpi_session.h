// MPI for the command lines (`mpirun -n N polyfit fit`, `mpirun -n N
// onefit train`). Include only where POLYFIT_WITH_MPI is defined: the
// libraries never need MPI.
#ifndef POLYFIT_UTIL_MPI_SESSION_H_
#define POLYFIT_UTIL_MPI_SESSION_H_

#include <mpi.h>

#include <cstdlib>

#include "polyfit/util/status.h"

namespace polyfit {

// Started by mpirun or srun (Open MPI, MPICH's PMI and PMIx set these):
// started alone, a program runs as it does without MPI.
inline bool LaunchedByMpi() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"}) {
    if (std::getenv(name) != nullptr) return true;
  }
  return false;
}

// MPI_Init to MPI_Finalize over MPI_COMM_WORLD.
class MpiSession {
 public:
  MpiSession() {
    MPI_Init(nullptr, nullptr);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  ~MpiSession() {
    if (!aborted_) MPI_Finalize();
  }
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }

  // RunReportingErrors on every rank; an error (exit codes 1 to 4: what a
  // rank may meet alone, while the others wait in a collective) aborts the
  // whole job with its code.
  template <typename Body>
  int Run(const char* program, Body&& body) {
    const int code = RunReportingErrors(program, body);
    if (code >= kExitFailure && code <= kExitOutputError) {
      aborted_ = true;
      MPI_Abort(MPI_COMM_WORLD, code);
    }
    return code;
  }

 private:
  int rank_ = 0;
  int size_ = 1;
  bool aborted_ = false;
};

}  // namespace polyfit

#endif  // POLYFIT_UTIL_MPI_SESSION_H_
