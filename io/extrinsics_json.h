// Extrinsics files (JSON): one object per camera serial holding its 4x4 row-major
// T_world_camera, plus an optional "_meta" object (../shared/docs/formats.md, docs/formats.md).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/types.h"

namespace rigfit {

/// The key of the metadata object in an extrinsics file; every other top-level key is a camera.
inline constexpr const char* kExtrinsicsMetaKey = "_meta";

/// An extrinsics file as read.
struct ExtrinsicsDocument {
  /// T_world_camera per serial; rotation blocks orthonormal to double round-off (each
  /// projected onto SO(3)).
  PoseMap poses;
  /// The whole file as read, unknown keys and "_meta" included: pass it as `base` to
  /// WriteExtrinsics to preserve them.
  nlohmann::json document;
  /// One line per rotation that was re-orthonormalised (naming file, serial and deviation).
  std::vector<std::string> warnings;
};

/// Reads an extrinsics file. Throws InputError naming the file (and the serial and field) on:
/// unreadable file, malformed JSON (with the parse position), a top level that is not an
/// object, a key repeated within an object (a duplicated serial), an empty serial, a camera value
/// that is not an object or lacks T_world_camera, a matrix that is not 4x4 finite numbers, a last
/// row other than [0, 0, 0, 1], and a rotation block R with ||R^T R - I|| (max norm) > 1e-3 or
/// det(R) <= 0. Smaller deviations are removed by projecting R onto SO(3) (SVD); those above 1e-6
/// (limited-precision pose files, e.g. 7-Scenes' at ~3e-4) are reported in `warnings`.
ExtrinsicsDocument ReadExtrinsics(const std::string& path);

/// ReadExtrinsics from text (e.g. a file already in memory, or a fuzzer's bytes); path stands
/// for the file name in messages.
ExtrinsicsDocument ParseExtrinsics(const std::string& json_text, const std::string& path);

/// The JSON value of a pose: 4x4 row-major nested arrays, last row exactly [0, 0, 0, 1].
nlohmann::json PoseToJson(const Pose& T_world_camera);

/// Writes `base` (e.g. the input document; may be an empty object) with T_world_camera of
/// every pose in `poses` set (other keys of each camera object preserved), plus `meta` merged
/// into base["_meta"] (keys of meta replace). Pretty-printed (indent 2), keys sorted, doubles
/// written with enough digits to read back bit-exactly. Atomic (temporary file in the same
/// directory + rename). Throws InputError if `path` is the same file as any of `inputs`, if
/// its directory does not exist, or if a pose is not finite or a serial is empty or "_meta".
void WriteExtrinsics(const std::string& path, const PoseMap& poses,
                     const nlohmann::json& base = nlohmann::json::object(),
                     const nlohmann::json& meta = nlohmann::json::object(),
                     const std::vector<std::string>& inputs = {});

}  // namespace rigfit
