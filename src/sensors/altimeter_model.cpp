#include "planetary_vo/sensors/altimeter_model.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

namespace planetary_vo::sensors {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegPerRad = 180.0 / kPi;
constexpr int kMaxRings = 6;  // 127 rays: far more than an altimeter footprint needs

uint64_t mix64(uint64_t z) {  // splitmix64 finaliser
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

/// Sequential generator over one hash state (splitmix64): a few draws in a fixed order.
class HashRng {
 public:
  explicit HashRng(uint64_t state) : state_(state) {}
  /// Uniform in [0, 1) from the 53 high bits.
  double uniform() {
    state_ = mix64(state_);
    return static_cast<double>(state_ >> 11) * (1.0 / 9007199254740992.0);
  }
  /// Standard normal (Box-Muller; always consumes two uniforms).
  double normal() {
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  }

 private:
  uint64_t state_;
};

constexpr uint64_t kBiasStream = 0xA17B1A5ull;
constexpr uint64_t kSampleStream = 0xA175A3E5ull;

uint64_t timestampKey(double timestamp_s) {
  if (timestamp_s == 0.0) timestamp_s = 0.0;  // -0 and +0 are the same instant
  uint64_t bits = 0;
  std::memcpy(&bits, &timestamp_s, sizeof(bits));
  return bits;
}

int ringsForRays(int rays) {
  for (int k = 0; k <= kMaxRings; ++k)
    if (1 + 3 * k * (k + 1) == rays) return k;
  return -1;
}

void require(bool ok, const char* field, const std::string& what) {
  if (!ok) throw std::invalid_argument(std::string("altimeter.") + field + ": " + what);
}

bool finiteNonNegative(double v) { return std::isfinite(v) && v >= 0.0; }

// The numeric fields, by YAML key (= field name).
struct DoubleField {
  const char* key;
  double AltimeterParams::*member;
};
const DoubleField kDoubleFields[] = {
    {"range_noise_floor_m", &AltimeterParams::range_noise_floor_m},
    {"range_noise_fraction", &AltimeterParams::range_noise_fraction},
    {"bias_sigma_m", &AltimeterParams::bias_sigma_m},
    {"max_range_m", &AltimeterParams::max_range_m},
    {"min_range_m", &AltimeterParams::min_range_m},
    {"max_incidence_deg", &AltimeterParams::max_incidence_deg},
    {"outlier_probability", &AltimeterParams::outlier_probability},
    {"beam_divergence_rad", &AltimeterParams::beam_divergence_rad},
    {"footprint_search_margin_m", &AltimeterParams::footprint_search_margin_m},
    {"quantization_m", &AltimeterParams::quantization_m},
};

}  // namespace

void validate(const AltimeterParams& p) {
  require(finiteNonNegative(p.range_noise_floor_m), "range_noise_floor_m", "must be finite and >= 0");
  require(finiteNonNegative(p.range_noise_fraction) && p.range_noise_fraction < 1.0, "range_noise_fraction",
          "must be in [0, 1)");
  require(finiteNonNegative(p.bias_sigma_m), "bias_sigma_m", "must be finite and >= 0");
  require(std::isfinite(p.max_range_m) && p.max_range_m > 0.0, "max_range_m", "must be finite and > 0");
  require(finiteNonNegative(p.min_range_m) && p.min_range_m < p.max_range_m, "min_range_m",
          "must be >= 0 and < max_range_m");
  require(std::isfinite(p.max_incidence_deg) && p.max_incidence_deg > 0.0 && p.max_incidence_deg <= 90.0,
          "max_incidence_deg", "must be in (0, 90]");
  require(
      std::isfinite(p.outlier_probability) && p.outlier_probability >= 0.0 && p.outlier_probability <= 1.0,
      "outlier_probability", "must be in [0, 1]");
  require(finiteNonNegative(p.beam_divergence_rad) && p.beam_divergence_rad <= 0.2, "beam_divergence_rad",
          "must be in [0, 0.2] rad");
  require(ringsForRays(p.footprint_rays) >= 0, "footprint_rays",
          "must be 1, 7, 19, 37, 61, 91 or 127 (centre + rings of 6, 12, 18 ... rays), got " +
              std::to_string(p.footprint_rays));
  require(std::isfinite(p.footprint_search_margin_m) && p.footprint_search_margin_m > 0.0,
          "footprint_search_margin_m", "must be finite and > 0");
  require(finiteNonNegative(p.quantization_m), "quantization_m", "must be finite and >= 0");
}

void readYaml(const YAML::Node& node, AltimeterParams* params) {
  if (!node || node.IsNull()) return;
  if (!node.IsMap()) throw std::invalid_argument("altimeter: expected a map of parameters");
  AltimeterParams p = *params;
  for (const auto& kv : node) {
    const std::string key = kv.first.as<std::string>();
    const YAML::Node& value = kv.second;
    const DoubleField* field = nullptr;
    for (const DoubleField& f : kDoubleFields)
      if (key == f.key) field = &f;
    if (!field && key != "enabled" && key != "footprint_rays")
      throw std::invalid_argument("altimeter: unknown key '" + key + "'");
    if (!value.IsScalar()) throw std::invalid_argument("altimeter." + key + ": expected a scalar value");
    try {
      if (key == "enabled")
        p.enabled = value.as<bool>();
      else if (key == "footprint_rays")
        p.footprint_rays = value.as<int>();
      else
        p.*(field->member) = value.as<double>();
    } catch (const YAML::Exception&) {
      throw std::invalid_argument("altimeter." + key + ": cannot parse '" + value.Scalar() + "'");
    }
  }
  validate(p);
  *params = p;
}

YAML::Node toYaml(const AltimeterParams& p) {
  YAML::Node node;
  node["enabled"] = p.enabled;
  for (const DoubleField& f : kDoubleFields) node[f.key] = p.*(f.member);
  node["footprint_rays"] = p.footprint_rays;
  return node;
}

std::vector<FootprintRay> footprintPattern(int footprint_rays, double beam_divergence_rad) {
  const int rings = ringsForRays(footprint_rays);
  require(rings >= 0, "footprint_rays", "must be 1, 7, 19, 37, 61, 91 or 127");
  require(finiteNonNegative(beam_divergence_rad), "beam_divergence_rad", "must be finite and >= 0");
  const double n = footprint_rays;
  const double weight = 1.0 / n;
  std::vector<FootprintRay> pattern;
  pattern.reserve(footprint_rays);
  pattern.push_back({0.0, 0.0, weight});
  if (rings == 0) return pattern;
  // The offset of a ray has the 2D Gaussian density exp(-rho^2 / (2 sigma^2)); u = rho^2 / (2 sigma^2) is
  // then Exp(1) distributed, so a cell boundary at cumulative energy F is u = -ln(1 - F), and the mean of u
  // over the annulus (a, b) is 1 + (a e^-a - b e^-b) / (e^-a - e^-b).
  std::vector<double> mean_u(rings + 1, 0.0);
  double second_moment = 0.0;  // sum over the rings of share * mean u (in units of 2 sigma^2)
  double a = -std::log1p(-1.0 / n);
  for (int k = 1; k <= rings; ++k) {
    const double share = 6.0 * k / n;
    if (k == rings) {
      mean_u[k] = 1.0 + a;
    } else {
      const double b = -std::log1p(-(1.0 + 3.0 * k * (k + 1)) / n);
      const double ea = std::exp(-a), eb = std::exp(-b);
      mean_u[k] = 1.0 + (a * ea - b * eb) / (ea - eb);
      a = b;
    }
    second_moment += share * mean_u[k];
  }
  // The boresight ray stands for the central disc at offset 0: scale the rings so that the pattern keeps the
  // beam's second moment, sum w rho^2 = 2 sigma^2 (mean u = 1).
  const double scale = std::sqrt(1.0 / second_moment);
  const double sigma_rad = beam_divergence_rad / 4.0;  // 1/e^2 half-angle = 2 sigma
  for (int k = 1; k <= rings; ++k) {
    const double offset = sigma_rad * std::sqrt(2.0 * mean_u[k]) * scale;
    const int m = 6 * k;
    const double stagger = (k % 2 == 0) ? 0.5 : 0.0;  // even rings turned by half a step
    for (int j = 0; j < m; ++j) pattern.push_back({offset, 2.0 * kPi * (j + stagger) / m, weight});
  }
  return pattern;
}

AltimeterModel::AltimeterModel(const AltimeterParams& params, uint64_t seed) : params_(params), seed_(seed) {
  validate(params_);
  if (params_.enabled) {
    HashRng rng(mix64(seed_ ^ kBiasStream));
    bias_m_ = params_.bias_sigma_m * rng.normal();
    pattern_ = footprintPattern(params_.footprint_rays, params_.beam_divergence_rad);
    // Energy of a plane perpendicular to the boresight at distance D: ray k hits at D / cos(a_k) with
    // incidence a_k, so it returns w cos^3(a_k) / D^2.
    for (const FootprintRay& ray : pattern_)
      reference_energy_ += ray.weight * std::pow(std::cos(ray.offset_rad), 3);
  }
}

AltimeterReading AltimeterModel::measure(double timestamp_s, const Eigen::Vector3d& origin_world,
                                         const Eigen::Vector3d& boresight_world,
                                         const Eigen::Vector3d& up_world, const RayCaster& cast) const {
  AltimeterReading reading;
  reading.timestamp_s = timestamp_s;
  reading.bias_m = bias_m_;
  const double max_range = params_.max_range_m;
  const Eigen::Vector3d b = boresight_world.normalized();

  const std::optional<RayHit> centre = cast(origin_world, b, 0.0, max_range);
  reading.ray_casts = 1;
  const bool hit = centre && centre->range_m <= max_range;
  if (hit) {
    reading.true_range_m = std::max(0.0, centre->range_m);
    const double cos_i = std::clamp(-b.dot(centre->normal_world.normalized()), -1.0, 1.0);
    reading.incidence_deg = std::acos(cos_i) * kDegPerRad;
  }

  if (!params_.enabled) {  // the perfect instrument
    if (hit) {
      reading.range_m = reading.footprint_range_m = reading.true_range_m;
      reading.echo_detected = reading.returned = true;
    }
    return reading;
  }

  // This sample's draws, always all of them and in this order, so that each error is independent of the
  // others being switched on or off.
  HashRng rng(mix64(mix64(seed_ ^ kSampleStream) ^ timestampKey(timestamp_s)));
  const double u_outlier = rng.uniform();
  const double u_outlier_range = rng.uniform();
  const double noise = rng.normal();

  if (hit) {
    // Orthonormal frame of the footprint: e1 along the part of up orthogonal to the boresight.
    Eigen::Vector3d e1 = up_world - up_world.dot(b) * b;
    e1 = e1.norm() > 1e-9 * up_world.norm() && e1.norm() > 0.0 ? e1.normalized() : b.unitOrthogonal();
    const Eigen::Vector3d e2 = b.cross(e1);
    const double start = std::max(0.0, reading.true_range_m - params_.footprint_search_margin_m);
    double energy = 0.0, energy_range = 0.0;
    for (size_t k = 0; k < pattern_.size(); ++k) {
      const FootprintRay& ray = pattern_[k];
      Eigen::Vector3d dir = b;
      std::optional<RayHit> h = centre;
      if (k > 0) {
        dir = std::cos(ray.offset_rad) * b +
              std::sin(ray.offset_rad) * (std::cos(ray.azimuth_rad) * e1 + std::sin(ray.azimuth_rad) * e2);
        h = cast(origin_world, dir, start, max_range);
        ++reading.ray_casts;
        if (h && start > 0.0 && h->range_m <= start) {  // under the terrain at the start: search from 0
          h = cast(origin_world, dir, 0.0, max_range);
          ++reading.ray_casts;
        }
      }
      if (!h || h->range_m > max_range) continue;
      const double r = std::max(h->range_m, 1e-6);
      const double cos_i = std::max(0.0, -dir.dot(h->normal_world.normalized()));
      const double e = ray.weight * cos_i / (r * r);
      energy += e;
      energy_range += e * r;
    }
    // All the energy is lost only at exactly grazing incidence: keep the boresight range then.
    reading.footprint_range_m = energy > 0.0 ? energy_range / energy : reading.true_range_m;
    reading.energy_ratio = energy * max_range * max_range / reference_energy_;
    reading.echo_detected = reading.energy_ratio >= 1.0 &&
                            reading.incidence_deg <= params_.max_incidence_deg &&
                            reading.footprint_range_m >= params_.min_range_m;
  }

  double range = std::numeric_limits<double>::infinity();
  if (reading.echo_detected) {
    const double sigma =
        params_.range_noise_floor_m + params_.range_noise_fraction * reading.footprint_range_m;
    range = reading.footprint_range_m + bias_m_ + sigma * noise;
  }
  if (u_outlier < params_.outlier_probability) {
    reading.outlier = true;
    range = params_.min_range_m + u_outlier_range * (params_.max_range_m - params_.min_range_m);
  }
  if (std::isfinite(range)) {
    if (params_.quantization_m > 0.0)
      range = params_.quantization_m * std::round(range / params_.quantization_m);
    reading.range_m = range;
    reading.returned = true;
  }
  return reading;
}

}  // namespace planetary_vo::sensors
