#pragma once
/// Helpers shared by the unit tests: where the shared data and the test output live.

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

namespace planetary_vo::test {

/// Absolute path of `relative` inside ../shared/data (or $PLANETARY_VO_DATA). A test that needs a missing
/// file must fail, not skip: call requireDataFile() in an ASSERT.
inline std::string dataPath(const std::string& relative) {
  const char* env = std::getenv("PLANETARY_VO_DATA");
  const std::string root = env && *env ? env : PLANETARY_VO_DATA_DIR;
  return root + "/" + relative;
}

inline ::testing::AssertionResult requireDataFile(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "required test data is missing: " << path
                                       << " (the shared data folder must be beside the checkout, "
                                          "or PLANETARY_VO_DATA must point to it)";
}

/// The repository root (with a trailing '/'), from this header's absolute path (CMake compiles by absolute
/// path).
inline std::string sourceRoot() {
  const std::string file = __FILE__;
  const std::string suffix = "test/test_support.h";
  if (file.size() < suffix.size() || file.substr(file.size() - suffix.size()) != suffix) {
    ADD_FAILURE() << "test_support.h compiled from an unexpected path: " << file;
    return "./";
  }
  return file.substr(0, file.size() - suffix.size());
}

/// The folder of the running test executable: catkin puts the tools beside it (devel/lib/planetary_vo/).
inline std::string executableDir() {
  char exe[4096];
  const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof(exe) - 1);
  if (n <= 0) return ".";
  const std::string path(exe, static_cast<size_t>(n));
  return path.substr(0, path.find_last_of('/'));
}

/// The whole text of a file ("" when it cannot be read).
inline std::string readText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Runs the tool `name` from executableDir() with `args`, stdout and stderr to `log`; its exit status (-1
/// when it did not exit normally).
inline int runTool(const std::string& name, const std::string& args, const std::string& log) {
  const std::string command = executableDir() + "/" + name + " " + args + " > " + log + " 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// A fresh folder for files a test writes, under the build tree: <build>/test_output/<name>.
inline std::string outputDir(const std::string& name) {
  const std::string dir = std::string(PLANETARY_VO_TEST_OUTPUT_DIR) + "/" + name;
  const std::string cmd = "rm -rf '" + dir + "' && mkdir -p '" + dir + "'";
  if (std::system(cmd.c_str()) != 0) ADD_FAILURE() << "cannot create " << dir;
  return dir;
}

}  // namespace planetary_vo::test
