/// Fuzz test of the command-line tools (issue 12, fault containment): vo_run, vo_eval and player (--bag mode)
/// run on randomly mutated input files, and must either succeed or exit with a clean non-zero code (1 or 2)
/// and an error message naming the tool, never die of a signal (abort, std::terminate, segfault, a sanitizer
/// finding with abort_on_error) or hang. When vo_run succeeds, its trajectory must be finite with unit
/// quaternions.
///
/// The base inputs: the first frames of the rendered Lunar test sequence of the VO rostests (images, times,
/// camera.yaml, IMU, altimeter, sensors.yaml, ground truth), config/default.yaml, config/lunar_fused.yaml,
/// config/hazard.yaml, vo_run's own trajectory, velocity and covariance files of that dataset (for vo_eval),
/// and a bag written by player from it. Mutations of one file per case: truncated, bit-flipped, emptied,
/// removed, a directory in its place, a line deleted / duplicated / swapped / garbage inserted, a number
/// replaced by NaN / Inf / huge / text, a YAML key duplicated or misspelt; a truncated bag given as dataset,
/// trajectory or configuration, or as player's output; and a few numeric command-line options made wild.
///
/// Seeded: $PLANETARY_VO_FUZZ_SEED (default below), printed; $PLANETARY_VO_FUZZ_TOOL_CASES sets the number of
/// cases. A failing case prints its command and keeps its files in test_output/tools_fuzz/failed_<n>.

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

extern char** environ;

namespace planetary_vo {
namespace {

namespace fs = std::filesystem;

constexpr uint64_t kDefaultSeed = 20261127;
constexpr int kDefaultCases = 240;
constexpr size_t kBaseFrames = 8;  ///< frames of the base dataset
constexpr double kTimeoutS = 120.0;

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}
void writeFile(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}

/// How a tool run ended.
struct RunResult {
  bool exited = false;  ///< by exit() (else killed by a signal, or hung)
  int code = -1;        ///< exit code, or the signal
  bool timed_out = false;
  std::string output;  ///< stdout + stderr
};

/// Runs argv (no shell) with stdout and stderr into `log`, killing it after kTimeoutS.
RunResult run(const std::vector<std::string>& argv, const std::string& log) {
  RunResult r;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  const int err = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (err != 0) {
    r.output = "cannot start " + argv[0] + ": " + std::strerror(err);
    return r;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(kTimeoutS);
  int status = 0;
  while (true) {
    const pid_t done = waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      r.timed_out = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));  // polling period of the child, not a delay
  }
  if (!r.timed_out && WIFEXITED(status)) {
    r.exited = true;
    r.code = WEXITSTATUS(status);
  } else if (!r.timed_out && WIFSIGNALED(status)) {
    r.code = WTERMSIG(status);
  }
  r.output = readFile(log);
  return r;
}

class Rng {
 public:
  explicit Rng(uint64_t seed) : engine_(seed) {}
  int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(engine_); }
  bool chance(double p) { return std::uniform_real_distribution<double>(0.0, 1.0)(engine_) < p; }
  template <class T>
  const T& pick(const std::vector<T>& values) {
    return values[size_t(integer(0, int(values.size()) - 1))];
  }

 private:
  std::mt19937_64 engine_;
};

std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::stringstream s(text);
  for (std::string line; std::getline(s, line);) lines.push_back(line);
  return lines;
}
std::string joinLines(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& l : lines) text += l + "\n";
  return text;
}

/// Whether a whitespace-separated token reads as a number.
bool isNumber(const std::string& token) {
  char* end = nullptr;
  std::strtod(token.c_str(), &end);
  return !token.empty() && end == token.c_str() + token.size();
}

/// Mutates the file (or folder entry) at `path` in place; returns what was done.
std::string mutateFile(Rng& rng, const std::string& path) {
  const bool yaml = path.size() > 5 && (path.substr(path.size() - 5) == ".yaml");
  const bool binary =
      !yaml &&
      (path.size() > 4 && (path.substr(path.size() - 4) == ".png" || path.substr(path.size() - 4) == ".bag"));
  std::string text = readFile(path);
  std::vector<std::string> lines = splitLines(text);
  const int kind = binary ? rng.pick<int>({0, 1, 2, 3, 4}) : rng.integer(0, yaml ? 11 : 9);
  switch (kind) {
    case 0: {
      const size_t size = text.empty() ? 0 : size_t(rng.integer(0, int(text.size()) - 1));
      writeFile(path, text.substr(0, size));
      return "truncated to " + std::to_string(size) + " of " + std::to_string(text.size()) + " bytes";
    }
    case 1: {
      const int flips = rng.pick<int>({1, 2, 8, 64});
      for (int k = 0; k < flips && !text.empty(); ++k)
        text[size_t(rng.integer(0, int(text.size()) - 1))] ^= char(1 << rng.integer(0, 7));
      writeFile(path, text);
      return std::to_string(flips) + " bits flipped";
    }
    case 2:
      writeFile(path, "");
      return "emptied";
    case 3:
      fs::remove_all(path);
      fs::create_directory(path);
      return "a directory in its place";
    case 4:
      fs::remove_all(path);
      return "removed";
    case 5: {
      if (lines.empty()) return "nothing to delete";
      const size_t i = size_t(rng.integer(0, int(lines.size()) - 1));
      lines.erase(lines.begin() + long(i));
      writeFile(path, joinLines(lines));
      return "line " + std::to_string(i + 1) + " deleted";
    }
    case 6: {
      if (lines.empty()) return "nothing to duplicate";
      const size_t i = size_t(rng.integer(0, int(lines.size()) - 1));
      lines.insert(lines.begin() + long(i), lines[i]);
      writeFile(path, joinLines(lines));
      return "line " + std::to_string(i + 1) + " duplicated";
    }
    case 7: {
      if (lines.size() < 2) return "nothing to swap";
      const size_t i = size_t(rng.integer(0, int(lines.size()) - 2));
      std::swap(lines[i], lines[i + 1]);
      writeFile(path, joinLines(lines));
      return "lines " + std::to_string(i + 1) + " and " + std::to_string(i + 2) + " swapped";
    }
    case 8: {
      const std::string garbage =
          rng.pick<std::string>({"garbage", std::string(100000, '9'), "1 2", "\x01\xff\xfe", "{[", "- - -",
                                 "  : :", "1e999 1e999"});
      const size_t i = lines.empty() ? 0 : size_t(rng.integer(0, int(lines.size())));
      lines.insert(lines.begin() + long(i), garbage);
      writeFile(path, joinLines(lines));
      return "garbage line inserted at " + std::to_string(i + 1);
    }
    case 9:
    case 10: {  // a number replaced (twice as likely for text tables, which are mostly numbers)
      std::vector<std::pair<size_t, size_t>> numbers;  // (line, token start)
      for (size_t l = 0; l < lines.size(); ++l) {
        const std::string& line = lines[l];
        for (size_t p = 0; p < line.size();) {
          const size_t start = line.find_first_not_of(" \t:[],", p);
          if (start == std::string::npos) break;
          const size_t end = line.find_first_of(" \t:[],", start);
          const std::string token =
              line.substr(start, end == std::string::npos ? std::string::npos : end - start);
          if (isNumber(token)) numbers.emplace_back(l, start);
          p = end == std::string::npos ? line.size() : end;
        }
      }
      if (numbers.empty()) return "no number to replace";
      const auto [l, start] = numbers[size_t(rng.integer(0, int(numbers.size()) - 1))];
      const size_t end = std::min(lines[l].find_first_of(" \t:[],", start), lines[l].size());
      const std::string value = rng.pick<std::string>(
          {"nan", "NaN", "inf", "-inf", "1e308", "-1e308", "1e400", "0", "-1", "99999999999999999999999",
           "abc", "0x1p3", "1,5", "-0", "4294967296", "-2147483649", ".", "~"});
      const std::string old = lines[l].substr(start, end - start);
      lines[l].replace(start, end - start, value);
      writeFile(path, joinLines(lines));
      return "number '" + old + "' on line " + std::to_string(l + 1) + " replaced by '" + value + "'";
    }
    default: {  // YAML: a key duplicated or misspelt
      std::vector<size_t> keys;
      for (size_t l = 0; l < lines.size(); ++l) {
        const size_t colon = lines[l].find(':');
        const size_t first = lines[l].find_first_not_of(' ');
        if (colon != std::string::npos && first != std::string::npos && first < colon &&
            lines[l][first] != '#')
          keys.push_back(l);
      }
      if (keys.empty()) return "no key";
      const size_t l = keys[size_t(rng.integer(0, int(keys.size()) - 1))];
      if (rng.chance(0.5)) {
        lines.insert(lines.begin() + long(l) + 1, lines[l]);
        writeFile(path, joinLines(lines));
        return "key on line " + std::to_string(l + 1) + " duplicated";
      }
      const size_t first = lines[l].find_first_not_of(' ');
      const size_t colon = lines[l].find(':');
      lines[l][first + size_t(rng.integer(0, int(colon - first) - 1))] = 'q';
      writeFile(path, joinLines(lines));
      return "key on line " + std::to_string(l + 1) + " misspelt: " + lines[l].substr(0, 60);
    }
  }
}

/// The first kBaseFrames frames of a planetary_vo dataset (every text table cut at the last frame's stamp,
/// the YAML files as they are; no terrain layers).
void writeBaseDataset(const std::string& from, const std::string& to) {
  fs::create_directories(to + "/images");
  std::vector<double> times;
  for (const std::string& line : splitLines(readFile(from + "/times.txt")))
    if (!line.empty() && line[0] != '#') times.push_back(std::stod(line));
  ASSERT_GE(times.size(), kBaseFrames) << from;
  const double last = times[kBaseFrames - 1] + 1e-6;
  for (const auto& entry : fs::directory_iterator(from)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_directory() || name.rfind("groundtruth_terrain", 0) == 0) continue;
    if (name.size() > 4 && name.substr(name.size() - 4) == ".txt") {
      std::vector<std::string> kept;
      for (const std::string& line : splitLines(readFile(entry.path().string()))) {
        std::istringstream in(line);
        double t = 0.0;
        if (line.empty() || line[0] == '#' || !(in >> t) || t <= last) kept.push_back(line);
      }
      writeFile(to + "/" + name, joinLines(kept));
    } else {
      fs::copy_file(entry.path(), to + "/" + name);
    }
  }
  char image[32];
  for (size_t i = 0; i < kBaseFrames; ++i) {
    std::snprintf(image, sizeof(image), "/images/%06zu.png", i);
    fs::copy_file(from + image, to + image);
  }
}

/// Every number of a TUM trajectory finite, every quaternion of unit norm.
::testing::AssertionResult finiteTrajectory(const std::string& path) {
  for (const std::string& line : splitLines(readFile(path))) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    std::vector<double> v;
    std::string token;
    while (in >> token) v.push_back(std::strtod(token.c_str(), nullptr));
    if (v.size() != 8) return ::testing::AssertionFailure() << path << ": line '" << line << "'";
    for (double x : v)
      if (!std::isfinite(x))
        return ::testing::AssertionFailure() << path << ": non-finite in '" << line << "'";
    const double norm = std::sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]);
    if (std::abs(norm - 1.0) > 1e-6)
      return ::testing::AssertionFailure() << path << ": |q| = " << norm << " in '" << line << "'";
  }
  return ::testing::AssertionSuccess();
}

std::string joinArgs(const std::vector<std::string>& argv) {
  std::string s;
  for (const std::string& a : argv) s += (s.empty() ? "" : " ") + a;
  return s;
}

/// The lines of a TUM trajectory: stamp, then tx ty tz qx qy qz qw.
std::vector<std::vector<double>> readTum(const std::string& path) {
  std::vector<std::vector<double>> rows;
  for (const std::string& line : splitLines(readFile(path))) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    std::vector<double> row(8);
    for (double& v : row) in >> v;
    if (in) rows.push_back(row);
  }
  return rows;
}

TEST(VoRun, KeyframeTrajectoryHoldsTheAdjustedKeyframesAndFirstFrameSkipsTheStart) {
  // --output-keyframes: every keyframe once, in time order, at an image's stamp, with its pose after the
  // adjustments that followed it, so most differ from the pose output at their own image. --first-frame N: no
  // pose before image N. Both on the rendered test sequence (61 images).
  const std::string out = std::string(PLANETARY_VO_TEST_OUTPUT_DIR) + "/vo_run_keyframes";
  fs::remove_all(out);
  fs::create_directories(out);
  std::vector<double> times;
  for (const std::string& line : splitLines(readFile(std::string(VO_TEST_DATASET) + "/times.txt")))
    if (!line.empty() && line[0] != '#') times.push_back(std::stod(line));
  ASSERT_GE(times.size(), 40u);
  const std::string vo_run = VO_RUN_EXE;
  RunResult r = run({vo_run, "--dataset", VO_TEST_DATASET, "--output", out + "/all.txt", "--output-keyframes",
                     out + "/keyframes.txt", "--quiet"},
                    out + "/all.log");
  ASSERT_TRUE(r.exited && r.code == 0) << r.output;
  const auto online = readTum(out + "/all.txt");
  const auto keyframes = readTum(out + "/keyframes.txt");
  ASSERT_GE(keyframes.size(), 5u);
  int refined = 0, compared = 0;
  for (size_t k = 0; k < keyframes.size(); ++k) {
    if (k > 0) EXPECT_LT(keyframes[k - 1][0], keyframes[k][0]) << "keyframe " << k;
    const double t_k = keyframes[k][0];
    EXPECT_TRUE(std::any_of(times.begin(), times.end(), [t_k](double t) { return std::abs(t - t_k) < 1e-6; }))
        << "keyframe " << k << " at " << t_k << " is not an image's stamp";
    for (const auto& pose : online) {
      if (std::abs(pose[0] - keyframes[k][0]) > 1e-6) continue;
      ++compared;
      const double moved =
          std::hypot(pose[1] - keyframes[k][1], pose[2] - keyframes[k][2], pose[3] - keyframes[k][3]);
      if (moved > 1e-9) ++refined;
    }
  }
  EXPECT_GE(compared, static_cast<int>(keyframes.size()) - 1);  // all but the initialisation's reference
  EXPECT_GT(2 * refined, compared) << refined << " of " << compared << " keyframes moved after their image";

  const size_t first = 20;
  r = run({vo_run, "--dataset", VO_TEST_DATASET, "--output", out + "/late.txt", "--first-frame",
           std::to_string(first), "--quiet"},
          out + "/late.log");
  ASSERT_TRUE(r.exited && r.code == 0) << r.output;
  const auto late = readTum(out + "/late.txt");
  ASSERT_GE(late.size(), 10u);
  EXPECT_GT(late.front()[0], times[first] - 1e-6);  // its first image initialises: no pose of its own
  EXPECT_LT(late.front()[0], times[first + 5]);
  EXPECT_NEAR(late.back()[0], online.back()[0], 1e-6);

  r = run({vo_run, "--dataset", VO_TEST_DATASET, "--output", out + "/none.txt", "--first-frame",
           std::to_string(times.size()), "--quiet"},
          out + "/none.log");
  EXPECT_TRUE(r.exited && r.code != 0);
  EXPECT_NE(r.output.find("--first-frame"), std::string::npos) << r.output;
}

TEST(VoRun, RealtimeFeedsTheFramesAtTheirRateAndKeepsTheTrajectory) {
  // vo_run --realtime gives each frame at its time since the first (as a camera would): the run lasts at least
  // the dataset's span, and the trajectory is that of the back-to-back run (the asynchronous optimiser is
  // waited for at fixed points, so results do not depend on timing).
  const std::string out = std::string(PLANETARY_VO_TEST_OUTPUT_DIR) + "/vo_run_realtime";
  fs::remove_all(out);
  fs::create_directories(out);
  ASSERT_NO_FATAL_FAILURE(writeBaseDataset(VO_TEST_DATASET, out + "/dataset"));
  std::vector<double> times;
  for (const std::string& line : splitLines(readFile(out + "/dataset/times.txt")))
    if (!line.empty() && line[0] != '#') times.push_back(std::stod(line));
  ASSERT_GE(times.size(), 2u);
  const double span_s = times.back() - times.front();
  ASSERT_GT(span_s, 0.5);
  const std::string vo_run = VO_RUN_EXE;
  const std::vector<std::string> back_to_back = {vo_run, "--dataset", out + "/dataset", "--output",
                                                 out + "/back_to_back.txt", "--quiet"};
  const auto t0 = std::chrono::steady_clock::now();
  RunResult r = run(back_to_back, out + "/back_to_back.log");
  const double back_to_back_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(r.exited && r.code == 0) << r.output;
  std::vector<std::string> realtime = back_to_back;
  realtime[4] = out + "/realtime.txt";
  realtime.push_back("--realtime");
  const auto start = std::chrono::steady_clock::now();
  r = run(realtime, out + "/realtime.log");
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(r.exited && r.code == 0) << r.output;
  std::printf("vo_run: %zu frames spanning %.2f s took %.2f s with --realtime, %.2f s back to back\n",
              times.size(), span_s, wall_s, back_to_back_s);
  EXPECT_GE(wall_s, span_s);
  // The frames' processing overlaps the waits, so the difference is the span less a little. That tells the
  // waits from the processing only where back to back takes well under the span (the normal build: about
  // 0.3 s of 0.7 s); in the sanitizer build on a loaded 2-core machine back to back took 1.12 s, longer than
  // the span, and a run that never waited would pass too. There only the lower bound above is checked.
  if (back_to_back_s < 0.5 * span_s) {
    EXPECT_GE(wall_s - back_to_back_s, 0.5 * span_s);
  } else {
    std::printf("vo_run: back to back took longer than half the span: only the lower bound is checked\n");
  }
  EXPECT_FALSE(readFile(out + "/realtime.txt").empty());
  EXPECT_EQ(readFile(out + "/realtime.txt"), readFile(out + "/back_to_back.txt"));
}

TEST(ToolsFuzz, MutatedFilesGiveCleanErrors) {
  uint64_t seed = kDefaultSeed;
  if (const char* env = std::getenv("PLANETARY_VO_FUZZ_SEED"); env && *env) seed = std::stoull(env);
  int cases = kDefaultCases;
  if (const char* env = std::getenv("PLANETARY_VO_FUZZ_TOOL_CASES"); env && *env) cases = std::stoi(env);
  std::printf("tools_fuzz: seed %llu, %d cases (PLANETARY_VO_FUZZ_SEED, PLANETARY_VO_FUZZ_TOOL_CASES)\n",
              static_cast<unsigned long long>(seed), cases);
  Rng rng(seed);
  const std::string out = std::string(PLANETARY_VO_TEST_OUTPUT_DIR) + "/tools_fuzz";
  fs::remove_all(out);
  fs::create_directories(out);
  const std::string vo_run = VO_RUN_EXE, vo_eval = VO_EVAL_EXE, player = PLAYER_EXE;
  const std::string config_dir = std::string(PLANETARY_VO_SOURCE_DIR) + "/config";

  // Base inputs, each run once unmutated: they must succeed.
  const std::string base = out + "/base";
  ASSERT_NO_FATAL_FAILURE(writeBaseDataset(VO_TEST_DATASET, base + "/dataset"));
  fs::copy_file(config_dir + "/default.yaml", base + "/default.yaml");
  fs::copy_file(config_dir + "/lunar_fused.yaml", base + "/lunar_fused.yaml");
  fs::copy_file(config_dir + "/hazard.yaml", base + "/hazard.yaml");
  const std::vector<std::string> base_run = {vo_run,
                                             "--dataset",
                                             base + "/dataset",
                                             "--config",
                                             base + "/lunar_fused.yaml",
                                             "--output",
                                             base + "/est.txt",
                                             "--output-velocity",
                                             base + "/vel.txt",
                                             "--output-covariance",
                                             base + "/cov.txt",
                                             "--initial-state-from-groundtruth",
                                             "--quiet"};
  RunResult r = run(base_run, out + "/base_vo_run.log");
  ASSERT_TRUE(r.exited && r.code == 0) << joinArgs(base_run) << "\n" << r.output;
  ASSERT_TRUE(finiteTrajectory(base + "/est.txt"));
  const std::vector<std::string> base_bag = {player, "--dataset", base + "/dataset", "--bag",
                                             base + "/full.bag"};
  r = run(base_bag, out + "/base_player.log");
  ASSERT_TRUE(r.exited && r.code == 0) << joinArgs(base_bag) << "\n" << r.output;
  {
    const std::string bag = readFile(base + "/full.bag");
    writeFile(base + "/truncated.bag", bag.substr(0, bag.size() / 2));
  }
  const std::vector<std::string> base_eval = {
      vo_eval,           "--gt",   base + "/dataset",  "--est",           base + "/est.txt",
      "--align",         "first",  "--est-velocity",   base + "/vel.txt", "--est-cov",
      base + "/cov.txt", "--json", base + "/eval.json"};
  r = run(base_eval, out + "/base_vo_eval.log");
  ASSERT_TRUE(r.exited && r.code == 0) << joinArgs(base_eval) << "\n" << r.output;

  const std::vector<std::string> dataset_files = {
      "times.txt",    "camera.yaml",           "imu.txt",           "altimeter.txt",    "groundtruth.txt",
      "sensors.yaml", "groundtruth_state.txt", "images/000003.png", "images/000000.png"};
  int failures = 0, clean_errors = 0, successes = 0;
  for (int n = 1; n <= cases; ++n) {
    const std::string work = out + "/case";
    fs::remove_all(work);
    fs::copy(base, work, fs::copy_options::recursive);
    const std::string d = work + "/dataset";
    std::vector<std::string> argv;
    std::string tool, what;
    const int target = rng.integer(0, 99);
    if (target < 45) {  // vo_run on a mutated dataset, configuration or hazard configuration
      tool = "vo_run";
      const std::string config = work + (rng.chance(0.5) ? "/lunar_fused.yaml" : "/default.yaml");
      argv = {vo_run, "--dataset", d, "--config", config, "--output", work + "/out.txt", "--quiet"};
      if (rng.chance(0.5)) argv.push_back("--initial-state-from-groundtruth");
      const int which = rng.integer(0, 9);
      if (which < 6) {
        const std::string file = rng.pick(dataset_files);
        what = file + ": " + mutateFile(rng, d + "/" + file);
      } else if (which < 8) {
        what = config.substr(config.find_last_of('/') + 1) + ": " + mutateFile(rng, config);
      } else if (which < 9) {
        argv.insert(argv.end(),
                    {"--output-terrain", work + "/terrain", "--hazard-config", work + "/hazard.yaml"});
        what = "hazard.yaml: " + mutateFile(rng, work + "/hazard.yaml");
      } else {
        const std::string flag = rng.pick<std::string>({"--dataset", "--config"});
        argv[size_t(std::find(argv.begin(), argv.end(), flag) - argv.begin()) + 1] = work + "/truncated.bag";
        what = "truncated bag as " + flag;
      }
      if (rng.chance(0.1)) {
        const std::string opt =
            rng.pick<std::string>({"--max-frames", "--initial-error-m", "--initial-error-deg"});
        const std::string value =
            rng.pick<std::string>({"nan", "inf", "-1", "0", "1e308", "abc", "1,2", "1,2,3,4", "nan,0,0",
                                   "1e308,1e308,1e308", "99999999999"});
        argv.insert(argv.end(), {opt, value});
        what += "; " + opt + " " + value;
      }
    } else if (target < 75) {  // vo_eval on a mutated estimate, ground truth, velocity or covariance
      tool = "vo_eval";
      argv = {vo_eval,
              "--gt",
              d,
              "--est",
              work + "/est.txt",
              "--align",
              rng.pick<std::string>({"first", "sim3", "se3", "none"}),
              "--est-velocity",
              work + "/vel.txt",
              "--json",
              work + "/out.json"};
      if (argv[6] == "first") argv.insert(argv.end(), {"--est-cov", work + "/cov.txt"});
      const int which = rng.integer(0, 11);
      if (which < 10) {
        const std::string file =
            rng.pick<std::string>({"est.txt", "vel.txt", "cov.txt", "dataset/groundtruth.txt",
                                   "dataset/groundtruth_state.txt", "est.txt"});
        what = file + ": " + mutateFile(rng, work + "/" + file);
      } else if (which < 11) {
        argv[size_t(rng.chance(0.5) ? 2 : 4)] = work + "/truncated.bag";
        what = "truncated bag as a trajectory";
      } else {
        const std::string opt =
            rng.pick<std::string>({"--first-scale-window", "--scale-window", "--gap-factor", "--align-frames",
                                   "--rpe-frames", "--rpe-distances", "--max-dt", "--initial-scale-error"});
        const std::string value = rng.pick<std::string>(
            {"nan", "inf", "-1", "0", "1e308", "abc", "-1e308", "1,,2", "4294967296", "1e-300"});
        argv.insert(argv.end(), {opt, value});
        what = opt + " " + value;
      }
    } else {  // player --bag on a mutated dataset, or with a bad output
      tool = "player";
      argv = {player, "--dataset", d, "--bag", work + "/out.bag"};
      const int which = rng.integer(0, 9);
      if (which < 7) {
        const std::string file = rng.pick(dataset_files);
        what = file + ": " + mutateFile(rng, d + "/" + file);
      } else if (which == 7) {
        argv[2] = work + "/truncated.bag";
        what = "truncated bag as --dataset";
      } else if (which == 8) {
        const std::string bad =
            rng.pick<std::string>({work + "/truncated.bag", work + "/dataset", work + "/missing/out.bag"});
        argv[4] = bad;
        what = "output " + bad.substr(work.size());
      } else {
        const std::string opt = rng.pick<std::string>({"--start", "--time-offset"});
        const std::string value =
            rng.pick<std::string>({"nan", "inf", "-1", "1e308", "abc", "99999999999", "-1e308"});
        argv.insert(argv.end(), {opt, value});
        what = opt + " " + value;
      }
    }
    std::printf("case %d: %s, %s\n", n, tool.c_str(), what.c_str());
    std::fflush(stdout);
    r = run(argv, work + "/log.txt");
    bool ok = true;
    std::string problem;
    if (r.timed_out) {
      ok = false;
      problem = "did not finish within " + std::to_string(int(kTimeoutS)) + " s";
    } else if (!r.exited) {
      ok = false;
      problem = "killed by signal " + std::to_string(r.code) + " (" + strsignal(r.code) + ")";
    } else if (r.code != 0) {
      const std::string prefix = tool + ": ";
      const size_t at = r.output.find(prefix);
      if (r.code != 1 && r.code != 2) {
        ok = false;
        problem = "exit code " + std::to_string(r.code) + " (clean errors are 1 and 2)";
      } else if (at == std::string::npos || r.output.size() <= at + prefix.size() ||
                 std::isspace(static_cast<unsigned char>(r.output[at + prefix.size()]))) {
        ok = false;
        problem = "exit code " + std::to_string(r.code) + " without an error message '" + prefix + "...'";
      } else {
        ++clean_errors;
        const size_t eol = r.output.find('\n', at);
        std::printf("  -> exit %d: %s\n", r.code,
                    r.output.substr(at, std::min<size_t>(eol - at, 200)).c_str());
      }
    } else {
      ++successes;
      std::printf("  -> exit 0\n");
      if (tool == "vo_run") {
        const ::testing::AssertionResult finite = finiteTrajectory(work + "/out.txt");
        if (!finite) {
          ok = false;
          problem = std::string("succeeded with a bad trajectory: ") + finite.message();
        }
      }
    }
    if (!ok) {
      ++failures;
      const std::string keep = out + "/failed_" + std::to_string(n);
      fs::remove_all(keep);
      fs::rename(work, keep);
      ADD_FAILURE() << "case " << n << " (seed " << seed << "): " << tool << ", " << what << ": " << problem
                    << "\ncommand (files kept in " << keep << "): " << joinArgs(argv) << "\noutput:\n"
                    << r.output.substr(0, 4000);
    }
  }
  fs::remove_all(out + "/case");
  std::printf("tools_fuzz: seed %llu, %d cases: %d succeeded, %d clean errors, %d failures\n",
              static_cast<unsigned long long>(seed), cases, successes, clean_errors, failures);
  EXPECT_GT(clean_errors, cases / 4) << "the mutations hardly ever made an input invalid";
}

}  // namespace
}  // namespace planetary_vo
