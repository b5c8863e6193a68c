#include "planetary_vo/render/sequence_renderer.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "planetary_vo/render/terrain_truth.h"

namespace planetary_vo::render {

namespace fs = std::filesystem;

SequenceSetup prepareSequence(const SequenceOptions& o) {
  if (o.width < 16 || o.height < 16) throw std::invalid_argument("image size must be at least 16x16");
  if (!(o.rate_hz > 0.0 && o.rate_hz <= 30.0)) throw std::invalid_argument("rate must be in (0, 30] Hz");
  if (!(o.sun_elevation_deg > 0.0 && o.sun_elevation_deg <= 90.0))
    throw std::invalid_argument("sun elevation must be in (0, 90] deg");
  if (o.dem_yaml.empty()) throw std::invalid_argument("no DEM given");
  if (o.sensors.camera.enabled && o.noise_sigma_dn > 0.0)
    throw std::invalid_argument(
        "--noise is the ideal camera's simple noise; the flight camera has its own model");
  if (!(o.imu_rate_hz > 0.0) || !(o.altimeter_rate_hz > 0.0))
    throw std::invalid_argument("IMU and altimeter rates must be positive");
  const SequenceSpec& spec = findSequence(o.sequence);
  DescentTrajectory trajectory = DescentTrajectory::fromSequence(spec);
  auto dem = LunarDem::load(o.dem_yaml);
  TerrainParams tp;
  tp.seed = o.seed;
  auto terrain =
      std::make_shared<const LunarTerrain>(dem, placeTrajectoryOnDem(*dem, trajectory, o.placement_rank), tp);
  RenderSettings rs;
  rs.camera = PinholeCamera::fromFieldOfView(o.width, o.height, o.fov_deg);
  if (o.sensors.camera.enabled) {
    rs.camera = sensors::trueCamera(rs.camera, o.sensors.camera);
    rs.output_reflectance = true;
  }
  rs.sun_direction = sunDirection(o.sun_elevation_deg, o.sun_azimuth_deg);
  rs.noise_sigma_dn = o.noise_sigma_dn;
  rs.noise_seed = o.seed;
  rs.num_threads = o.num_threads;
  const double duration =
      o.duration_s < 0 ? trajectory.duration() : std::min(o.duration_s, trajectory.duration());
  if (!(o.start_s >= 0.0) || !(o.start_s < duration))
    throw std::invalid_argument("the start time must be >= 0 and below the end of the sequence (" +
                                std::to_string(duration) + " s)");
  const size_t frames = static_cast<size_t>(std::floor((duration - o.start_s) * o.rate_hz + 1e-9)) + 1;
  return SequenceSetup{spec, dem, terrain, trajectory, rs, duration, o.start_s, frames};
}

namespace {

std::string fnv1aHex(const std::string& text) {
  uint64_t h = 1469598103934665603ull;  // FNV-1a: stable across runs and platforms (std::hash is not)
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  char buf[17];
  std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

}  // namespace

std::string sequenceParamHash(const SequenceOptions& o) {
  std::ostringstream os;
  os.precision(17);
  os << kRendererVersion << '|' << o.sequence << '|' << fs::path(o.dem_yaml).filename().string() << '|'
     << (fs::exists(o.dem_yaml) ? fs::file_size(o.dem_yaml) : 0) << '|' << o.width << 'x' << o.height << '|'
     << o.fov_deg << '|' << o.rate_hz << '|' << o.duration_s << '|' << o.seed << '|' << o.sun_elevation_deg
     << '|' << o.sun_azimuth_deg << '|' << o.noise_sigma_dn << '|' << o.imu_rate_hz << '|'
     << o.altimeter_rate_hz << '|' << o.save_depth;
  // Appended only when not the defaults of renderer 1.2, so that its (ideal) renders keep their hash.
  if (o.placement_rank != 0) os << "|placement_rank " << o.placement_rank;
  if (o.start_s != 0.0) os << "|start_s " << o.start_s;
  if (o.sensors.camera.enabled)
    os << "|camera " << sensors::yamlText(sensors::toYaml(o.sensors.camera)) << "|sensor_seed "
       << o.sensor_seed;
  return fnv1aHex(os.str());
}

std::string streamsParamHash(const SequenceOptions& o) {
  std::ostringstream os;
  os << kStreamsVersion << '|' << sequenceParamHash(o) << "|imu "
     << sensors::yamlText(sensors::toYaml(o.sensors.imu)) << "|altimeter "
     << sensors::yamlText(sensors::toYaml(o.sensors.altimeter)) << "|camera "
     << sensors::yamlText(sensors::toYaml(o.sensors.camera)) << "|sensor_seed " << o.sensor_seed;
  os.precision(17);
  os << "|landing_area " << o.landing_area.half_extent_m << ' ' << o.landing_area.cell_size_m << ' '
     << o.landing_area.footprint_diameter_m;
  return fnv1aHex(os.str());
}

AltimeterTruth altimeterTruthAt(const LunarTerrain& terrain, const DescentTrajectory& trajectory, double t) {
  const TrajectoryState s = trajectory.state(t);
  AltimeterTruth a;
  a.timestamp_s = t;
  a.altitude_m = s.position.z() - terrain.height(s.position.x(), s.position.y(), kAltimeterLodM);
  const Eigen::Vector3d boresight = s.R_world_cam.col(2);
  const auto range = castRayOnTerrain(terrain, s.position, boresight, kAltimeterLodM, 50000.0);
  a.true_range_m = range ? *range : std::numeric_limits<double>::infinity();
  a.incidence_deg = std::numeric_limits<double>::quiet_NaN();
  if (range) {
    const Eigen::Vector3d hit = s.position + *range * boresight;
    const Eigen::Vector3d n = terrain.normal(hit.x(), hit.y(), kAltimeterLodM);
    a.incidence_deg = std::acos(std::clamp(-n.dot(boresight), -1.0, 1.0)) * 180.0 / M_PI;
  }
  return a;
}

sensors::RayCaster terrainRayCaster(const LunarTerrain& terrain) {
  return [&terrain](const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double start_range_m,
                    double max_range_m) -> std::optional<sensors::RayHit> {
    const Eigen::Vector3d start = origin + start_range_m * direction;
    // A start point under the terrain means the terrain is hit before it (the model then recasts from the
    // instrument).
    if (start.z() <= terrain.height(start.x(), start.y(), kAltimeterLodM))
      return sensors::RayHit{start_range_m, terrain.normal(start.x(), start.y(), kAltimeterLodM)};
    const auto range =
        castRayOnTerrain(terrain, start, direction, kAltimeterLodM, max_range_m - start_range_m);
    if (!range) return std::nullopt;
    const Eigen::Vector3d hit = start + *range * direction;
    return sensors::RayHit{start_range_m + *range, terrain.normal(hit.x(), hit.y(), kAltimeterLodM)};
  };
}

namespace {

/// key: value lines of render_stamp.txt ("" when absent).
std::map<std::string, std::string> readStamp(const std::string& dir) {
  std::map<std::string, std::string> stamp;
  std::ifstream in(dir + "/render_stamp.txt");
  for (std::string line; std::getline(in, line);) {
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string value = line.substr(colon + 1);
    value.erase(0, value.find_first_not_of(' '));
    stamp[line.substr(0, colon)] = value;
  }
  return stamp;
}

void writeStamp(const std::string& dir, const std::string& image_hash, const std::string& streams_hash,
                size_t frames) {
  std::ofstream(dir + "/render_stamp.txt") << "param_hash: " << image_hash << "\nframes: " << frames
                                           << "\ncomplete: true\nstreams_hash: " << streams_hash << "\n";
}

size_t countImages(const std::string& dir) {
  size_t n = 0;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir + "/images", ec))
    if (e.path().extension() == ".png") ++n;
  return n;
}

double processCpuSeconds() {
  struct rusage u {};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

std::string vec3(const Eigen::Vector3d& v) {
  std::ostringstream os;
  os.precision(12);
  os << "[" << v.x() << ", " << v.y() << ", " << v.z() << "]";
  return os.str();
}

std::string mat3(const Eigen::Matrix3d& m) {
  std::ostringstream os;
  os.precision(15);
  os << "[";
  for (int i = 0; i < 9; ++i) os << (i ? ", " : "") << m(i / 3, i % 3);
  os << "]";
  return os.str();
}

std::string cameraText(const PinholeCamera& c) {
  std::ostringstream os;
  os.precision(12);
  os << "{fx: " << c.fx() << ", fy: " << c.fy() << ", cx: " << c.cx() << ", cy: " << c.cy()
     << ", distortion_model: " << (c.distortionModel().empty() ? "none" : c.distortionModel())
     << ", distortion: [";
  for (size_t i = 0; i < c.distortion().size(); ++i) os << (i ? ", " : "") << c.distortion()[i];
  os << "]}";
  return os.str();
}

/// sensors.yaml: the sensors as their user knows them (data sheet and nominal mounting), what an estimator
/// may use. Never the errors drawn for this run.
std::string sensorsSpecYaml(const SequenceOptions& o) {
  const sensors::SensorSuiteParams& p = o.sensors;
  std::ostringstream y;
  y.precision(10);
  y << "# The sensors as their data sheets and mounting drawings give them (what an estimator may use).\n"
    << "# The errors drawn for this run are ground truth: groundtruth_sensors.yaml (evaluator only).\n"
    << "preset: " << p.preset << "\n"
    << "camera:\n"
    << "  model: " << (p.camera.enabled ? "flight camera (docs/sensors/camera.md)" : "ideal pinhole") << "\n"
    << "  calibration: camera.yaml\n"
    << "  bit_depth: " << (p.camera.enabled ? p.camera.bit_depth : 8) << "\n"
    << "  png_storage: " << (p.camera.enabled ? "16-bit, MSB-aligned (value << (16 - bit_depth))" : "8-bit")
    << "\n"
    << "  exposure_telemetry: " << (p.camera.enabled ? "image_exposure.txt" : "none") << "\n"
    << "  timestamp: mid-exposure\n"
    << "imu:\n"
    << "  rate_hz: " << o.imu_rate_hz << "\n"
    << "  grade: \"" << (p.imu.enabled ? p.imu.grade : std::string("ideal")) << "\"\n"
    << "  T_cam_imu_nominal: identity  # IMU axes = camera optical frame axes, co-located\n"
    << "  gyro_noise_density_radps_per_sqrt_hz: " << p.imu.gyro.white_noise_density << "\n"
    << "  gyro_bias_instability_radps: " << p.imu.gyro.bias_instability << "\n"
    << "  gyro_random_walk_radps2_per_sqrt_hz: " << p.imu.gyro.bias_random_walk << "\n"
    << "  gyro_turn_on_bias_radps: " << p.imu.gyro.turn_on_bias << "\n"
    << "  accel_noise_density_mps2_per_sqrt_hz: " << p.imu.accel.white_noise_density << "\n"
    << "  accel_bias_instability_mps2: " << p.imu.accel.bias_instability << "\n"
    << "  accel_random_walk_mps3_per_sqrt_hz: " << p.imu.accel.bias_random_walk << "\n"
    << "  accel_turn_on_bias_mps2: " << p.imu.accel.turn_on_bias << "\n"
    << "altimeter:\n"
    << "  rate_hz: " << o.altimeter_rate_hz << "\n"
    << "  boresight: camera optical axis (+z of the camera frame), co-located\n"
    << "  no_return: inf\n"
    << "  range_noise_floor_m: " << (p.altimeter.enabled ? p.altimeter.range_noise_floor_m : 0.0) << "\n"
    << "  range_noise_fraction: " << (p.altimeter.enabled ? p.altimeter.range_noise_fraction : 0.0) << "\n"
    << "  max_range_m: " << p.altimeter.max_range_m << "\n"
    << "  min_range_m: " << (p.altimeter.enabled ? p.altimeter.min_range_m : 0.0) << "\n"
    << "  beam_divergence_rad: " << (p.altimeter.enabled ? p.altimeter.beam_divergence_rad : 0.0) << "\n";
  return y.str();
}

}  // namespace

std::string formatStats(size_t frame, const RenderStats& st) {
  char buf[320];
  std::snprintf(
      buf, sizeof(buf),
      "frame %zu: %.0f ms = region %.1f + bake %.0f (%d/%d chunks) + assemble %.0f + shadows %.0f + "
      "trace %.0f ms (%d levels, %.1f steps/ray, slope bound %.2f)",
      frame, st.setup_ms + st.shadow_ms + st.trace_ms, st.region_ms, st.bake_ms, st.chunks_baked,
      st.chunks_used, st.assemble_ms, st.shadow_ms, st.trace_ms, st.levels, st.mean_ray_steps, st.lipschitz);
  return buf;
}

namespace {

std::string indented(const std::string& text, int spaces) {
  std::istringstream in(text);
  std::ostringstream out;
  for (std::string line; std::getline(in, line);) out << std::string(spaces, ' ') << line << "\n";
  return out.str();
}

/// sequence.yaml: how the sequence was made (no error drawn for the run: those are in
/// groundtruth_sensors.yaml).
std::string sequenceYaml(const SequenceOptions& o, const SequenceSetup& setup, const SequenceResult& result) {
  std::ostringstream y;
  y.precision(10);
  const DemPlacement& pl = setup.terrain->placement();
  const Eigen::Vector3d& sun = setup.settings.sun_direction;
  y << "# Synthetic Lunar descent rendered by lunar_render (planetary_vo docs/rendering.md)\n"
    << "name: " << o.sequence << "\n"
    << "renderer_version: \"" << kRendererVersion << "\"\n"
    << "streams_version: \"" << kStreamsVersion << "\"\n"
    << "param_hash: \"" << result.param_hash << "\"\n"
    << "streams_hash: \"" << result.streams_hash << "\"\n"
    << "world_frame: \"landing site: x crossrange, y downrange, z up (altitude); ground truth "
       "T_world_cam\"\n"
    << "trajectory:\n"
    << setup.trajectory.describeYaml(2) << "camera_mode: " << toString(setup.spec.mode) << "\n"
    << "start_s: " << setup.start_s << "\n"
    << "duration_s: " << setup.duration_s << "\n"
    << "rate_hz: " << o.rate_hz << "\n"
    << "frames: " << setup.num_frames << "\n"
    << "resolution: [" << o.width << ", " << o.height << "]\n"
    << "fov_deg: " << o.fov_deg << "\n"
    << "seed: " << o.seed << "\n"
    << "sun:\n  elevation_deg: " << o.sun_elevation_deg << "\n  azimuth_deg: " << o.sun_azimuth_deg
    << "\n  direction_world: [" << sun.x() << ", " << sun.y() << ", " << sun.z() << "]\n"
    << "photometry: lunar_lambert_mcewen\n"
    << "noise_sigma_dn: " << o.noise_sigma_dn << "\n"
    << "dem:\n  file: " << fs::path(o.dem_yaml).filename().string()
    << "\n  placement_rank: " << o.placement_rank << "\n  origin_east_m: " << pl.origin_east_m
    << "\n  origin_north_m: " << pl.origin_north_m << "\n  heading_deg: " << pl.heading_rad * 180.0 / M_PI
    << "\n  datum_m: " << pl.datum_m << "\n"
    << "imu_rate_hz: " << o.imu_rate_hz << "\n"
    << "altimeter_rate_hz: " << o.altimeter_rate_hz << "\n"
    << "depth_saved: " << (o.save_depth ? "true" : "false") << "\n"
    << "sensor_seed: " << o.sensor_seed << "\n"
    << "sensors:  # every parameter of the error models (docs/sensors/)\n"
    << indented(sensors::yamlText(sensors::toYaml(o.sensors)), 2);
  return y.str();
}

}  // namespace

SequenceResult renderSequence(const SequenceOptions& o, const ProgressFn& progress) {
  if (o.output_dir.empty()) throw std::invalid_argument("no output directory");
  SequenceResult result;
  result.param_hash = sequenceParamHash(o);
  result.streams_hash = streamsParamHash(o);
  const SequenceSetup setup = prepareSequence(o);
  const sensors::SensorSuiteParams& sp = o.sensors;
  std::map<std::string, std::string> stamp = readStamp(o.output_dir);
  const bool images_cached = !o.force && stamp["param_hash"] == result.param_hash &&
                             stamp["frames"] == std::to_string(setup.num_frames) &&
                             stamp["complete"] == "true" && countImages(o.output_dir) == setup.num_frames &&
                             (!sp.camera.enabled || fs::exists(o.output_dir + "/image_exposure.txt"));
  if (images_cached && stamp["streams_hash"] == result.streams_hash &&
      fs::exists(o.output_dir + "/sequence.yaml")) {
    result.skipped = true;
    result.frames = setup.num_frames;
    return result;
  }
  // Whatever is rewritten is removed first, so that an interrupted run is never taken as complete.
  std::error_code ec;
  fs::remove(o.output_dir + "/render_stamp.txt", ec);
  for (const char* f : {"groundtruth_state.txt", "groundtruth_altimeter.txt", "groundtruth_camera.yaml",
                        "groundtruth_sensors.yaml", "sensors.yaml"})
    fs::remove(o.output_dir + "/" + f, ec);
  std::vector<fs::path> terrain_files;  // groundtruth_terrain.yaml and its layers
  for (const auto& e : fs::directory_iterator(o.output_dir, ec))
    if (e.path().filename().string().rfind(kGroundTruthTerrainName, 0) == 0)
      terrain_files.push_back(e.path());
  for (const fs::path& f : terrain_files) fs::remove(f, ec);
  if (!images_cached) {
    fs::remove_all(o.output_dir + "/images", ec);
    fs::remove_all(o.output_dir + "/depth", ec);
    fs::remove(o.output_dir + "/image_exposure.txt", ec);
    if (o.save_depth) fs::create_directories(o.output_dir + "/depth");
  }

  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = processCpuSeconds();
  const PinholeCamera& true_camera = setup.settings.camera;
  const PinholeCamera calibrated =
      sp.camera.enabled
          ? sensors::calibratedCamera(true_camera, sp.camera, sensors::subSeed(o.sensor_seed, "calibration"))
          : true_camera;
  std::ostringstream truth_yaml;
  truth_yaml.precision(12);
  truth_yaml << "# GROUND TRUTH (evaluator only): the errors drawn for this run (sensor_seed "
             << o.sensor_seed << ")\nsensor_seed: " << o.sensor_seed
             << "\ncamera:\n  true: " << cameraText(true_camera)
             << "\n  calibrated: " << cameraText(calibrated) << "\n";
  {
    DatasetWriter writer(o.output_dir, calibrated);
    if (sp.camera.enabled) writer.setTrueCamera(true_camera);
    if (images_cached) {
      result.images_reused = true;
      for (size_t i = 0; i < setup.num_frames; ++i) {
        const double t = setup.frameTime(i, o.rate_hz);
        writer.addExistingFrame(t, setup.trajectory.state(t).T_world_cam());
      }
    } else {
      Renderer renderer(setup.terrain, setup.settings);
      std::unique_ptr<sensors::CameraSensor> sensor;
      std::ofstream exposure_log;
      if (sp.camera.enabled) {
        sensor = std::make_unique<sensors::CameraSensor>(sp.camera, o.width, o.height,
                                                         sensors::subSeed(o.sensor_seed, "camera"));
        exposure_log.open(o.output_dir + "/image_exposure.txt.part");
        exposure_log
            << "# timestamp[s] exposure_s: the camera's exposure time of each image (telemetry); the "
               "stamp is mid-exposure\n";
        exposure_log.precision(9);
      }
      cv::Mat2f disp_start, disp_end;
      for (size_t i = 0; i < setup.num_frames; ++i) {
        const double t = setup.frameTime(i, o.rate_hz);
        const Pose T = setup.trajectory.state(t).T_world_cam();
        const RenderOutput out = renderer.render(T, i);
        if (o.verbose) std::fprintf(stderr, "%s\n", formatStats(i, out.stats).c_str());
        if (!sensor) {
          writer.addFrame(t, out.image, T);
        } else {
          // The image is stamped at mid-exposure: the scene moves from t - e/2 to t + e/2 while it
          // integrates.
          if (i == 0) sensor->settleExposure(out.reflectance);
          const double exposure_s = sensor->exposureS();
          cv::Mat1f radiance = out.reflectance;
          if (sp.camera.motion_blur && exposure_s > 0.0) {
            const Pose T_start = setup.trajectory.state(t - 0.5 * exposure_s).T_world_cam();
            const Pose T_end = setup.trajectory.state(t + 0.5 * exposure_s).T_world_cam();
            sensors::imageMotionFromDepth(out.depth, true_camera, T.inverse() * T_start, T.inverse() * T_end,
                                          &disp_start, &disp_end);
            radiance = sensors::motionBlur(out.reflectance, disp_start, disp_end, sp.camera.max_blur_samples);
          }
          sensors::FrameExposure info;
          const cv::Mat1w raw = sensor->expose(radiance, i, &info);
          writer.addFrame(t, sensor->toPng16(raw), T);
          exposure_log << t << " " << info.exposure_s << "\n";
        }
        if (o.save_depth) {
          char name[64];
          std::snprintf(name, sizeof(name), "/depth/%06zu.tiff", i);
          if (!cv::imwrite(o.output_dir + name, out.depth))
            throw std::runtime_error("cannot write depth image");
        }
        if (progress)
          progress(i + 1, setup.num_frames,
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      }
      if (sensor) {
        exposure_log.close();
        if (!exposure_log) throw std::runtime_error("cannot write " + o.output_dir + "/image_exposure.txt");
        fs::rename(o.output_dir + "/image_exposure.txt.part", o.output_dir + "/image_exposure.txt");
      }
    }
    const double cpu1 = processCpuSeconds();
    result.render_cpu_s = cpu1 - cpu0;

    // IMU: the true sample of the trajectory through the error model; the true state with the model's biases.
    sensors::ImuErrorModel imu(sp.imu, o.imu_rate_hz, sensors::subSeed(o.sensor_seed, "imu"));
    const int n_imu = static_cast<int>(std::floor((setup.duration_s - setup.start_s) * o.imu_rate_hz + 1e-9));
    for (int i = 0; i <= n_imu; ++i) {
      const double t = setup.frameTime(i, o.imu_rate_hz);
      writer.addImu(imu.measure(setup.trajectory.imu(t)));
      const TrajectoryState s = setup.trajectory.state(t);
      writer.addGroundTruthState({t, s.T_world_cam(), s.velocity, imu.trueErrors().gyro_bias_radps,
                                  imu.trueErrors().accel_bias_mps2});
      if (i == 0)
        truth_yaml << "imu:\n  grade: \"" << sp.imu.grade << "\"\n  R_imu_body: " << mat3(imu.R_imu_body())
                   << "\n  gyro_scale_misalignment: " << mat3(imu.gyroScaleMisalignment())
                   << "\n  accel_scale_misalignment: " << mat3(imu.accelScaleMisalignment())
                   << "\n  gyro_bias_at_start_radps: " << vec3(imu.trueErrors().gyro_bias_radps)
                   << "\n  accel_bias_at_start_mps2: " << vec3(imu.trueErrors().accel_bias_mps2) << "\n";
    }
    // Altimeter: the instrument's reading goes to the stream, its ground truth (true range, altitude,
    // incidence, outlier) to groundtruth_altimeter.txt.
    sensors::AltimeterModel altimeter(sp.altimeter, sensors::subSeed(o.sensor_seed, "altimeter"));
    const sensors::RayCaster caster = terrainRayCaster(*setup.terrain);
    const int n_alt =
        static_cast<int>(std::floor((setup.duration_s - setup.start_s) * o.altimeter_rate_hz + 1e-9));
    double range_bias_m = 0.0;
    for (int i = 0; i <= n_alt; ++i) {
      const double t = setup.frameTime(i, o.altimeter_rate_hz);
      const TrajectoryState s = setup.trajectory.state(t);
      const sensors::AltimeterReading r =
          altimeter.measure(t, s.position, s.R_world_cam.col(2), -s.R_world_cam.col(1), caster);
      writer.addAltimeter({t, r.range_m});
      AltimeterTruth a;
      a.timestamp_s = t;
      a.true_range_m = r.true_range_m;
      a.altitude_m = s.position.z() - setup.terrain->height(s.position.x(), s.position.y(), kAltimeterLodM);
      a.incidence_deg = r.incidence_deg;
      a.returned = r.returned;
      a.outlier = r.outlier;
      writer.addAltimeterTruth(a);
      range_bias_m = r.bias_m;
    }
    truth_yaml << "altimeter:\n  range_bias_m: " << range_bias_m << "\n";
    // The true terrain of the landing area, from the terrain the images were rendered from.
    terrain::writeGridSet(o.output_dir, kGroundTruthTerrainName,
                          groundTruthTerrain(*setup.terrain, o.landing_area));

    writer.setSequenceYaml(sequenceYaml(o, setup, result));
    writer.setTextFile("sensors.yaml", sensorsSpecYaml(o));
    writer.setTextFile("groundtruth_sensors.yaml", truth_yaml.str());
    writer.finish();
    result.streams_cpu_s = processCpuSeconds() - cpu1;
  }
  result.frames = setup.num_frames;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  result.frames_per_second = result.frames / std::max(result.seconds, 1e-9);
  writeStamp(o.output_dir, result.param_hash, result.streams_hash, setup.num_frames);
  return result;
}

ProgressFn makeProgressBar() {
  auto last = std::make_shared<double>(-1.0);
  return [last](size_t done, size_t total, double elapsed) {
    if (done < total && elapsed - *last < 0.25) return;
    *last = elapsed;
    const int width = 30, filled = static_cast<int>(width * done / std::max<size_t>(total, 1));
    const double rate = done / std::max(elapsed, 1e-9);
    const double eta = (total - done) / std::max(rate, 1e-9);
    std::fprintf(stderr, "\r[%s%s] %zu/%zu frames  %.2f fps  ETA %02d:%02d:%02d ",
                 std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(), done, total,
                 rate, static_cast<int>(eta) / 3600, static_cast<int>(eta) / 60 % 60,
                 static_cast<int>(eta) % 60);
    if (done == total) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  };
}

}  // namespace planetary_vo::render
