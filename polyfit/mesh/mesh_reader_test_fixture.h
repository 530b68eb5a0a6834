// The fixture the mesh readers' tests share: files written to a scratch
// folder, and the message a reader throws for one.
#ifndef POLYFIT_MESH_MESH_READER_TEST_FIXTURE_H_
#define POLYFIT_MESH_MESH_READER_TEST_FIXTURE_H_

#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "polyfit/mesh/mesh_io.h"
#include "polyfit/util/scoped_temp_dir.h"

namespace polyfit {

class MeshReaderTest : public ::testing::Test {
 protected:
  // Writes `text` (bytes as given) to the scratch folder; returns its path.
  std::string Write(const std::string& name, const std::string& text) const {
    const std::string path = (temp_.path() / name).string();
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
  // The message of the MeshIoError `read` throws for `text` written as
  // `name`, or "(no error)".
  template <typename Read>
  std::string ErrorOf(Read read, const std::string& name, const std::string& text) const {
    try {
      read(Write(name, text));
    } catch (const MeshIoError& e) {
      return e.what();
    }
    return "(no error)";
  }

 private:
  ScopedTempDir temp_{"polyfit_mesh_reader"};
};

}  // namespace polyfit

#endif  // POLYFIT_MESH_MESH_READER_TEST_FIXTURE_H_
