/// Runs the vo_eval executable, which catkin puts beside the test executables (devel/lib/planetary_vo/): exit
/// codes, report, JSON and plots. Fails (does not skip) when the executable has not been built.

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "planetary_vo/dataset/dataset.h"
#include "test_support.h"

namespace planetary_vo {
namespace {

std::string executableDir() {
  char exe[4096];
  const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof(exe) - 1);
  if (n <= 0) return ".";
  const std::string path(exe, static_cast<size_t>(n));
  return path.substr(0, path.find_last_of('/'));
}

std::string readText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Runs vo_eval with `args`, output to `log`; returns its exit status.
int runVoEval(const std::string& args, const std::string& log) {
  const std::string command = executableDir() + "/vo_eval " + args + " > " + log + " 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(VoEvalTool, ReportJsonPlotsAndErrorExitCodes) {
  ASSERT_TRUE(test::requireDataFile(executableDir() + "/vo_eval")) << "build the vo_eval target first";
  const std::string gt = test::dataPath("kitti_clip_turn/poses.txt");
  ASSERT_TRUE(test::requireDataFile(gt));
  const std::string dir = test::outputDir("vo_eval_tool");
  // Estimate: the ground truth shifted by 0.5 m in z, in TUM format (KITTI stamps are index / 10 Hz).
  Trajectory est = readTrajectory(gt);
  for (StampedPose& p : est) p.T_world_cam.translation().z() += 0.5;
  writeTumTrajectory(dir + "/est.txt", est);

  ASSERT_EQ(runVoEval("--gt " + gt + " --est " + dir + "/est.txt --align none --json " + dir +
                          "/eval.json --plot " + dir + "/plots --axes xyz",
                      dir + "/log.txt"),
            0)
      << readText(dir + "/log.txt");
  const std::string log = readText(dir + "/log.txt");
  EXPECT_NE(log.find("associated 51"), std::string::npos) << log;
  EXPECT_NE(log.find("translation  rmse 0.5000"), std::string::npos) << log;
  EXPECT_NE(readText(dir + "/eval.json").find("\"num_associated\": 51"), std::string::npos);
  for (const char* png : {"trajectory.png", "position_vs_time.png", "attitude.png", "ate_vs_time.png"})
    EXPECT_TRUE(test::requireDataFile(dir + "/plots/" + png));

  EXPECT_EQ(runVoEval("--gt " + dir + "/missing.txt --est " + dir + "/est.txt", dir + "/log2.txt"), 1);
  EXPECT_NE(readText(dir + "/log2.txt").find("cannot open " + dir + "/missing.txt"), std::string::npos);
  EXPECT_EQ(runVoEval("--gt " + gt + " --est " + dir + "/est.txt --max-dt -1", dir + "/log3.txt"), 2);
  EXPECT_EQ(runVoEval("--gt " + gt, dir + "/log4.txt"), 2);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
