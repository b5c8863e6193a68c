/// @file ros_params.cpp
/// The only file of the ROS layer that reads parameters (see ros_params.h).

#include "planetary_vo/ros_io/ros_params.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iterator>
#include <set>
#include <sstream>

#include <xmlrpcpp/XmlRpcValue.h>

#include "planetary_vo/vo/config_yaml.h"

namespace planetary_vo::ros_io {

const char* const kFallbackCameraFrame = "camera_optical";

const char* const kVoConfigSections[12] = {"detector", "tracker",   "map",           "keyframe",
                                           "motion",   "pnp",       "motion_filter", "bundle_adjustment",
                                           "pipeline", "altimeter", "imu",           "cpu_budget"};

namespace {

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

/// One scalar as YAML; structures and lists are written as an unparseable marker so that the core loader
/// reports the key ("wrong type") instead of this file guessing.
std::string scalarYaml(XmlRpc::XmlRpcValue& v) {
  std::ostringstream os;
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      os << (static_cast<bool>(v) ? "true" : "false");
      break;
    case XmlRpc::XmlRpcValue::TypeInt:
      os << static_cast<int>(v);
      break;
    case XmlRpc::XmlRpcValue::TypeDouble:
      os << std::setprecision(17) << static_cast<double>(v);
      break;
    case XmlRpc::XmlRpcValue::TypeString:
      os << quoted(static_cast<std::string>(v));
      break;
    default:
      os << "[]";  // a list: the loader rejects it with the key's name
  }
  return os.str();
}

/// Every parameter of NodeletParams with its name: the one list both the reader and nodeletParamNames() use.
template <class V>
void visitNodeletParams(NodeletParams& p, V&& v) {
  v("world_frame", p.world_frame);
  v("camera_frame", p.camera_frame);
  v("base_frame", p.base_frame);
  v("publish_tf", p.publish_tf);
  v("queue_size", p.queue_size);
  v("max_path_length", p.max_path_length);
  v("path_publish_period_s", p.path_publish_period_s);
  v("mono16_significant_bits", p.mono16_significant_bits);
  v("position_sigma_m", p.position_sigma_m);
  v("orientation_sigma_rad", p.orientation_sigma_rad);
  v("lost_sigma_factor", p.lost_sigma_factor);
  v("max_frame_gap_factor", p.max_frame_gap_factor);
  v("min_rate_hz", p.min_rate_hz);
  v("max_rate_hz", p.max_rate_hz);
  v("velocity_sigma_mps", p.velocity_sigma_mps);
  v("wait_for_initial_state", p.wait_for_initial_state);
  v("initial_state_tolerance", p.initial_state_tolerance_s);
  v("imu_queue_size", p.imu_queue_size);
  v("altimeter_queue_size", p.altimeter_queue_size);
}

template <class V>
void visitHazardNodeletParams(HazardNodeletParams& p, V&& v) {
  v("publish_period_s", p.publish_period_s);
  v("cloud_stride", p.cloud_stride);
  v("events_queue_size", p.events_queue_size);
}

}  // namespace

std::string yamlFromParams(const ros::NodeHandle& private_nh, const std::vector<std::string>& sections) {
  std::ostringstream yaml;
  for (const std::string& section : sections) {
    XmlRpc::XmlRpcValue values;
    if (!private_nh.getParam(section, values)) continue;
    if (values.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
      yaml << section << ": 0\n";  // not a map: the loader names the section
      continue;
    }
    yaml << section << ":\n";
    for (auto& entry : values) yaml << "  " << entry.first << ": " << scalarYaml(entry.second) << "\n";
  }
  return yaml.str();
}

std::string voConfigYamlFromParams(const ros::NodeHandle& private_nh) {
  return yamlFromParams(private_nh,
                        std::vector<std::string>(std::begin(kVoConfigSections), std::end(kVoConfigSections)));
}

const std::vector<std::string>& hazardConfigSections() {
  static const std::vector<std::string> sections = terrain::hazardMapperConfigSections();
  return sections;
}

terrain::HazardMapperConfig loadHazardConfigFromParams(const ros::NodeHandle& private_nh) {
  try {
    return terrain::parseHazardMapperConfig(yamlFromParams(private_nh, hazardConfigSections()));
  } catch (const terrain::HazardConfigError& e) {
    std::vector<std::string> problems;
    for (const std::string& p : e.problems()) problems.push_back(private_nh.getNamespace() + "/" + p);
    throw terrain::HazardConfigError(problems);
  }
}

HazardNodeletParams loadHazardNodeletParams(const ros::NodeHandle& nh) {
  HazardNodeletParams p;
  visitHazardNodeletParams(p, [&nh](const char* name, auto& value) { nh.param(name, value, value); });
  if (!(p.publish_period_s > 0.0) || !std::isfinite(p.publish_period_s))
    p.publish_period_s = HazardNodeletParams().publish_period_s;
  if (p.cloud_stride < 1) p.cloud_stride = 1;
  if (p.events_queue_size < 1) p.events_queue_size = 1;
  return p;
}

VoConfig loadVoConfigFromParams(const ros::NodeHandle& private_nh) {
  try {
    return parseVoConfig(voConfigYamlFromParams(private_nh));
  } catch (const ConfigError& e) {
    std::vector<std::string> problems;
    for (const std::string& p : e.problems()) problems.push_back(private_nh.getNamespace() + "/" + p);
    throw ConfigError(problems);
  }
}

std::vector<std::string> validateNodeletParams(NodeletParams* p) {
  const NodeletParams d;
  std::vector<std::string> problems;
  auto check = [&problems](const char* name, double* value, double fallback, bool ok, const char* rule) {
    if (std::isfinite(*value) && ok) return;
    std::ostringstream os;
    os << "~" << name << " = " << *value << " is invalid (" << rule << "): the default " << fallback
       << " is used";
    problems.push_back(os.str());
    *value = fallback;
  };
  check("position_sigma_m", &p->position_sigma_m, d.position_sigma_m, p->position_sigma_m > 0.0, "> 0");
  check("orientation_sigma_rad", &p->orientation_sigma_rad, d.orientation_sigma_rad,
        p->orientation_sigma_rad > 0.0, "> 0");
  check("lost_sigma_factor", &p->lost_sigma_factor, d.lost_sigma_factor, p->lost_sigma_factor >= 1.0, ">= 1");
  check("velocity_sigma_mps", &p->velocity_sigma_mps, d.velocity_sigma_mps, p->velocity_sigma_mps > 0.0,
        "> 0");
  check("max_frame_gap_factor", &p->max_frame_gap_factor, d.max_frame_gap_factor,
        p->max_frame_gap_factor > 1.0, "> 1");
  check("min_rate_hz", &p->min_rate_hz, d.min_rate_hz, p->min_rate_hz > 0.0, "> 0");
  check("max_rate_hz", &p->max_rate_hz, d.max_rate_hz, p->max_rate_hz > p->min_rate_hz, "> ~min_rate_hz");
  check("initial_state_tolerance", &p->initial_state_tolerance_s, d.initial_state_tolerance_s,
        p->initial_state_tolerance_s >= 0.0, ">= 0");
  auto check_int = [&problems](const char* name, int* value, int fallback) {
    if (*value >= 1) return;
    problems.push_back("~" + std::string(name) + " = " + std::to_string(*value) +
                       " is invalid (>= 1): the default " + std::to_string(fallback) + " is used");
    *value = fallback;
  };
  check_int("queue_size", &p->queue_size, d.queue_size);
  check_int("imu_queue_size", &p->imu_queue_size, d.imu_queue_size);
  check_int("altimeter_queue_size", &p->altimeter_queue_size, d.altimeter_queue_size);
  check("path_publish_period_s", &p->path_publish_period_s, d.path_publish_period_s,
        p->path_publish_period_s > 0.0, "> 0");
  if (p->mono16_significant_bits < 8 || p->mono16_significant_bits > 16) {
    problems.push_back("~mono16_significant_bits = " + std::to_string(p->mono16_significant_bits) +
                       " is invalid (8..16): the default " + std::to_string(d.mono16_significant_bits) +
                       " is used");
    p->mono16_significant_bits = d.mono16_significant_bits;
  }
  if (p->max_path_length < 0) {
    problems.push_back("~max_path_length = " + std::to_string(p->max_path_length) +
                       " is invalid (>= 0): the default " + std::to_string(d.max_path_length) + " is used");
    p->max_path_length = d.max_path_length;
  }
  return problems;
}

NodeletParams loadNodeletParams(const ros::NodeHandle& nh, std::vector<std::string>* problems) {
  NodeletParams p;
  visitNodeletParams(p, [&nh](const char* name, auto& value) { nh.param(name, value, value); });
  const std::vector<std::string> invalid = validateNodeletParams(&p);
  if (problems) *problems = invalid;
  return p;
}

std::vector<std::string> nodeletParamNames() {
  NodeletParams p;
  std::vector<std::string> names;
  visitNodeletParams(p, [&names](const char* name, auto&) { names.push_back(name); });
  return names;
}

std::vector<std::string> hazardNodeletParamNames() {
  HazardNodeletParams p;
  std::vector<std::string> names;
  visitHazardNodeletParams(p, [&names](const char* name, auto&) { names.push_back(name); });
  return names;
}

std::vector<std::string> unknownPrivateNames(const ros::NodeHandle& private_nh,
                                             const std::vector<std::string>& known) {
  std::vector<std::string> all, problems;
  if (!private_nh.getParamNames(all)) return {"the parameter names could not be listed (no master?)"};
  const std::string prefix = private_nh.getNamespace() + "/";
  std::set<std::string> reported;
  for (const std::string& full : all) {
    if (full.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string name = full.substr(prefix.size(), full.find('/', prefix.size()) - prefix.size());
    if (name.empty() || std::find(known.begin(), known.end(), name) != known.end()) continue;
    if (!reported.insert(name).second) continue;
    const bool section = full.size() > prefix.size() + name.size();
    problems.push_back(prefix + name + ": not a " + (section ? "section" : "parameter") +
                       " of this nodelet (misspelt?); it is ignored");
  }
  return problems;
}

}  // namespace planetary_vo::ros_io
