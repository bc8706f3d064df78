// A rig capture as bytes, to pass between processes of one machine (the guarded capture
// read of io/capture_h5.h sends it from its child through a pipe). Native byte order and
// sizes: not a file format.
#pragma once

#include <string>

#include "core/types.h"

namespace rigfit {

/// Every field of every camera, in order; each vector after its size as a uint64.
std::string EncodeCapture(const RigCapture& capture);

/// The capture EncodeCapture wrote. Throws std::runtime_error on any other bytes: cut short
/// anywhere, followed by more, or with a count or size larger than the bytes left could
/// hold (refused before anything is allocated for it).
RigCapture DecodeCapture(std::string bytes);

}  // namespace rigfit
