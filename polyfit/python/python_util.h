// What the Python modules (_core, _sft, _drape) share: NumPy arrays to
// and from PolyFit's Eigen storage, JSON settings, copyable options.
//
// PolyFit stores points as 3 by N column-major matrices: in memory that is
// exactly NumPy's C-ordered N by 3 array, so points cross without a copy in
// both directions. Python sees rows (N by 3, the convention of NumPy and
// trimesh); C++ keeps its columns.
#ifndef POLYFIT_PYTHON_PYTHON_UTIL_H_
#define POLYFIT_PYTHON_PYTHON_UTIL_H_

#include <exception>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

namespace polyfit::python {

namespace py = pybind11;

template <typename Scalar>
using CArray = py::array_t<Scalar, py::array::c_style | py::array::forcecast>;

// The C-ordered (#cols by rows) view of a column-major matrix that `owner`
// keeps alive (the Python object holding it): no copy.
template <typename Matrix>
py::array ColumnsAsRows(Matrix& matrix, py::handle owner) {
  using Scalar = typename Matrix::Scalar;
  const py::ssize_t rows = matrix.rows();
  return py::array_t<Scalar>({py::ssize_t(matrix.cols()), rows},
                             {py::ssize_t(rows * sizeof(Scalar)), py::ssize_t(sizeof(Scalar))}, matrix.data(), owner);
}

// The same for a matrix the caller gives away: the array owns it.
template <typename Matrix>
py::array ColumnsAsRows(Matrix&& matrix) {
  auto* owned = new Matrix(std::move(matrix));
  py::capsule owner(owned, [](void* p) { delete static_cast<Matrix*>(p); });
  return ColumnsAsRows(*owned, owner);
}

// A vector's values as a 1-D array that owns them.
template <typename Scalar>
py::array_t<Scalar> VectorToArray(std::vector<Scalar> values) {
  auto* owned = new std::vector<Scalar>(std::move(values));
  py::capsule owner(owned, [](void* p) { delete static_cast<std::vector<Scalar>*>(p); });
  return py::array_t<Scalar>({py::ssize_t(owned->size())}, {py::ssize_t(sizeof(Scalar))}, owned->data(), owner);
}

// Checks that `array` is #rows by `width` (1-D accepted for width 1) and
// returns its row count; ValueError naming `name` otherwise.
template <typename Scalar>
py::ssize_t CheckRows(const CArray<Scalar>& array, py::ssize_t width, const char* name) {
  const bool ok = (array.ndim() == 2 && array.shape(1) == width) || (width == 1 && array.ndim() == 1);
  if (!ok) {
    throw py::value_error(std::string(name) + ": expected an array of shape (N, " + std::to_string(width) + "), got " +
                          std::to_string(array.ndim()) + " dimensions" +
                          (array.ndim() >= 2 ? " with " + std::to_string(array.shape(1)) + " columns" : ""));
  }
  return array.shape(0);
}

// The (N, rows) C-ordered array as a rows by N column-major map: no copy;
// valid while `array` lives.
template <int Rows, typename Scalar>
Eigen::Map<const Eigen::Matrix<Scalar, Rows, Eigen::Dynamic>> RowsAsColumns(const CArray<Scalar>& array,
                                                                            const char* name) {
  const py::ssize_t n = CheckRows(array, Rows, name);
  return {array.data(), Rows, Eigen::Index(n)};
}

// JSON (settings, metrics) to Python objects and back: objects become
// dicts, arrays lists.
inline py::object JsonToPython(const nlohmann::json& value) {
  switch (value.type()) {
    case nlohmann::json::value_t::object: {
      py::dict d;
      for (const auto& [key, item] : value.items()) d[py::str(key)] = JsonToPython(item);
      return std::move(d);
    }
    case nlohmann::json::value_t::array: {
      py::list l;
      for (const auto& item : value) l.append(JsonToPython(item));
      return std::move(l);
    }
    case nlohmann::json::value_t::string: return py::str(value.get<std::string>());
    case nlohmann::json::value_t::boolean: return py::bool_(value.get<bool>());
    case nlohmann::json::value_t::number_integer: return py::int_(value.get<long long>());
    case nlohmann::json::value_t::number_unsigned: return py::int_(value.get<unsigned long long>());
    case nlohmann::json::value_t::number_float: return py::float_(value.get<double>());
    default: return py::none();
  }
}

inline nlohmann::json PythonToJson(py::handle value) {
  if (value.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>();
  if (py::isinstance<py::int_>(value)) return value.cast<long long>();
  if (py::isinstance<py::float_>(value)) return value.cast<double>();
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::isinstance<py::dict>(value)) {
    nlohmann::json object = nlohmann::json::object();
    for (const auto& [key, item] : value.cast<py::dict>())
      object[py::str(key).cast<std::string>()] = PythonToJson(item);
    return object;
  }
  if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value)) {
    nlohmann::json array = nlohmann::json::array();
    for (const auto& item : value) array.push_back(PythonToJson(item));
    return array;
  }
  // NumPy scalars and anything else with a float value.
  if (py::hasattr(value, "__float__")) return value.cast<double>();
  throw py::type_error("cannot pass a " + std::string(py::str(value.get_type())) + " as a setting");
}

// A Python callable as a C++ callback that runs while the GIL is released
// (on the calling thread or a worker): each call takes the GIL back; the
// first exception the callable raises is kept, later calls are skipped, and
// Rethrow() raises it once the C++ call has returned, so that it never
// unwinds through C++ mid-write.
template <typename... Args>
class DeferredCallback {
 public:
  explicit DeferredCallback(py::object callable) : callable_(std::move(callable)) {}

  // Empty for None (the C++ side then calls nothing).
  std::function<void(Args...)> Function() {
    if (callable_.is_none()) return nullptr;
    return [this](Args... args) {
      py::gil_scoped_acquire acquire;
      if (error_) return;
      try {
        callable_(args...);
      } catch (...) {
        error_ = std::current_exception();
      }
    };
  }
  bool failed() const { return static_cast<bool>(error_); }
  void Rethrow() const {
    if (error_) std::rethrow_exception(error_);
  }

 private:
  py::object callable_;
  std::exception_ptr error_;
};

// Lets options be copied from Python (copy.copy, copy.deepcopy).
template <typename Class>
void AddCopy(Class& c) {
  using T = typename Class::type;
  c.def("__copy__", [](const T& self) { return T(self); });
  c.def(
      "__deepcopy__", [](const T& self, py::dict) { return T(self); }, py::arg("memo"));
}

}  // namespace polyfit::python

#endif  // POLYFIT_PYTHON_PYTHON_UTIL_H_
