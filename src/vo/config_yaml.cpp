/// @file config_yaml.cpp
/// YAML reading and writing of VoConfig over the key table in config_fields.h.

#include "planetary_vo/vo/config_yaml.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "config_fields.h"

namespace planetary_vo {
namespace {

size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

/// " (did you mean 'x'?)" when a known name is within a third of the typed length, else "".
std::string suggestion(const std::string& typed, const std::vector<std::string>& known) {
  std::string best;
  size_t best_distance = std::numeric_limits<size_t>::max();
  for (const std::string& k : known) {
    const size_t d = editDistance(typed, k);
    if (d < best_distance) best_distance = d, best = k;
  }
  if (best.empty() || best_distance > std::max<size_t>(2, typed.size() / 3)) return "";
  return " (did you mean '" + best + "'?)";
}

std::string lineOf(const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  return mark.is_null() ? "" : " (line " + std::to_string(mark.line + 1) + ")";
}

/// Lists section names and, per section, key names, in table order.
struct KeyCollector {
  std::vector<std::string> sections;
  std::vector<std::vector<std::string>> keys;
  void beginSection(const char* name) {
    sections.emplace_back(name);
    keys.emplace_back();
  }
  template <class T, class L>
  void operator()(const char* key, const T&, L, L) {
    keys.back().emplace_back(key);
  }
  void operator()(const char* key, const bool&) { keys.back().emplace_back(key); }
  template <class E>
  void enumeration(const char* key, const E&) {
    keys.back().emplace_back(key);
  }
};

/// Fills a VoConfig from the YAML root; every problem is appended to `errors` and parsing goes on.
class Parser {
 public:
  Parser(const YAML::Node& root, std::vector<std::string>* errors) : root_(root), errors_(errors) {}

  void beginSection(const char* name) {
    section_ = name;
    node_ = YAML::Node();
    const YAML::Node n = root_[name];
    if (!n) return;  // absent section: all defaults
    if (n.IsNull()) return;
    if (!n.IsMap()) {
      errors_->push_back(section_ + ": must be a map of key: value" + lineOf(n));
      return;
    }
    node_ = n;
  }

  template <class T, class L>
  void operator()(const char* key, T& value, L, L) {
    const YAML::Node n = scalar(key, std::is_integral_v<T> ? "an integer" : "a number");
    if (!n) return;
    try {
      value = n.as<T>();
    } catch (const YAML::Exception&) {
      bad(key, n, std::is_integral_v<T> ? "an integer" : "a number");
    }
  }

  void operator()(const char* key, bool& value) {
    const YAML::Node n = scalar(key, "true or false");
    if (!n) return;
    try {
      value = n.as<bool>();
    } catch (const YAML::Exception&) {
      bad(key, n, "true or false");
    }
  }

  template <class E>
  void enumeration(const char* key, E& value) {
    std::string choices;
    for (const auto& entry : config_detail::EnumNames<E>::kValues)
      choices += (choices.empty() ? "" : " | ") + std::string(entry.second);
    const YAML::Node n = scalar(key, choices.c_str());
    if (!n) return;
    if (!config_detail::enumFromName(n.Scalar().c_str(), &value)) bad(key, n, choices.c_str());
  }

 private:
  /// The scalar node of `key` in the current section, or an invalid node when absent or not a scalar.
  YAML::Node scalar(const char* key, const char* expected) {
    if (!node_) return YAML::Node(YAML::NodeType::Undefined);
    const YAML::Node n = node_[key];
    if (!n) return YAML::Node(YAML::NodeType::Undefined);
    if (!n.IsScalar()) {
      errors_->push_back(section_ + "." + key + ": expected " + expected + ", got " +
                         (n.IsNull()  ? "nothing"
                          : n.IsMap() ? "a map"
                                      : "a list") +
                         lineOf(n));
      return YAML::Node(YAML::NodeType::Undefined);
    }
    return n;
  }
  void bad(const char* key, const YAML::Node& n, const char* expected) {
    errors_->push_back(section_ + "." + key + ": expected " + expected + ", got '" + n.Scalar() + "'" +
                       lineOf(n));
  }

  YAML::Node root_;
  YAML::Node node_;
  std::string section_;
  std::vector<std::string>* errors_;
};

/// Shortest decimal text that reads back as exactly `v`, so dump() round-trips bit for bit.
std::string formatDouble(double v) {
  char buffer[64];
  for (int precision = 6; precision <= 17; ++precision) {
    std::snprintf(buffer, sizeof(buffer), "%.*g", precision, v);
    if (std::strtod(buffer, nullptr) == v) break;
  }
  std::string text = buffer;
  // Keep a decimal point so the value still reads as a floating-point number to a human.
  if (std::isfinite(v) && text.find_first_of(".eE") == std::string::npos) text += ".0";
  return text;
}

class Dumper {
 public:
  void beginSection(const char* name) { out << name << ":\n"; }
  template <class T, class L>
  void operator()(const char* key, const T& value, L, L) {
    out << "  " << key << ": ";
    if constexpr (std::is_integral_v<T>)
      out << value;
    else
      out << formatDouble(value);
    out << "\n";
  }
  void operator()(const char* key, const bool& value) {
    out << "  " << key << ": " << (value ? "true" : "false") << "\n";
  }
  template <class E>
  void enumeration(const char* key, const E& value) {
    out << "  " << key << ": " << config_detail::enumName(value) << "\n";
  }
  std::ostringstream out;
};

}  // namespace

VoConfig parseVoConfig(const std::string& yaml_text) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ConfigError({std::string("YAML syntax error: ") + e.what()});
  }

  VoConfig config;
  std::vector<std::string> errors;
  if (root.IsNull()) return config;
  if (!root.IsMap()) throw ConfigError({"the document must be a map of sections (detector:, tracker:, ...)"});

  KeyCollector known;
  config_detail::forEachField(config, known);
  // yaml-cpp keeps every duplicate of a key while rosparam keeps the last one: both are refused, so that the
  // file and the parameter server cannot disagree.
  std::set<std::string> seen_sections;
  for (const auto& entry : root) {
    if (!entry.first.IsScalar()) {
      errors.push_back("a section name must be a plain word" + lineOf(entry.first));
      continue;
    }
    const std::string section = entry.first.as<std::string>();
    if (!seen_sections.insert(section).second) {
      errors.push_back(section + ": duplicate section" + lineOf(entry.first));
      continue;
    }
    const auto it = std::find(known.sections.begin(), known.sections.end(), section);
    if (it == known.sections.end()) {
      errors.push_back(section + ": unknown section" + suggestion(section, known.sections) +
                       lineOf(entry.first));
      continue;
    }
    if (!entry.second.IsMap()) continue;  // reported by the parser
    const std::vector<std::string>& keys = known.keys[it - known.sections.begin()];
    std::set<std::string> seen_keys;
    for (const auto& kv : entry.second) {
      if (!kv.first.IsScalar()) {
        errors.push_back(section + ": a key must be a plain word" + lineOf(kv.first));
        continue;
      }
      const std::string key = kv.first.as<std::string>();
      if (!seen_keys.insert(key).second)
        errors.push_back(section + "." + key + ": duplicate key" + lineOf(kv.first));
      else if (std::find(keys.begin(), keys.end(), key) == keys.end())
        errors.push_back(section + "." + key + ": unknown key" + suggestion(key, keys) + lineOf(kv.first));
    }
  }

  Parser parser(root, &errors);
  config_detail::forEachField(config, parser);

  // A value that failed to parse kept its (valid) default, so the range checks never report a key twice.
  for (std::string& e : config.validationErrors()) errors.push_back(std::move(e));
  if (!errors.empty()) throw ConfigError(std::move(errors));
  return config;
}

VoConfig loadVoConfig(const std::string& yaml_path) {
  std::error_code ec;
  if (std::filesystem::is_directory(yaml_path, ec))
    throw ConfigError({yaml_path + ": is a folder, not a YAML file"});
  std::ifstream file(yaml_path);
  if (!file) throw ConfigError({yaml_path + ": cannot open the file"});
  std::stringstream text;
  text << file.rdbuf();
  try {
    return parseVoConfig(text.str());
  } catch (const ConfigError& e) {
    std::vector<std::string> problems;
    for (const std::string& p : e.problems()) problems.push_back(yaml_path + ": " + p);
    throw ConfigError(std::move(problems));
  }
}

std::string VoConfig::dump() const {
  Dumper dumper;
  dumper.out << "# planetary_vo VO configuration in effect (keys documented in config/default.yaml)\n";
  config_detail::forEachField(*this, dumper);
  return dumper.out.str();
}

}  // namespace planetary_vo
