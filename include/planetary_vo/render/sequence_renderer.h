#pragma once
/// @file sequence_renderer.h
/// Renders a whole descent sequence into a planetary_vo dataset folder (images, groundtruth, camera.yaml,
/// imu.txt, altimeter.txt, sequence.yaml) through DatasetWriter, with caching and progress reporting.
///
/// Caching: sequence.yaml and render_stamp.txt carry a hash of every render parameter plus kRendererVersion.
/// If the output folder already holds a complete render with the same hash, nothing is rendered again.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/render/descent_trajectory.h"
#include "planetary_vo/render/renderer.h"

namespace planetary_vo::render {

/// Bump whenever a change alters rendered pixels or streams, so cached sequences are re-rendered.
constexpr const char* kRendererVersion = "lunar_render 1.2";

struct SequenceOptions {
  std::string sequence = "approach_down";  ///< one of lunarSequences()
  std::string output_dir;
  std::string dem_yaml;  ///< empty = <data>/lunar_dem/apollo15_gld100.yaml (caller resolves)
  int width = 1024, height = 1024;
  double fov_deg = 60.0;
  double rate_hz = 10.0;
  double duration_s = -1.0;  ///< < 0: the whole sequence
  uint64_t seed = 1;
  double sun_elevation_deg = 12.0;
  double sun_azimuth_deg = 250.0;
  double noise_sigma_dn = 0.0;
  double imu_rate_hz = 200.0;
  double altimeter_rate_hz = 20.0;
  bool save_depth = false;  ///< depth/NNNNNN.tiff (32-bit float z-depth in m)
  bool force = false;       ///< render even if a complete identical render exists
  int num_threads = 0;
  bool verbose = false;  ///< per-frame timing of every render phase on stderr (not part of the hash)
};

struct SequenceResult {
  bool skipped = false;  ///< up to date, nothing rendered
  size_t frames = 0;
  double seconds = 0.0;
  double frames_per_second = 0.0;
  std::string param_hash;
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
  double duration_s = 0.0;
  size_t num_frames = 0;
};
/// Loads the DEM, places the trajectory on it and prepares the renderer settings. Throws on bad options.
SequenceSetup prepareSequence(const SequenceOptions& options);

/// Stable hex hash of all options that change the output (not output_dir, force, num_threads) + renderer
/// version.
std::string sequenceParamHash(const SequenceOptions& options);

/// Altimeter reading at time t: slant range along the boresight (ray cast) and altitude above the terrain
/// below, both on the terrain evaluated at 5 cm detail (the laser footprint).
AltimeterSample altimeterAt(const LunarTerrain& terrain, const DescentTrajectory& trajectory, double t);
constexpr double kAltimeterLodM = 0.05;

/// Renders (or skips if cached) the sequence. `progress` may be empty.
SequenceResult renderSequence(const SequenceOptions& options, const ProgressFn& progress = {});

/// One line of per-phase timings of a rendered frame (for --verbose and profiling).
std::string formatStats(size_t frame, const RenderStats& stats);

/// A stderr progress bar with rate and ETA, redrawn at most 4 times per second.
ProgressFn makeProgressBar();

}  // namespace planetary_vo::render
