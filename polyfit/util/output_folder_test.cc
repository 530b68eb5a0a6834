#include "polyfit/util/output_folder.h"

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <gtest/gtest.h>

#include "polyfit/util/atomic_file.h"
#include "polyfit/util/scoped_temp_dir.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;

// The temporary a write leaves when it dies halfway: what
// WriteFileAtomically names it, caught by failing inside the write.
std::string TemporaryOfAFailedWrite(const std::string& path) {
  std::string seen;
  try {
    WriteFileAtomically(path, [&](std::ostream&) {
      for (const auto& entry : fs::directory_iterator(fs::path(path).parent_path())) {
        if (entry.path().filename().string().rfind(fs::path(path).filename().string() + ".tmp", 0) == 0) {
          seen = entry.path().filename().string();
        }
      }
      throw std::runtime_error("killed");
    });
  } catch (const std::runtime_error&) {
  }
  return seen;
}

TEST(OutputFolderTest, RecognisesTheAtomicWritersTemporaries) {
  ScopedTempDir dir;
  const std::string temporary = TemporaryOfAFailedWrite(dir.File("metrics.json"));
  ASSERT_FALSE(temporary.empty());
  EXPECT_TRUE(IsAtomicWriteTemporary(temporary)) << temporary;
  EXPECT_FALSE(fs::exists(dir.File(temporary)));  // the writer's own clean-up
  EXPECT_FALSE(IsAtomicWriteTemporary("metrics.json"));
  EXPECT_FALSE(IsAtomicWriteTemporary("frame.tmp.ply"));
  EXPECT_FALSE(IsAtomicWriteTemporary(".tmp1_2"));
}

TEST(OutputFolderTest, AbsentAndEmptyFoldersSayNothing) {
  ScopedTempDir dir;
  EXPECT_EQ(CleanOutputFolder(dir.File("absent"), "metrics.json").Describe("x", "metrics.json"), "");
  const OutputFolderState empty = CleanOutputFolder(dir.path().string(), "metrics.json");
  EXPECT_TRUE(empty.exists);
  EXPECT_EQ(empty.Describe("x", "metrics.json"), "");
}

TEST(OutputFolderTest, AnInterruptedRunIsNamedAndItsTemporariesRemoved) {
  ScopedTempDir dir;
  fs::create_directories(dir.path() / "meshes");
  std::ofstream(dir.path() / "meshes" / "000000.ply") << "ply\n";
  std::ofstream(dir.path() / "meshes" / "000001.ply") << "ply\n";
  std::ofstream(dir.path() / "meshes" / "000002.ply.tmp4711_3") << "pl";  // killed mid-write
  std::ofstream(dir.path() / "trace.csv.tmp12_0") << "frame,";
  const OutputFolderState state = CleanOutputFolder(dir.path().string(), "metrics.json");
  EXPECT_FALSE(state.finished);
  EXPECT_EQ(state.files, 2);
  EXPECT_EQ(state.removed_temporaries, 2);
  EXPECT_FALSE(fs::exists(dir.path() / "meshes" / "000002.ply.tmp4711_3"));
  EXPECT_FALSE(fs::exists(dir.path() / "trace.csv.tmp12_0"));
  EXPECT_TRUE(fs::exists(dir.path() / "meshes" / "000001.ply"));
  EXPECT_EQ(state.Describe("out", "metrics.json"),
            "out: an earlier run was interrupted here (no metrics.json) and left 2 complete files and 2 "
            "half-written ones, removed; this run replaces its outputs");
}

TEST(OutputFolderTest, AFinishedRunIsNamed) {
  ScopedTempDir dir;
  std::ofstream(dir.path() / "metrics.json") << "{}";
  const OutputFolderState state = CleanOutputFolder(dir.path().string(), "metrics.json");
  EXPECT_TRUE(state.finished);
  EXPECT_EQ(state.Describe("out", "metrics.json"),
            "out: an earlier run finished here and left 1 complete file; this run replaces its outputs");
}

}  // namespace
}  // namespace polyfit
