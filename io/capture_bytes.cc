#include "io/capture_bytes.h"

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <utility>
#include <vector>

namespace rigfit {
namespace {

/// Writes and reads the fields of a capture in order, each vector after its size as a
/// uint64.
class CaptureBytes {
 public:
  static std::string Encode(const RigCapture& capture) {
    CaptureBytes out;
    out.Put<std::uint64_t>(capture.cameras.size());
    for (const CameraCapture& c : capture.cameras) {
      out.PutVector(std::vector<char>(c.serial.begin(), c.serial.end()));
      out.Put(c.width);
      out.Put(c.height);
      out.PutVector(c.depth_m);
      out.Put(c.intrinsics);
      out.PutVector(c.confidence);
      out.PutVector(c.color);
      out.Put(c.glitch_depth_samples);
      out.Put(c.baseline_m);
      out.PutVector(c.points);
      out.PutVector(c.normals);
    }
    return std::move(out.bytes_);
  }

  /// Throws std::runtime_error on bytes that Encode did not write (a truncated transfer).
  static RigCapture Decode(std::string bytes) {
    CaptureBytes in;
    in.bytes_ = std::move(bytes);
    RigCapture capture;
    // The fewest bytes a camera takes: five sizes, width, height and the intrinsics.
    constexpr std::size_t kMinCameraBytes =
        5 * sizeof(std::uint64_t) + 2 * sizeof(int) + sizeof(PinholeIntrinsics);
    const std::uint64_t count = in.Get<std::uint64_t>();
    if (count > (in.bytes_.size() - in.read_) / kMinCameraBytes) {
      throw std::runtime_error("truncated");
    }
    capture.cameras.resize(count);
    for (CameraCapture& c : capture.cameras) {
      const std::vector<char> serial = in.GetVector<char>();
      c.serial.assign(serial.begin(), serial.end());
      c.width = in.Get<int>();
      c.height = in.Get<int>();
      c.depth_m = in.GetVector<float>();
      c.intrinsics = in.Get<PinholeIntrinsics>();
      c.confidence = in.GetVector<float>();
      c.color = in.GetVector<std::uint8_t>();
      c.glitch_depth_samples = in.Get<std::int64_t>();
      c.baseline_m = in.Get<double>();
      c.points = in.GetVector<Vec3>();
      c.normals = in.GetVector<Vec3>();
    }
    if (in.read_ != in.bytes_.size()) throw std::runtime_error("trailing bytes");
    return capture;
  }

 private:
  template <typename T>
  void Put(const T& value) {
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  template <typename V>
  void PutVector(const V& values) {
    Put<std::uint64_t>(values.size());
    if (values.empty()) return;  // data() may be null
    bytes_.append(reinterpret_cast<const char*>(values.data()),
                  values.size() * sizeof(typename V::value_type));
  }
  void Take(void* to, std::size_t size) {
    if (size > bytes_.size() - read_) throw std::runtime_error("truncated");
    if (size == 0) return;  // `to` may be an empty vector's null data()
    std::memcpy(to, bytes_.data() + read_, size);
    read_ += size;
  }
  template <typename T>
  T Get() {
    T value;
    Take(&value, sizeof(T));
    return value;
  }
  template <typename T>
  std::vector<T> GetVector() {
    const std::uint64_t size = Get<std::uint64_t>();
    if (size > (bytes_.size() - read_) / sizeof(T)) throw std::runtime_error("truncated");
    std::vector<T> values(size);
    Take(values.data(), size * sizeof(T));
    return values;
  }

  std::string bytes_;
  std::size_t read_ = 0;
};

}  // namespace

std::string EncodeCapture(const RigCapture& capture) { return CaptureBytes::Encode(capture); }

RigCapture DecodeCapture(std::string bytes) { return CaptureBytes::Decode(std::move(bytes)); }

}  // namespace rigfit
