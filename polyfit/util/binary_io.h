// Binary files built and read back field by field (the .pfm and .pfonefit
// formats): little-endian as the machine writes it, no padding. The reader
// checks every read against the bytes left, so that a truncated file or an
// impossible size is named (ErrorType(path + ": " + reason)) before anything
// is allocated for it.
#ifndef POLYFIT_UTIL_BINARY_IO_H_
#define POLYFIT_UTIL_BINARY_IO_H_

#include <cstddef>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

namespace polyfit {

class BinaryWriter {
 public:
  template <typename T>
  void Put(const T& value) {
    PutBytes(&value, sizeof(T));
  }
  void PutBytes(const void* data, size_t size) {
    const char* bytes = static_cast<const char*>(data);
    buffer_.insert(buffer_.end(), bytes, bytes + size);
  }
  void PutDoubles(const double* data, size_t count) { PutBytes(data, count * sizeof(double)); }
  void Reserve(size_t bytes) { buffer_.reserve(bytes); }
  const std::vector<char>& buffer() const { return buffer_; }

 private:
  std::vector<char> buffer_;
};

template <typename ErrorType>
class BinaryReader {
 public:
  BinaryReader(std::vector<char> data, std::string path) : data_(std::move(data)), path_(std::move(path)) {}

  template <typename T>
  T Get(const char* section) {
    T value;
    GetBytes(&value, sizeof(T), section);
    return value;
  }
  void GetBytes(void* out, size_t size, const char* section) {
    if (size > remaining()) Fail(std::string("truncated in section '") + section + "'");
    if (size == 0) return;  // out may be an empty vector's null data()
    std::memcpy(out, data_.data() + position_, size);
    position_ += size;
  }
  // count doubles, refused before allocating when fewer bytes are left.
  std::vector<double> GetDoubles(size_t count, const char* section) {
    if (count > remaining() / sizeof(double)) Fail(std::string("truncated in section '") + section + "'");
    std::vector<double> values(count);
    GetBytes(values.data(), count * sizeof(double), section);
    return values;
  }
  size_t remaining() const { return data_.size() - position_; }
  [[noreturn]] void Fail(const std::string& reason) const { throw ErrorType(path_ + ": " + reason); }

 private:
  std::vector<char> data_;
  std::string path_;
  size_t position_ = 0;
};

}  // namespace polyfit

#endif  // POLYFIT_UTIL_BINARY_IO_H_
