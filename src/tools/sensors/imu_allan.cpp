/// @file imu_allan.cpp
/// imu_allan: overlapping Allan deviation table, per axis, of a dataset's IMU stream (imu.txt of any format
/// the dataset reader knows) or of a static IMU simulated with a named grade of the IMU error model. For a
/// simulated grade the analytic curve of the model is printed beside the measured one. Meaningful for
/// static records only (motion adds to the deviation).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/sensors/allan_deviation.h"
#include "planetary_vo/sensors/imu_model.h"

using namespace planetary_vo;
using namespace planetary_vo::sensors;

namespace {
const char* kUsage =
    "usage: imu_allan --dataset DIR [--points-per-decade P]\n"
    "       imu_allan --grade NAME [--hours H] [--rate HZ] [--seed N] [--points-per-decade P]\n"
    "  --dataset            read DIR's IMU stream (static record expected)\n"
    "  --grade              simulate a static IMU of this grade (ideal, navigation, tactical, mems)\n"
    "  --hours              simulated duration (default 2)\n"
    "  --rate               simulated sample rate in Hz (default 200)\n"
    "  --seed               simulation seed (default 1)\n"
    "  --points-per-decade  tau values per decade (default 5)\n";

void printTable(const std::vector<double> (&gyro)[3], const std::vector<double> (&accel)[3], double dt,
                int points_per_decade, const ImuErrorParams* model) {
  // Averaging times log-spaced in seconds (so that 1 s, 10 s ... are in the table), as cluster sizes m >= 1.
  std::vector<size_t> cluster_sizes;
  const size_t m_max = gyro[0].size() / 2;
  for (int i = static_cast<int>(std::floor(points_per_decade * std::log10(dt)));; ++i) {
    const size_t m =
        static_cast<size_t>(std::llround(std::pow(10.0, static_cast<double>(i) / points_per_decade) / dt));
    if (m > m_max) break;
    if (m >= 1 && (cluster_sizes.empty() || m > cluster_sizes.back())) cluster_sizes.push_back(m);
  }
  std::vector<AllanPoint> g[3], a[3];
  for (int i = 0; i < 3; ++i)
    for (size_t m : cluster_sizes) {
      g[i].push_back(overlappingAllanDeviationAt(gyro[i], dt, m));
      a[i].push_back(overlappingAllanDeviationAt(accel[i], dt, m));
    }
  std::printf("# overlapping Allan deviation: gyro rad/s, accel m/s^2%s\n",
              model ? "; model = analytic curve of the parameters" : "");
  std::printf("%12s %9s %11s %11s %11s%s %11s %11s %11s%s\n", "tau_s", "clusters", "gyro_x", "gyro_y",
              "gyro_z", model ? "  gyro_model" : "", "accel_x", "accel_y", "accel_z",
              model ? " accel_model" : "");
  for (size_t j = 0; j < g[0].size(); ++j) {
    const double tau = g[0][j].tau_s;
    std::printf("%12.4g %9zu %11.4e %11.4e %11.4e", tau, g[0][j].num_clusters, g[0][j].deviation,
                g[1][j].deviation, g[2][j].deviation);
    if (model) std::printf(" %11.4e", modelAllanDeviation(model->gyro, tau));
    std::printf(" %11.4e %11.4e %11.4e", a[0][j].deviation, a[1][j].deviation, a[2][j].deviation);
    if (model) std::printf(" %11.4e", modelAllanDeviation(model->accel, tau));
    std::printf("\n");
  }
  // Summary: deviation at 1 s (white noise N if it dominates there) and the minimum (0.664 B).
  for (const auto& [name, points] : {std::pair{"gyro", &g}, std::pair{"accel", &a}}) {
    for (int i = 0; i < 3; ++i) {
      const std::vector<AllanPoint>& p = (*points)[i];
      if (p.empty()) continue;
      const auto one_second =
          std::min_element(p.begin(), p.end(), [](const AllanPoint& x, const AllanPoint& y) {
            return std::abs(std::log(x.tau_s)) < std::abs(std::log(y.tau_s));
          });
      const auto minimum = std::min_element(p.begin(), p.end(), [](const AllanPoint& x, const AllanPoint& y) {
        return x.deviation < y.deviation;
      });
      std::printf(
          "# %s_%c: deviation %.4e at tau %.3g s; minimum %.4e at tau %.4g s (B = min / 0.664 = %.4e)\n",
          name, "xyz"[i], one_second -> deviation, one_second -> tau_s, minimum -> deviation,
          minimum -> tau_s, minimum -> deviation / ieeeBiasInstabilityFactor());
    }
  }
}
}  // namespace

int main(int argc, char** argv) {
  std::string dataset_dir, grade;
  double hours = 2.0, rate_hz = 200.0;
  uint64_t seed = 1;
  int points_per_decade = 5;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help" || i + 1 >= argc) {
      std::cerr << kUsage;
      return arg == "-h" || arg == "--help" ? 0 : 2;
    }
    const std::string value = argv[++i];
    char* end = nullptr;
    const double number = std::strtod(value.c_str(), &end);
    const bool is_number = end != value.c_str() && *end == '\0';
    if (arg == "--dataset") {
      dataset_dir = value;
    } else if (arg == "--grade") {
      grade = value;
    } else if (is_number && arg == "--hours" && number > 0.0) {
      hours = number;
    } else if (is_number && arg == "--rate" && number > 0.0) {
      rate_hz = number;
    } else if (is_number && arg == "--seed" && number >= 0.0) {
      seed = static_cast<uint64_t>(number);
    } else if (is_number && arg == "--points-per-decade" && number >= 1.0) {
      points_per_decade = static_cast<int>(number);
    } else {
      std::cerr << "imu_allan: bad option " << arg << " " << value << "\n" << kUsage;
      return 2;
    }
  }
  if (dataset_dir.empty() == grade.empty()) {
    std::cerr << "imu_allan: give exactly one of --dataset and --grade\n" << kUsage;
    return 2;
  }
  std::vector<double> gyro[3], accel[3];
  try {
    if (!grade.empty()) {
      const ImuErrorParams params = imuGrade(grade);
      ImuErrorModel model(params, rate_hz, seed);
      const size_t samples = static_cast<size_t>(std::llround(hours * 3600.0 * rate_hz));
      ImuSample truth;  // static: zero rate and zero specific force
      for (size_t k = 0; k < samples; ++k) {
        truth.timestamp_s = static_cast<double>(k) / rate_hz;
        const ImuSample m = model.measure(truth);
        for (int i = 0; i < 3; ++i) {
          gyro[i].push_back(m.angular_velocity_radps[i]);
          accel[i].push_back(m.specific_force_mps2[i]);
        }
      }
      std::printf("# grade %s, static, %.3g h at %.4g Hz, seed %llu\n", grade.c_str(), hours, rate_hz,
                  static_cast<unsigned long long>(seed));
      printTable(gyro, accel, 1.0 / rate_hz, points_per_decade, &params);
    } else {
      const Dataset dataset = Dataset::open(dataset_dir);
      const std::vector<ImuSample>& imu = dataset.imu();
      if (imu.size() < 4) {
        std::cerr << "imu_allan: " << dataset_dir << " has " << imu.size() << " IMU samples\n";
        return 1;
      }
      std::vector<double> steps;
      for (size_t k = 1; k < imu.size(); ++k) steps.push_back(imu[k].timestamp_s - imu[k - 1].timestamp_s);
      std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
      const double dt = steps[steps.size() / 2];
      for (const ImuSample& s : imu)
        for (int i = 0; i < 3; ++i) {
          gyro[i].push_back(s.angular_velocity_radps[i]);
          accel[i].push_back(s.specific_force_mps2[i]);
        }
      std::printf("# dataset %s: %zu IMU samples, median period %.6g s (%.4g Hz), %.4g s\n",
                  dataset_dir.c_str(), imu.size(), dt, 1.0 / dt,
                  imu.back().timestamp_s - imu.front().timestamp_s);
      printTable(gyro, accel, dt, points_per_decade, nullptr);
    }
  } catch (const std::exception& e) {
    std::cerr << "imu_allan: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
