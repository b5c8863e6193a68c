#pragma once
/// @file config_yaml.h
/// YAML -> VoConfig. Keys that are absent keep their default (the member initialisers in config.h); keys that
/// are unknown, of the wrong type or out of range are all reported together in one ConfigError, each as
/// `section.key: what is wrong`, with a "did you mean" hint for near-miss spellings.

#include <string>

#include "planetary_vo/vo/config.h"

namespace planetary_vo {

/// @brief Parses YAML text into a validated VoConfig.
/// @param yaml_text the document; an empty document yields the defaults.
/// @throws ConfigError naming every unknown section or key, every value of the wrong type, every range
/// violation
///         (VoConfig::validationErrors()) and YAML syntax errors with their line.
VoConfig parseVoConfig(const std::string& yaml_text);

/// @brief Reads and parses a YAML file; as parseVoConfig(), with the path prefixed to the error message.
/// @throws ConfigError also when the file cannot be read.
VoConfig loadVoConfig(const std::string& yaml_path);

}  // namespace planetary_vo
