#include "planetary_vo/sensors/sensor_suite.h"

#include <fstream>
#include <sstream>
#include <stdexcept>

namespace planetary_vo::sensors {

std::vector<std::string> sensorPresetNames() { return {"flight", "ideal"}; }

SensorSuiteParams sensorPreset(const std::string& name) {
  SensorSuiteParams p;
  p.preset = name;
  if (name == "ideal") {
    p.camera.enabled = false;
    p.imu = imuGrade("ideal");
    p.altimeter.enabled = false;
    p.altimeter.max_range_m = 50000.0;  // the perfect instrument sees the terrain from any altitude
  } else if (name == "flight") {
    p.camera.enabled = true;
    p.imu = imuGrade("tactical");
    p.altimeter.enabled = true;
  } else {
    throw std::invalid_argument("unknown sensor preset '" + name + "' (valid: flight, ideal)");
  }
  return p;
}

void readYaml(const YAML::Node& node, SensorSuiteParams* params) {
  if (!node || node.IsNull()) return;
  if (!node.IsMap())
    throw std::invalid_argument("sensors: expected a map with preset, camera, imu, altimeter");
  if (node["preset"]) {
    if (!node["preset"].IsScalar()) throw std::invalid_argument("sensors: preset must be a name");
    *params = sensorPreset(node["preset"].as<std::string>());
  }
  for (const auto& kv : node) {
    const std::string key = kv.first.as<std::string>();
    if (key == "preset") continue;
    if (key == "camera")
      readYaml(kv.second, &params->camera);
    else if (key == "imu")
      readYaml(kv.second, &params->imu);
    else if (key == "altimeter")
      readYaml(kv.second, &params->altimeter);
    else
      throw std::invalid_argument("sensors: unknown key '" + key +
                                  "' (valid: preset, camera, imu, altimeter)");
  }
}

YAML::Node toYaml(const SensorSuiteParams& params) {
  YAML::Node n;
  n["preset"] = params.preset;
  n["camera"] = toYaml(params.camera);
  n["imu"] = toYaml(params.imu);
  n["altimeter"] = toYaml(params.altimeter);
  return n;
}

void applyOverride(const std::string& assignment, SensorSuiteParams* params) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw std::invalid_argument("sensor override '" + assignment +
                                "' is not KEY=VALUE (e.g. camera.read_noise_e=20)");
  const std::string path = assignment.substr(0, eq), value = assignment.substr(eq + 1);
  std::vector<std::string> keys;
  std::stringstream ss(path);
  for (std::string k; std::getline(ss, k, '.');) {
    if (k.empty()) throw std::invalid_argument("sensor override '" + assignment + "': empty key");
    keys.push_back(k);
  }
  if (keys.size() < 2 && keys.front() != "preset")
    throw std::invalid_argument("sensor override '" + assignment +
                                "': give SECTION.KEY (camera, imu, altimeter)");
  YAML::Node parsed;
  try {
    parsed = YAML::Load(value);
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument("sensor override '" + assignment + "': value is not YAML: " + e.what());
  }
  // Build {k0: {k1: ... value}} and read it like a file.
  YAML::Node root = parsed;
  for (auto it = keys.rbegin(); it != keys.rend(); ++it) {
    YAML::Node wrap;
    wrap[*it] = root;
    root = wrap;
  }
  readYaml(root, params);
}

void readYamlFile(const std::string& path, SensorSuiteParams* params) {
  YAML::Node node;
  try {
    node = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument("cannot read sensor configuration " + path + ": " + e.what());
  }
  try {
    readYaml(node, params);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path + ": " + e.what());
  }
}

uint64_t subSeed(uint64_t sensor_seed, const std::string& model) {
  uint64_t h = 1469598103934665603ull ^ sensor_seed;  // FNV-1a over the model name, then splitmix
  for (unsigned char c : model) h = (h ^ c) * 1099511628211ull;
  h += 0x9E3779B97F4A7C15ull;
  h = (h ^ (h >> 30)) * 0xBF58476D1CE4E5B9ull;
  h = (h ^ (h >> 27)) * 0x94D049BB133111EBull;
  return h ^ (h >> 31);
}

std::string yamlText(const YAML::Node& node) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  out << node;
  return out.c_str();
}

}  // namespace planetary_vo::sensors
