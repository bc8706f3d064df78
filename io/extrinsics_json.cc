#include "io/extrinsics_json.h"

#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/errors.h"
#include "io/atomic_file.h"
#include "io/pose_matrix.h"
#include "io/read_file.h"

namespace rigfit {
namespace {

using Json = nlohmann::json;

const char* kPoseKey = "T_world_camera";

Pose ParsePose(const Json& matrix, const std::string& where, std::vector<std::string>* warnings) {
  const std::string field = where + ": " + kPoseKey;
  if (!matrix.is_array() || matrix.size() != 4) {
    throw InputError(field + ": expected a 4x4 array of numbers (4 rows)");
  }
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r) {
    const Json& row = matrix[r];
    if (!row.is_array() || row.size() != 4) {
      throw InputError(field + ": row " + std::to_string(r) + " is not an array of 4 numbers");
    }
    for (int c = 0; c < 4; ++c) {
      if (!row[c].is_number()) {
        throw InputError(field + ": entry [" + std::to_string(r) + "][" + std::to_string(c) +
                         "] is not a number");
      }
      M(r, c) = row[c].get<double>();
      if (!std::isfinite(M(r, c))) {
        throw InputError(field + ": entry [" + std::to_string(r) + "][" + std::to_string(c) +
                         "] is not finite");
      }
    }
  }
  return PoseFromMatrix(M, field, warnings);
}

std::string ParseErrorText(const Json::exception& e) {
  // Drop nlohmann's "[json.exception.parse_error.101] " prefix; keep "parse error at line ..".
  const std::string what = e.what();
  const size_t end = what.find("] ");
  return end == std::string::npos ? what : what.substr(end + 2);
}

/// Json::parse, except that a key repeated within one object is an error: nlohmann would keep
/// the last value silently, and a duplicated serial (or T_world_camera) is ambiguous.
Json ParseRejectingDuplicateKeys(const std::string& text, const std::string& path) {
  std::vector<std::set<std::string>> open_objects;  // the keys seen so far in each
  std::vector<std::string> object_names;            // the key each open object is under
  std::string last_key;
  const Json::parser_callback_t check = [&](int depth, Json::parse_event_t event, Json& parsed) {
    switch (event) {
      case Json::parse_event_t::object_start:
        open_objects.emplace_back();
        object_names.push_back(depth == 0 ? "" : last_key);
        break;
      case Json::parse_event_t::object_end:
        open_objects.pop_back();
        object_names.pop_back();
        break;
      case Json::parse_event_t::key:
        last_key = parsed.get<std::string>();
        if (!open_objects.back().insert(last_key).second) {
          throw InputError(path + ": duplicate key \"" + last_key + "\"" +
                           (open_objects.size() == 1 ? " (camera serials must be unique)"
                                                     : " in \"" + object_names.back() + "\""));
        }
        break;
      default:
        break;
    }
    return true;
  };
  return Json::parse(text, check);
}

}  // namespace

Json PoseToJson(const Pose& T_world_camera) {
  const Eigen::Matrix4d M = T_world_camera.matrix();
  Json rows = Json::array();
  for (int r = 0; r < 3; ++r) rows.push_back({M(r, 0), M(r, 1), M(r, 2), M(r, 3)});
  rows.push_back({0.0, 0.0, 0.0, 1.0});
  return rows;
}

ExtrinsicsDocument ReadExtrinsics(const std::string& path) {
  return ParseExtrinsics(ReadWholeFile(path), path);
}

ExtrinsicsDocument ParseExtrinsics(const std::string& json_text, const std::string& path) {
  ExtrinsicsDocument result;
  try {
    result.document = ParseRejectingDuplicateKeys(json_text, path);
  } catch (const Json::exception& e) {  // parse_error, or out_of_range for 1e999
    throw InputError(path + ": malformed JSON: " + ParseErrorText(e));
  }
  if (!result.document.is_object()) {
    throw InputError(path + ": expected a JSON object with one key per camera serial, got " +
                     std::string(result.document.type_name()));
  }
  for (const auto& [serial, camera] : result.document.items()) {
    if (serial == kExtrinsicsMetaKey) continue;
    if (serial.empty()) throw InputError(path + ": empty camera serial \"\"");
    const std::string where = path + ": camera " + serial;
    if (!camera.is_object()) {
      throw InputError(where + ": expected an object with " + kPoseKey + ", got " +
                       camera.type_name());
    }
    const auto matrix = camera.find(kPoseKey);
    if (matrix == camera.end()) throw InputError(where + ": missing " + kPoseKey);
    result.poses[serial] = ParsePose(*matrix, where, &result.warnings);
  }
  return result;
}

void WriteExtrinsics(const std::string& path, const PoseMap& poses, const Json& base,
                     const Json& meta, const std::vector<std::string>& inputs) {
  RefuseToOverwriteInputs(path, inputs, "extrinsics");
  if (!(base.is_object() || base.is_null()) || !meta.is_object()) {
    throw std::invalid_argument("WriteExtrinsics: base and meta must be JSON objects");
  }
  Json document = base.is_null() ? Json::object() : base;
  for (const auto& [serial, T] : poses) {
    if (serial.empty() || serial == kExtrinsicsMetaKey) {
      throw InputError(path + ": cannot write a camera named \"" + serial + "\"");
    }
    if (!T.matrix().allFinite()) {
      throw InputError(path + ": camera " + serial + ": " + kPoseKey + " is not finite");
    }
    Json& camera = document[serial];
    if (!camera.is_object()) camera = Json::object();
    camera[kPoseKey] = PoseToJson(T);
  }
  if (!meta.empty()) {
    Json& meta_out = document[kExtrinsicsMetaKey];
    if (!meta_out.is_object()) meta_out = Json::object();
    for (const auto& [key, value] : meta.items()) meta_out[key] = value;
  }
  const std::string text = document.dump(2) + "\n";
  WriteTextFileAtomically(path, text);
}

}  // namespace rigfit
