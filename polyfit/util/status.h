// What every PolyFit entry point shares: how a solve ended (a Summary's
// termination_type, as Ceres' Solver::Summary), the one error class that
// library calls throw for bad input and unwritable output, and the exit
// codes of the three command lines (README, "Exit codes").
#ifndef POLYFIT_UTIL_STATUS_H_
#define POLYFIT_UTIL_STATUS_H_

#include <iostream>
#include <stdexcept>
#include <string>

namespace polyfit {

enum class TerminationType {
  kConvergence,    // the solver met its tolerances (or its own stopping rule)
  kNoConvergence,  // the iteration or time budget ran out; the result is usable
  kFailure         // no usable result (non-finite values, a diverged solve)
};

inline const char* TerminationTypeToString(TerminationType type) {
  switch (type) {
    case TerminationType::kConvergence: return "CONVERGENCE";
    case TerminationType::kNoConvergence: return "NO_CONVERGENCE";
    case TerminationType::kFailure: return "FAILURE";
  }
  return "UNKNOWN";
}

enum class ErrorKind {
  kInvalidArgument,  // options or arguments out of range
  kInput,            // a file or key that cannot be read or is malformed
  kOutput,           // an output that cannot be written
};

inline const char* ErrorKindToString(ErrorKind kind) {
  switch (kind) {
    case ErrorKind::kInvalidArgument: return "invalid argument";
    case ErrorKind::kInput: return "input error";
    case ErrorKind::kOutput: return "output error";
  }
  return "error";
}

// The base of every error PolyFit throws for what its caller gave it; the
// message names the file, key or option. Subsystems derive their own
// (MeshIoError, SceneError, ...) so that callers may catch narrowly.
class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  ErrorKind kind() const { return kind_; }

 private:
  ErrorKind kind_;
};

// Exit codes of polyfit, polysft and onefit.
enum ExitCode : int {
  kExitSuccess = 0,
  kExitFailure = 1,        // an unexpected error (a bug: please report it)
  kExitUsage = 2,          // bad command line or invalid options
  kExitInputError = 3,     // an input file or key cannot be used
  kExitOutputError = 4,    // an output cannot be written
  kExitSolverFailure = 5,  // the solver found no usable result (outputs say how far it got)
  kExitPartial = 6         // a batch finished, but some of its items failed
};

inline int ExitCodeFor(ErrorKind kind) {
  switch (kind) {
    case ErrorKind::kInvalidArgument: return kExitUsage;
    case ErrorKind::kInput: return kExitInputError;
    case ErrorKind::kOutput: return kExitOutputError;
  }
  return kExitFailure;
}

// Runs a command line's body (returning its exit code) and maps what it
// throws to the codes above, printing "program: message" on stderr.
template <typename Body>
int RunReportingErrors(const char* program, Body&& body) {
  try {
    return body();
  } catch (const Error& e) {
    std::cerr << program << ": " << e.what() << '\n';
    return ExitCodeFor(e.kind());
  } catch (const std::invalid_argument& e) {
    std::cerr << program << ": " << e.what() << '\n';
    return kExitUsage;
  } catch (const std::exception& e) {
    std::cerr << program << ": " << e.what() << '\n';
    return kExitFailure;
  }
}

}  // namespace polyfit

#endif  // POLYFIT_UTIL_STATUS_H_
