#pragma once
/// \file
/// The device's origin kept in the state directory ([device] origin =
/// "persist"; docs/config.md, "Calibration"), so a restart finds it again
/// where the encoder allows: an absolute encoder, or a device that kept
/// power (and so kept counting) while hapticd was down. The file says
/// whose origin it is (driver, the device's identity, encoder kind, motion,
/// resolution): one written for another device, or another encoder, is
/// refused, not applied. Written atomically (a temporary file, fsync,
/// rename, fsync of the directory): a crash leaves the old file or the new,
/// never half of one.
///
///   # hapticd: the device's origin ...
///   [origin]
///   position = 0.785398163397448   # m or rad, in the device's own frame
///   unit = "rad"
///   set_by = "zero"                # or "homing" (with homing_method)
///   cycle = 1234
///   set_at = "2026-12-05T10:00:00Z"
///   [identity]
///   driver = "canopen"
///   device = "interface can0, node 1, vendor 0x..., serial 0x..."
///   encoder = "incremental"
///   motion = "rotary"
///   resolution = 0.000383495196971410
///
/// Bad input (a torn or edited file, another format) is refused with the
/// file, line and column, the key and what is accepted; never a crash.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace hapticd::daemon::config {

/// Who an origin belongs to: a stored one applies only to the same.
struct OriginIdentity {
  std::string driver;       ///< "canopen"
  std::string device;       ///< the driver's identity of the device (address, serial ...)
  std::string encoder;      ///< "incremental" or "absolute" ([device] encoder)
  std::string motion;       ///< "rotary" or "linear"
  double resolution = 0.0;  ///< m or rad per count (0: continuous)
  bool operator==(const OriginIdentity&) const = default;
};

struct OriginRecord {
  double position = 0.0;    ///< m or rad, subtracted from the device's readings
  std::string set_by;       ///< "zero" (device.zero) or "homing" (the device's own reference search)
  int homing_method = 0;    ///< with set_by = "homing" (CiA 402 0x6098)
  std::uint64_t cycle = 0;  ///< the loop cycle it was set at (0 for homing: before the loop)
  std::string set_at;       ///< UTC, ISO 8601
  OriginIdentity identity;
  bool operator==(const OriginRecord&) const = default;
};

/// A file that is not an origin this daemon wrote: what() is
/// "file:line:column: key ...; accepted: ...".
class OriginFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The file's text for `record` (numbers in the shortest form that reads back exactly).
std::string format_origin(const OriginRecord& record);
/// Parses an origin file's text; `source` names it in messages. Throws OriginFileError.
OriginRecord parse_origin(std::string_view text, std::string_view source);

/// Why `stored` does not apply to `device` ("" when it does): the first field that differs, both values.
std::string identity_mismatch(const OriginIdentity& stored, const OriginIdentity& device);

/// Reads and parses `path`; nothing when it does not exist. Throws
/// OriginFileError when it cannot be read or parsed.
std::optional<OriginRecord> load_origin_file(const std::filesystem::path& path);
/// Writes `record` to `path` atomically (temporary file in the same
/// directory, fsync, rename, fsync of the directory). Throws
/// std::system_error naming the step and the path.
void write_origin_file(const std::filesystem::path& path, const OriginRecord& record);

/// The current UTC time as "2026-12-05T10:00:00Z".
std::string utc_now();

}  // namespace hapticd::daemon::config
