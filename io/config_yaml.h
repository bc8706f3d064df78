// The YAML config of `rigfit refine`: sections ground:, region:, icp: whose keys are exactly
// the member names of the structs in options/refine_options.h (docs/config.md lists every key).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "options/refine_options.h"

namespace rigfit {

/// Loads a YAML config onto the defaults of RefineOptions: only keys present override.
/// Throws InputError listing every problem, one line each as "<file>:<line>: <key>: <what>",
/// for: YAML syntax errors, unknown keys (with "did you mean 'x'?" for a near miss or a key of
/// another section), duplicate keys, wrong types (a string or list where a number is expected,
/// a non-integer for an integer, ...), unknown enum values (listing the valid ones) and every
/// OptionProblems() of the result. An empty file gives the defaults.
RefineOptions LoadConfig(const std::string& path);

/// LoadConfig from text; source_name stands for the file name in messages.
RefineOptions ParseConfig(const std::string& yaml_text, const std::string& source_name);

/// The YAML text of options: every key in the layout LoadConfig reads, with a comment per key,
/// numbers written so that they parse back exactly. ParseConfig(ConfigToYaml(o)) == o.
std::string ConfigToYaml(const RefineOptions& options);

/// The same values as JSON ({"ground": {...}, "region": {...}, "icp": {...}}, enums as their
/// config strings), e.g. for the config echo in the output's _meta.
nlohmann::json ConfigToJson(const RefineOptions& options);

/// The method of a config name (point_to_plane, gicp), as icp.method reads it; InputError listing
/// the valid names for another (for surface_bundle, saying where the surface bundle went).
RegistrationMethod RegistrationMethodNamed(const std::string& name);

/// The config names of the registration methods (icp.method), in order: point_to_plane, gicp.
std::vector<std::string> RegistrationMethodNames();

/// The config name of a method (icp.method), the inverse of RegistrationMethodNamed (as the
/// config writer spells it: an out-of-range value as its number).
std::string RegistrationMethodName(RegistrationMethod method);

}  // namespace rigfit
