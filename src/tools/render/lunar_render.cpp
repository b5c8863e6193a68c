/// lunar_render: renders the synthetic Lunar descent sequences (docs/rendering.md).
///   lunar_render --sequence NAME --output DIR [--width W --height H --rate HZ --duration S --seed N
///                --dem FILE.yaml --sun-elevation DEG --sun-azimuth DEG --noise SIGMA --depth --force
///                --progress --verbose --threads N]
///   lunar_render --sequence NAME --snapshot T --output FILE.png [same options]   one frame at time T
///   lunar_render --list

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>

#include <unistd.h>

#include <opencv2/imgcodecs.hpp>

#include "planetary_vo/render/sequence_renderer.h"

using namespace planetary_vo::render;

namespace {

int usage(const char* msg) {
  if (msg) std::cerr << "lunar_render: " << msg << "\n";
  std::cerr
      << "usage: lunar_render --sequence NAME --output DIR [--width W] [--height H] [--rate HZ] "
         "[--duration S] [--seed N] [--dem FILE.yaml|NAME] [--sun-elevation DEG] [--sun-azimuth DEG] "
         "[--noise SIGMA_DN] [--depth] [--force] [--progress] [--verbose] [--threads N] [--snapshot T]\n"
         "       lunar_render --list\n";
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
  bool progress = isatty(STDERR_FILENO), list = false;
  double snapshot = -1.0;
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
      else if (a == "--seed")
        o.seed = std::stoull(next());
      else if (a == "--dem")
        o.dem_yaml = next();
      else if (a == "--sun-elevation")
        o.sun_elevation_deg = std::stod(next());
      else if (a == "--sun-azimuth")
        o.sun_azimuth_deg = std::stod(next());
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
      const RenderOutput out = renderer.render(setup.trajectory.state(snapshot).T_world_cam());
      if (!cv::imwrite(o.output_dir, out.image)) throw std::runtime_error("cannot write " + o.output_dir);
      std::cerr << "rendered " << o.width << "x" << o.height << " t=" << snapshot
                << " s: " << formatStats(0, out.stats) << "\n";
      return 0;
    }
    const SequenceResult r = renderSequence(o, progress ? makeProgressBar() : ProgressFn());
    if (r.skipped)
      std::cout << "up to date (param hash " << r.param_hash << "), " << r.frames << " frames in "
                << o.output_dir << "\n";
    else
      std::printf("rendered %zu frames %dx%d in %.1f s: %.2f frames/s -> %s\n", r.frames, o.width, o.height,
                  r.seconds, r.frames_per_second, o.output_dir.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "lunar_render: " << e.what() << "\n";
    return 1;
  }
}
