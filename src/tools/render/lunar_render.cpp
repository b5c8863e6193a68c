/// lunar_render: renders the synthetic Lunar descent sequences (docs/rendering.md) with the sensors' error
/// models (docs/sensors/).
///   lunar_render --sequence NAME --output DIR [--width W --height H --rate HZ --duration S --start S
///                --seed N --dem FILE.yaml --placement-rank K --sun-elevation DEG --sun-azimuth DEG
///                --sensors flight|ideal --sensor-seed N --imu-grade G --sensor-config FILE.yaml
///                --set SECTION.KEY=VALUE ... --noise SIGMA --depth --force --progress --verbose --threads N]
///   lunar_render --sequence NAME --snapshot T --output FILE.png [same options]   one frame at time T
///   lunar_render --list

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include <unistd.h>

#include <opencv2/imgcodecs.hpp>

#include "planetary_vo/render/renderer.h"
#include "planetary_vo/render/sequence_renderer.h"
#include "planetary_vo/sensors/camera_sensor.h"
#include "planetary_vo/sensors/sensor_suite.h"

using namespace planetary_vo;
using namespace planetary_vo::render;

namespace {

int usage(const char* msg) {
  if (msg) std::cerr << "lunar_render: " << msg << "\n";
  std::cerr
      << "usage: lunar_render --sequence NAME --output DIR [--width W] [--height H] [--rate HZ] "
         "[--duration S] [--start S] [--seed N] [--dem FILE.yaml|NAME] [--placement-rank K] "
         "[--sun-elevation DEG] [--sun-azimuth DEG] [--sensors flight|ideal] [--sensor-seed N] [--imu-grade "
         "navigation|tactical|mems|ideal] [--sensor-config FILE.yaml] [--set SECTION.KEY=VALUE]... "
         "[--noise SIGMA_DN] [--depth] [--force] [--progress] [--verbose] [--threads N] [--snapshot T]\n"
         "       lunar_render --print-sensors [--sensors P] [--imu-grade G] [--sensor-config F] [--set ...]\n"
         "       lunar_render --list\n"
         "  --sensors        sensor preset (default flight: every error model on; ideal: the perfect data "
         "of\n"
         "                   renderer 1.2, bit for bit); then --imu-grade, --sensor-config and --set "
         "override it\n"
         "                   in that order (docs/sensors/ lists every parameter)\n"
         "  --sensor-seed    seed of every sensor error (noise, biases, calibration error, defects); default "
         "1\n"
         "  --seed           seed of the procedural terrain (craters, boulders, roughness); default 1\n"
         "  --duration, --start  the sequence up to / from that time (s); every stream keeps its time "
         "stamps\n"
         "  --placement-rank 0 = the best placement of the trajectory on the DEM, k = the k-th next distinct "
         "one\n"
         "  --print-sensors  print the effective sensor parameters as YAML and exit\n";
  return 2;
}

std::string dataDir() {
  const char* env = std::getenv("PLANETARY_VO_DATA");
  return env && *env ? env : PLANETARY_VO_DATA_DIR;
}

}  // namespace

int main(int argc, char** argv) {
  SequenceOptions o;
  o.dem_yaml = "apollo15_gld100";
  bool progress = isatty(STDERR_FILENO), list = false, print_sensors = false;
  double snapshot = -1.0;
  std::string preset = "flight", imu_grade, sensor_config;
  std::vector<std::string> overrides;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto next = [&]() -> std::string {
        if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
        return argv[++i];
      };
      if (a == "--sequence")
        o.sequence = next();
      else if (a == "--output")
        o.output_dir = next();
      else if (a == "--width")
        o.width = std::stoi(next());
      else if (a == "--height")
        o.height = std::stoi(next());
      else if (a == "--rate")
        o.rate_hz = std::stod(next());
      else if (a == "--duration")
        o.duration_s = std::stod(next());
      else if (a == "--start")
        o.start_s = std::stod(next());
      else if (a == "--seed")
        o.seed = std::stoull(next());
      else if (a == "--dem")
        o.dem_yaml = next();
      else if (a == "--sun-elevation")
        o.sun_elevation_deg = std::stod(next());
      else if (a == "--sun-azimuth")
        o.sun_azimuth_deg = std::stod(next());
      else if (a == "--sensors")
        preset = next();
      else if (a == "--sensor-seed")
        o.sensor_seed = std::stoull(next());
      else if (a == "--imu-grade")
        imu_grade = next();
      else if (a == "--sensor-config")
        sensor_config = next();
      else if (a == "--set")
        overrides.push_back(next());
      else if (a == "--placement-rank")
        o.placement_rank = std::stoi(next());
      else if (a == "--print-sensors")
        print_sensors = true;
      else if (a == "--noise")
        o.noise_sigma_dn = std::stod(next());
      else if (a == "--threads")
        o.num_threads = std::stoi(next());
      else if (a == "--snapshot")
        snapshot = std::stod(next());
      else if (a == "--depth")
        o.save_depth = true;
      else if (a == "--force")
        o.force = true;
      else if (a == "--verbose")
        o.verbose = true;
      else if (a == "--progress")
        progress = true;
      else if (a == "--no-progress")
        progress = false;
      else if (a == "--list")
        list = true;
      else if (a == "-h" || a == "--help")
        return usage(nullptr), 0;
      else
        return usage(("unknown option " + a).c_str());
    }
    o.sensors = sensors::sensorPreset(preset);
    if (!imu_grade.empty()) o.sensors.imu = sensors::imuGrade(imu_grade);  // "ideal" = no IMU error
    if (!sensor_config.empty()) sensors::readYamlFile(sensor_config, &o.sensors);
    for (const std::string& assignment : overrides) sensors::applyOverride(assignment, &o.sensors);
    if (print_sensors) {
      std::cout << sensors::yamlText(sensors::toYaml(o.sensors)) << "\n";
      return 0;
    }
    if (list) {
      for (const SequenceSpec& s : lunarSequences())
        std::cout << s.name << "  (" << toString(s.phase) << ", " << toString(s.mode) << ")\n";
      return 0;
    }
    if (o.output_dir.empty()) return usage("--output is required");
    // A bare DEM name refers to the shared data folder.
    if (o.dem_yaml.find('/') == std::string::npos && o.dem_yaml.find(".yaml") == std::string::npos)
      o.dem_yaml = dataDir() + "/lunar_dem/" + o.dem_yaml + ".yaml";

    if (snapshot >= 0.0) {
      const SequenceSetup setup = prepareSequence(o);
      Renderer renderer(setup.terrain, setup.settings);
      const Pose T = setup.trajectory.state(snapshot).T_world_cam();
      const RenderOutput out = renderer.render(T);
      cv::Mat image = out.image;
      if (o.sensors.camera.enabled) {
        // One frame of the flight camera: settled exposure, motion blur, sensor; saved as its 16-bit PNG.
        sensors::CameraSensor sensor(o.sensors.camera, o.width, o.height,
                                     sensors::subSeed(o.sensor_seed, "camera"));
        sensor.settleExposure(out.reflectance);
        const double e = sensor.exposureS();
        cv::Mat1f radiance = out.reflectance;
        if (o.sensors.camera.motion_blur) {
          cv::Mat2f ds, de;
          sensors::imageMotionFromDepth(
              out.depth, setup.settings.camera,
              T.inverse() * setup.trajectory.state(snapshot - 0.5 * e).T_world_cam(),
              T.inverse() * setup.trajectory.state(snapshot + 0.5 * e).T_world_cam(), &ds, &de);
          radiance = sensors::motionBlur(out.reflectance, ds, de, o.sensors.camera.max_blur_samples);
        }
        image = sensor.toPng16(sensor.expose(radiance, 0));
        std::cerr << "flight camera: exposure " << e * 1e3 << " ms\n";
      }
      if (!cv::imwrite(o.output_dir, image)) throw std::runtime_error("cannot write " + o.output_dir);
      std::cerr << "rendered " << o.width << "x" << o.height << " t=" << snapshot
                << " s: " << formatStats(0, out.stats) << "\n";
      return 0;
    }
    const SequenceResult r = renderSequence(o, progress ? makeProgressBar() : ProgressFn());
    if (r.skipped)
      std::cout << "up to date (param hash " << r.param_hash << ", streams " << r.streams_hash << "), "
                << r.frames << " frames in " << o.output_dir << "\n";
    else if (r.images_reused)
      std::printf("images up to date; sensor streams written again in %.1f s (CPU %.1f s) -> %s\n", r.seconds,
                  r.streams_cpu_s, o.output_dir.c_str());
    else
      std::printf(
          "rendered %zu frames %dx%d (%s sensors) in %.1f s: %.2f frames/s; CPU %.1f s images + %.1f s "
          "streams -> %s\n",
          r.frames, o.width, o.height, o.sensors.preset.c_str(), r.seconds, r.frames_per_second,
          r.render_cpu_s, r.streams_cpu_s, o.output_dir.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "lunar_render: " << e.what() << "\n";
    return 1;
  }
}
