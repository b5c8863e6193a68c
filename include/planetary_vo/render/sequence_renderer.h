#pragma once
/// @file sequence_renderer.h
/// Renders a whole descent sequence into a planetary_vo dataset folder through DatasetWriter, with the
/// sensors' error models (sensors/sensor_suite.h), caching and progress reporting:
///  - what the sensors measure: images/ (8-bit for the ideal camera, 16-bit MSB-aligned raw frames for the
///    flight camera), times.txt, camera.yaml (the calibration, with its error), image_exposure.txt (the
///    camera's exposure telemetry), imu.txt, altimeter.txt, sensors.yaml (the sensors' specifications as a
///    user knows them), sequence.yaml;
///  - ground truth, for the evaluator only: groundtruth.txt, groundtruth_state.txt (pose, velocity, true IMU
///    biases at the IMU rate), groundtruth_altimeter.txt (true range, altitude, incidence),
///    groundtruth_camera.yaml (the real camera), groundtruth_sensors.yaml (every error drawn for this
///    run) and groundtruth_terrain.yaml + groundtruth_terrain_{elevation_m,slope_deg,roughness_m}.tiff (the
///    true terrain of the landing area, render/terrain_truth.h).
///
/// Caching: render_stamp.txt carries two hashes. The image hash covers everything that changes the pixels
/// (renderer version, sequence, DEM and its placement, size, rate, duration, terrain seed, Sun, camera sensor
/// parameters and the sensor seed); for the ideal camera it is the hash of renderer 1.2, so its renders stay
/// valid. The stream hash adds the IMU and altimeter parameters and the landing area of the terrain grids. A
/// complete render with the same image hash keeps its images and only writes the streams again when the
/// stream hash differs; nothing is done when both match.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/render/descent_trajectory.h"
#include "planetary_vo/render/renderer.h"
#include "planetary_vo/sensors/sensor_suite.h"
#include "planetary_vo/terrain/landing_area.h"

namespace planetary_vo::render {

/// Bump whenever a change alters rendered pixels or streams, so cached sequences are re-rendered.
/// (The ideal camera's images have not changed since 1.2; the streams and files of 1.3 are versioned by
/// kStreamsVersion.)
constexpr const char* kRendererVersion = "lunar_render 1.2";
/// Bump whenever the sensor streams or the dataset files change (IMU, altimeter, ground-truth files).
/// 1.4: the ground-truth terrain grids (groundtruth_terrain*).
constexpr const char* kStreamsVersion = "streams 1.4";

struct SequenceOptions {
  std::string sequence = "approach_down";  ///< one of lunarSequences()
  std::string output_dir;
  std::string dem_yaml;  ///< empty = <data>/lunar_dem/apollo15_gld100.yaml (caller resolves)
  int width = 1024, height = 1024;
  double fov_deg = 60.0;
  double rate_hz = 10.0;
  double duration_s = -1.0;  ///< the sequence up to this time (s); < 0: to its end
  /// The first frame's time (s): the sequence from here on, every stream (images, IMU, altimeter, ground
  /// truth) with its own time stamps, e.g. only the end of an approach for a hazard-map campaign. 0: from the
  /// start. Must be below the end.
  double start_s = 0.0;
  uint64_t seed = 1;
  double sun_elevation_deg = 12.0;
  double sun_azimuth_deg = 250.0;
  double noise_sigma_dn = 0.0;  ///< the old additive noise of the ideal camera (not with the flight camera)
  /// Sensor error models; the default is the flight preset (the default of lunar_render and the benchmark).
  sensors::SensorSuiteParams sensors = sensors::sensorPreset("flight");
  uint64_t sensor_seed = 1;  ///< seeds every sensor error (noise, biases, calibration error, defects)
  /// 0: the best placement of the trajectory on the DEM; k > 0: the k-th next best distinct one (another
  /// track over other relief, for dispersed campaigns).
  int placement_rank = 0;
  double imu_rate_hz = 200.0;
  double altimeter_rate_hz = 20.0;
  /// Extent, cell and lander footprint of the ground-truth terrain grids (render/terrain_truth.h).
  terrain::LandingAreaParams landing_area;
  bool save_depth = false;  ///< depth/NNNNNN.tiff (32-bit float z-depth in m)
  bool force = false;       ///< render even if a complete identical render exists
  int num_threads = 0;
  bool verbose = false;  ///< per-frame timing of every render phase on stderr (not part of the hash)
};

struct SequenceResult {
  bool skipped = false;        ///< up to date, nothing rendered
  bool images_reused = false;  ///< cached images kept, only the streams written again
  size_t frames = 0;
  double seconds = 0.0;
  double frames_per_second = 0.0;
  std::string param_hash;      ///< the image hash
  std::string streams_hash;    ///< the image hash + IMU, altimeter and landing-area parameters
  double render_cpu_s = 0.0;   ///< process CPU time spent on the images (all threads)
  double streams_cpu_s = 0.0;  ///< process CPU time spent on IMU, altimeter, terrain grids and files
};

/// Progress callback: (frames done, total frames, seconds elapsed).
using ProgressFn = std::function<void(size_t, size_t, double)>;

/// Everything needed to render a sequence: DEM, placement, terrain, trajectory, renderer settings.
struct SequenceSetup {
  SequenceSpec spec;
  std::shared_ptr<const LunarDem> dem;
  std::shared_ptr<const LunarTerrain> terrain;
  DescentTrajectory trajectory;
  RenderSettings settings;
  double duration_s = 0.0;  ///< the end time (s)
  double start_s = 0.0;     ///< the first frame's time (s)
  size_t num_frames = 0;
  double frameTime(size_t i, double rate_hz) const { return start_s + static_cast<double>(i) / rate_hz; }
};
/// Loads the DEM, places the trajectory on it and prepares the renderer settings. Throws on bad options.
SequenceSetup prepareSequence(const SequenceOptions& options);

/// Stable hex hash of all options that change the images (not output_dir, force, num_threads, verbose) +
/// renderer version. For the ideal camera and placement 0 it is the hash of renderer 1.2.
std::string sequenceParamHash(const SequenceOptions& options);
/// sequenceParamHash + the IMU and altimeter parameters + the landing area + kStreamsVersion.
std::string streamsParamHash(const SequenceOptions& options);

/// The exact altimeter geometry at time t: range along the boresight (ray cast), altitude above the terrain
/// below and incidence, on the terrain evaluated at 5 cm detail. `returned` and `outlier` are left false.
AltimeterTruth altimeterTruthAt(const LunarTerrain& terrain, const DescentTrajectory& trajectory, double t);
constexpr double kAltimeterLodM = 0.05;
/// A ray caster for sensors::AltimeterModel on the terrain at altimeter detail.
sensors::RayCaster terrainRayCaster(const LunarTerrain& terrain);

/// Renders (or skips if cached) the sequence. `progress` may be empty.
SequenceResult renderSequence(const SequenceOptions& options, const ProgressFn& progress = {});

/// One line of per-phase timings of a rendered frame (for --verbose and profiling).
std::string formatStats(size_t frame, const RenderStats& stats);

/// A stderr progress bar with rate and ETA, redrawn at most 4 times per second.
ProgressFn makeProgressBar();

}  // namespace planetary_vo::render
