#pragma once
/// \file
/// CiA 301 PDOs: the communication parameter (RPDO n: 0x1400 + n - 1,
/// TPDO n: 0x1800 + n - 1; sub 1 COB-ID, sub 2 transmission type), the
/// mapping parameter (RPDO n: 0x1600 + n - 1, TPDO n: 0x1A00 + n - 1; sub 0
/// the number of mapped objects, subs 1..8 one entry each: index << 16 |
/// sub-index << 8 | length in bits), the standard mapping procedure, and the
/// payload of a mapped PDO (entries packed in order, little-endian).

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "drivers/canopen/301/frame.hpp"
#include "drivers/canopen/301/object.hpp"

namespace hapticd::drivers::canopen::cia301 {

/// RPDO: received (consumed) by the device; TPDO: transmitted (produced) by it.
enum class PdoDirection : std::uint8_t { receive, transmit };

constexpr std::uint16_t pdo_communication_index(PdoDirection d, int n) noexcept {
  return static_cast<std::uint16_t>((d == PdoDirection::receive ? 0x1400 : 0x1800) + (n - 1));
}
constexpr std::uint16_t pdo_mapping_index(PdoDirection d, int n) noexcept {
  return static_cast<std::uint16_t>((d == PdoDirection::receive ? 0x1600 : 0x1A00) + (n - 1));
}
/// Which PDO a communication or mapping index belongs to.
struct PdoRef {
  PdoDirection direction;
  int number;  ///< 1..512
  bool mapping;
};
std::optional<PdoRef> pdo_of_index(std::uint16_t index) noexcept;

/// COB-ID entry (communication parameter sub 1): bit 31 set = the PDO does
/// not exist / is not valid; bit 30 set = no RTR allowed; bit 29 set = 29-bit id.
inline constexpr std::uint32_t pdo_cob_not_valid = 1U << 31;
inline constexpr std::uint32_t pdo_cob_no_rtr = 1U << 30;
inline constexpr std::uint32_t pdo_cob_extended = 1U << 29;
struct PdoCobId {
  std::uint32_t can_id = 0;  ///< 11-bit identifier
  bool valid = false;
  bool rtr_allowed = false;
  friend bool operator==(const PdoCobId&, const PdoCobId&) = default;
};
constexpr std::uint32_t encode_pdo_cob_id(const PdoCobId& c) noexcept {
  return (c.can_id & can_sff_mask) | (c.valid ? 0U : pdo_cob_not_valid) |
         (c.rtr_allowed ? 0U : pdo_cob_no_rtr);
}
constexpr PdoCobId decode_pdo_cob_id(std::uint32_t v) noexcept {
  return {v & can_sff_mask, (v & pdo_cob_not_valid) == 0, (v & pdo_cob_no_rtr) == 0};
}

/// Transmission type (communication parameter sub 2).
namespace transmission_type {
inline constexpr std::uint8_t synchronous_acyclic = 0;  ///< on SYNC, when the data changed
inline constexpr std::uint8_t every_sync = 1;           ///< 1..240: every n-th SYNC
inline constexpr std::uint8_t max_cyclic = 240;
inline constexpr std::uint8_t event_manufacturer = 254;
inline constexpr std::uint8_t event_profile = 255;
}  // namespace transmission_type
constexpr bool is_synchronous(std::uint8_t type) noexcept { return type <= transmission_type::max_cyclic; }

struct MappingEntry {
  ObjectAddress object;
  std::uint8_t bits = 0;  ///< 8, 16 or 32 here (whole bytes)
  friend bool operator==(const MappingEntry&, const MappingEntry&) = default;
};
constexpr std::uint32_t encode_mapping(const MappingEntry& e) noexcept {
  return (static_cast<std::uint32_t>(e.object.index) << 16) |
         (static_cast<std::uint32_t>(e.object.sub) << 8) | e.bits;
}
constexpr MappingEntry decode_mapping(std::uint32_t v) noexcept {
  return {{static_cast<std::uint16_t>(v >> 16), static_cast<std::uint8_t>(v >> 8)},
          static_cast<std::uint8_t>(v)};
}

inline constexpr std::size_t max_pdo_entries = 8;
inline constexpr std::size_t max_pdo_bits = 64;

/// A PDO's mapping: up to 8 whole-byte entries, at most 8 bytes in all.
class PdoLayout {
 public:
  PdoLayout() = default;
  /// Throws std::invalid_argument if more than 8 entries, an entry not 8/16/32 bits, or more than 64 bits.
  explicit PdoLayout(std::span<const MappingEntry> entries);
  std::size_t count() const noexcept { return count_; }
  const MappingEntry& entry(std::size_t i) const noexcept { return entries_[i]; }
  std::span<const MappingEntry> entries() const noexcept { return {entries_.data(), count_}; }
  std::size_t bytes() const noexcept { return bytes_; }
  std::size_t offset(std::size_t i) const noexcept { return offsets_[i]; }
  /// Index of the entry mapping `object`, if mapped.
  std::optional<std::size_t> find(ObjectAddress object) const noexcept;

  /// Packs raw values (one per entry, low bytes used) into a frame's data.
  Frame pack(std::uint32_t can_id, std::span<const std::uint32_t> values) const noexcept;
  /// Unpacks a received PDO. False if it carries fewer bytes than mapped
  /// (CiA 301: not processed, EMCY 0x8210); extra bytes are ignored.
  bool unpack(const Frame& frame, std::span<std::uint32_t> values) const noexcept;

 private:
  std::array<MappingEntry, max_pdo_entries> entries_{};
  std::array<std::uint8_t, max_pdo_entries> offsets_{};
  std::size_t count_ = 0;
  std::size_t bytes_ = 0;
};

/// One expedited SDO write.
struct SdoWrite {
  ObjectAddress address;
  std::uint32_t value = 0;
  std::uint8_t size = 0;  ///< bytes
  friend bool operator==(const SdoWrite&, const SdoWrite&) = default;
};

struct PdoConfiguration {
  PdoDirection direction = PdoDirection::receive;
  int number = 1;            ///< 1..4 in the predefined set
  std::uint32_t can_id = 0;  ///< 11-bit COB-ID
  std::uint8_t transmission_type = transmission_type::every_sync;
  PdoLayout layout;
};
/// The standard procedure (CiA 301, PDO mapping parameter): 1. make the PDO
/// not valid (COB-ID with bit 31 set); 2. set the transmission type; 3. zero
/// the mapping count (sub 0); 4. write the entries (subs 1..n); 5. write the
/// count n; 6. make the PDO valid again (bit 31 clear). A disabled PDO
/// (empty layout) stops after step 3.
std::vector<SdoWrite> pdo_configuration_sequence(const PdoConfiguration& pdo);
/// The writes that leave a PDO not valid (used for a PDO we do not use).
std::vector<SdoWrite> pdo_disable_sequence(PdoDirection direction, int number, std::uint32_t can_id);

}  // namespace hapticd::drivers::canopen::cia301
