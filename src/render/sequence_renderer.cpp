#include "planetary_vo/render/sequence_renderer.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include <unistd.h>

#include <opencv2/imgcodecs.hpp>

namespace planetary_vo::render {

namespace fs = std::filesystem;

SequenceSetup prepareSequence(const SequenceOptions& o) {
  if (o.width < 16 || o.height < 16) throw std::invalid_argument("image size must be at least 16x16");
  if (!(o.rate_hz > 0.0 && o.rate_hz <= 30.0)) throw std::invalid_argument("rate must be in (0, 30] Hz");
  if (!(o.sun_elevation_deg > 0.0 && o.sun_elevation_deg <= 90.0))
    throw std::invalid_argument("sun elevation must be in (0, 90] deg");
  if (o.dem_yaml.empty()) throw std::invalid_argument("no DEM given");
  const SequenceSpec& spec = findSequence(o.sequence);
  DescentTrajectory trajectory = DescentTrajectory::fromSequence(spec);
  auto dem = LunarDem::load(o.dem_yaml);
  TerrainParams tp;
  tp.seed = o.seed;
  auto terrain = std::make_shared<const LunarTerrain>(dem, placeTrajectoryOnDem(*dem, trajectory), tp);
  RenderSettings rs;
  rs.camera = PinholeCamera::fromFieldOfView(o.width, o.height, o.fov_deg);
  rs.sun_direction = sunDirection(o.sun_elevation_deg, o.sun_azimuth_deg);
  rs.noise_sigma_dn = o.noise_sigma_dn;
  rs.noise_seed = o.seed;
  rs.num_threads = o.num_threads;
  const double duration =
      o.duration_s < 0 ? trajectory.duration() : std::min(o.duration_s, trajectory.duration());
  const size_t frames = static_cast<size_t>(std::floor(duration * o.rate_hz + 1e-9)) + 1;
  return SequenceSetup{spec, dem, terrain, trajectory, rs, duration, frames};
}

std::string sequenceParamHash(const SequenceOptions& o) {
  std::ostringstream os;
  os.precision(17);
  os << kRendererVersion << '|' << o.sequence << '|' << fs::path(o.dem_yaml).filename().string() << '|'
     << (fs::exists(o.dem_yaml) ? fs::file_size(o.dem_yaml) : 0) << '|' << o.width << 'x' << o.height << '|'
     << o.fov_deg << '|' << o.rate_hz << '|' << o.duration_s << '|' << o.seed << '|' << o.sun_elevation_deg
     << '|' << o.sun_azimuth_deg << '|' << o.noise_sigma_dn << '|' << o.imu_rate_hz << '|'
     << o.altimeter_rate_hz << '|' << o.save_depth;
  uint64_t h = 1469598103934665603ull;  // FNV-1a: stable across runs and platforms (std::hash is not)
  for (unsigned char c : os.str()) h = (h ^ c) * 1099511628211ull;
  char buf[17];
  std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

AltimeterSample altimeterAt(const LunarTerrain& terrain, const DescentTrajectory& trajectory, double t) {
  const TrajectoryState s = trajectory.state(t);
  AltimeterSample a;
  a.timestamp_s = t;
  a.altitude_m = s.position.z() - terrain.height(s.position.x(), s.position.y(), kAltimeterLodM);
  const auto range = castRayOnTerrain(terrain, s.position, s.R_world_cam.col(2), kAltimeterLodM, 50000.0);
  a.slant_range_m = range ? *range : 0.0;
  return a;
}

namespace {

std::string readStamp(const std::string& dir) {
  std::ifstream in(dir + "/render_stamp.txt");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string stampText(const std::string& hash, size_t frames) {
  return "param_hash: " + hash + "\nframes: " + std::to_string(frames) + "\ncomplete: true\n";
}

size_t countImages(const std::string& dir) {
  size_t n = 0;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir + "/images", ec))
    if (e.path().extension() == ".png") ++n;
  return n;
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

SequenceResult renderSequence(const SequenceOptions& o, const ProgressFn& progress) {
  if (o.output_dir.empty()) throw std::invalid_argument("no output directory");
  SequenceResult result;
  result.param_hash = sequenceParamHash(o);
  const SequenceSetup setup = prepareSequence(o);
  const std::string stamp = stampText(result.param_hash, setup.num_frames);
  if (!o.force && readStamp(o.output_dir) == stamp && countImages(o.output_dir) == setup.num_frames &&
      fs::exists(o.output_dir + "/sequence.yaml")) {
    result.skipped = true;
    result.frames = setup.num_frames;
    return result;
  }
  // A stale or partial render: remove its stamp and frames first, so an interrupted run is never taken as
  // complete.
  std::error_code ec;
  fs::remove(o.output_dir + "/render_stamp.txt", ec);
  fs::remove_all(o.output_dir + "/images", ec);
  fs::remove_all(o.output_dir + "/depth", ec);
  if (o.save_depth) fs::create_directories(o.output_dir + "/depth");

  const auto t0 = std::chrono::steady_clock::now();
  Renderer renderer(setup.terrain, setup.settings);
  {
    DatasetWriter writer(o.output_dir, setup.settings.camera);
    for (size_t i = 0; i < setup.num_frames; ++i) {
      const double t = static_cast<double>(i) / o.rate_hz;
      const Pose T = setup.trajectory.state(t).T_world_cam();
      const RenderOutput out = renderer.render(T, i);
      if (o.verbose) std::fprintf(stderr, "%s\n", formatStats(i, out.stats).c_str());
      writer.addFrame(t, out.image, T);
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
    const int n_imu = static_cast<int>(std::floor(setup.duration_s * o.imu_rate_hz + 1e-9));
    for (int i = 0; i <= n_imu; ++i) writer.addImu(setup.trajectory.imu(i / o.imu_rate_hz));
    const int n_alt = static_cast<int>(std::floor(setup.duration_s * o.altimeter_rate_hz + 1e-9));
    for (int i = 0; i <= n_alt; ++i)
      writer.addAltimeter(altimeterAt(*setup.terrain, setup.trajectory, i / o.altimeter_rate_hz));

    std::ostringstream y;
    y.precision(10);
    const DemPlacement& pl = setup.terrain->placement();
    const Eigen::Vector3d& sun = setup.settings.sun_direction;
    y << "# Synthetic Lunar descent rendered by lunar_render (planetary_vo docs/rendering.md)\n"
      << "name: " << o.sequence << "\n"
      << "renderer_version: \"" << kRendererVersion << "\"\n"
      << "param_hash: \"" << result.param_hash << "\"\n"
      << "world_frame: \"landing site: x crossrange, y downrange, z up (altitude); ground truth "
         "T_world_cam\"\n"
      << "trajectory:\n"
      << setup.trajectory.describeYaml(2) << "camera_mode: " << toString(setup.spec.mode) << "\n"
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
      << "\n  origin_east_m: " << pl.origin_east_m << "\n  origin_north_m: " << pl.origin_north_m
      << "\n  heading_deg: " << pl.heading_rad * 180.0 / M_PI << "\n  datum_m: " << pl.datum_m << "\n"
      << "imu_rate_hz: " << o.imu_rate_hz << "\n"
      << "altimeter_rate_hz: " << o.altimeter_rate_hz << "\n"
      << "depth_saved: " << (o.save_depth ? "true" : "false") << "\n";
    writer.setSequenceYaml(y.str());
    writer.finish();
  }
  result.frames = setup.num_frames;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  result.frames_per_second = result.frames / std::max(result.seconds, 1e-9);
  std::ofstream(o.output_dir + "/render_stamp.txt") << stamp;
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
